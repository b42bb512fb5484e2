//! Uniform cubic B-spline references: replay of recorded ground truth (TUM / EuRoC ASL) and
//! random smooth waypoints.
//!
//! The spline has 7 channels: position (3) and the attitude quaternion's components (4, signs
//! made continuous). The attitude is the normalized quaternion spline `q̂ = q/|q|`, whose rates
//! have closed forms: `ω_b = 2·Im(q* ⊗ q̇)/|q|²` and
//! `ω̇_b = 2·Im(q* ⊗ q̈)/|q|² − 2(q·q̇)/|q|²·ω_b`; world-frame rates are `R ω_b`, `R ω̇_b`.
//!
//! Recorded files are fitted by linear least squares (all samples, knots every `knot_spacing_s`,
//! a tiny second-difference penalty for conditioning), which smooths the recorder's noise so the
//! reference's accelerations are those of the motion, not of the noise.

use super::reference::{RefState, Reference, attitude_from_ypr};
use crate::rng::sensor_rng;
use nalgebra::{Quaternion, UnitQuaternion, Vector3, Vector4};
use rand::RngExt;

/// Number of spline channels: px py pz qw qx qy qz.
const DIM: usize = 7;

/// A uniform cubic B-spline with 7 channels (position + quaternion components).
///
/// Control point `k` sits at time `t0 + (k − 1)·dt`; the spline is valid on
/// `[t0, t0 + (n − 3)·dt]` and is extrapolated at constant rates outside.
#[derive(Clone, Debug)]
pub struct PoseSpline {
    t0: f64,
    dt: f64,
    ctrl: Vec<[f64; DIM]>,
}

/// Uniform cubic B-spline basis and its first two derivatives (w.r.t. `u`) at `u ∈ [0, 1]`.
fn basis(u: f64) -> ([f64; 4], [f64; 4], [f64; 4]) {
    let u2 = u * u;
    let u3 = u2 * u;
    let om = 1.0 - u;
    (
        [
            om * om * om / 6.0,
            (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
            (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
            u3 / 6.0,
        ],
        [
            -0.5 * om * om,
            0.5 * (3.0 * u2 - 4.0 * u),
            0.5 * (-3.0 * u2 + 2.0 * u + 1.0),
            0.5 * u2,
        ],
        [om, 3.0 * u - 2.0, -3.0 * u + 1.0, u],
    )
}

/// Errors while reading or fitting a trajectory.
#[derive(Debug, thiserror::Error)]
pub enum TrajectoryError {
    /// The file could not be read.
    #[error("cannot read trajectory {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A line could not be parsed.
    #[error("trajectory line {line}: {msg}")]
    Parse {
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        msg: String,
    },
    /// Too few samples, or timestamps not increasing.
    #[error("trajectory unusable: {0}")]
    Unusable(String),
}

/// One recorded pose sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseSample {
    /// Time (s) in the file's clock.
    pub t: f64,
    /// Position (m).
    pub p: Vector3<f64>,
    /// Attitude `R_w_b`.
    pub q: UnitQuaternion<f64>,
}

/// A recording as written: samples with their stamps in the file's own unit, and the line each
/// came from.
#[derive(Clone, Debug, PartialEq)]
pub struct Recording {
    /// Samples; `t` in file units (TUM: as written; ASL: nanoseconds).
    pub samples: Vec<PoseSample>,
    /// 1-based line of each sample.
    pub lines: Vec<usize>,
    /// Whether the file is EuRoC ASL csv (stamps in nanoseconds by the format).
    pub asl: bool,
}

/// Parses a TUM trajectory (`t tx ty tz qx qy qz qw`, `#` comments, spaces) or an EuRoC ASL
/// ground-truth csv (`t_ns, px, py, pz, qw, qx, qy, qz, …`, comma separated, header starting
/// with `#`), keeping the stamps in the file's unit. The format is recognized per line by the
/// presence of commas. Quaternions must be unit to 1 %.
pub fn parse_recording(text: &str) -> Result<Recording, TrajectoryError> {
    let mut out = Vec::new();
    let mut lines = Vec::new();
    let mut asl_any = false;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let perr = |msg: String| TrajectoryError::Parse { line: i + 1, msg };
        let asl = line.contains(',');
        asl_any |= asl;
        let fields: Vec<&str> = if asl {
            line.split(',').map(str::trim).collect()
        } else {
            line.split_whitespace().collect()
        };
        if fields.len() < 8 {
            return Err(perr(format!("expected ≥ 8 fields, got {}", fields.len())));
        }
        let mut v = [0.0; 8];
        for (k, f) in fields[..8].iter().enumerate() {
            v[k] = f
                .parse::<f64>()
                .map_err(|e| perr(format!("field {}: {e}", k + 1)))?;
        }
        if v.iter().any(|x| !x.is_finite()) {
            return Err(perr("non-finite value".into()));
        }
        let q = if asl {
            Quaternion::new(v[4], v[5], v[6], v[7])
        } else {
            Quaternion::new(v[7], v[4], v[5], v[6])
        };
        if (q.norm() - 1.0).abs() > 0.01 {
            return Err(perr(format!(
                "quaternion norm {:.4}: expected a unit quaternion (to 1 %)",
                q.norm()
            )));
        }
        out.push(PoseSample {
            t: v[0],
            p: Vector3::new(v[1], v[2], v[3]),
            q: UnitQuaternion::new_normalize(q),
        });
        lines.push(i + 1);
    }
    if out.len() < 4 {
        return Err(TrajectoryError::Unusable(format!(
            "{} samples, need at least 4",
            out.len()
        )));
    }
    Ok(Recording {
        samples: out,
        lines,
        asl: asl_any,
    })
}

/// Parses a TUM (seconds) or EuRoC ASL (nanoseconds) trajectory into samples in seconds (see
/// [`parse_recording`]); stamps must increase strictly.
pub fn parse_trajectory(text: &str) -> Result<Vec<PoseSample>, TrajectoryError> {
    let rec = parse_recording(text)?;
    let scale = if rec.asl { 1e-9 } else { 1.0 };
    let out: Vec<PoseSample> = rec
        .samples
        .into_iter()
        .map(|s| PoseSample {
            t: s.t * scale,
            ..s
        })
        .collect();
    if let Some(i) = out.windows(2).position(|w| w[1].t <= w[0].t) {
        return Err(TrajectoryError::Parse {
            line: rec.lines[i + 1],
            msg: "timestamps must increase strictly".into(),
        });
    }
    Ok(out)
}

/// Symmetric positive-definite banded matrix (half bandwidth `B`) stored by rows of the lower
/// band, with an in-place Cholesky factorization and solve.
struct Banded<const B: usize> {
    n: usize,
    /// `a[i][k]` = A(i, i − k) for k = 0..=B.
    a: Vec<[f64; 4]>,
}

impl<const B: usize> Banded<B> {
    fn new(n: usize) -> Self {
        Self {
            n,
            a: vec![[0.0; 4]; n],
        }
    }
    fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        debug_assert!(i - j <= B);
        self.a[i][i - j] += v;
    }
    fn get(&self, i: usize, j: usize) -> f64 {
        if i - j > B { 0.0 } else { self.a[i][i - j] }
    }
    /// Cholesky `A = L Lᵀ` in place; `false` if not positive definite.
    fn factor(&mut self) -> bool {
        for i in 0..self.n {
            for j in i.saturating_sub(B)..=i {
                let mut s = self.get(i, j);
                for k in i.saturating_sub(B)..j {
                    s -= self.get(i, k) * self.get(j, k);
                }
                if i == j {
                    if s <= 0.0 {
                        return false;
                    }
                    self.a[i][0] = s.sqrt();
                } else {
                    self.a[i][i - j] = s / self.get(j, j);
                }
            }
        }
        true
    }
    fn solve(&self, b: &mut [f64]) {
        for i in 0..self.n {
            let mut s = b[i];
            for k in i.saturating_sub(B)..i {
                s -= self.get(i, k) * b[k];
            }
            b[i] = s / self.get(i, i);
        }
        for i in (0..self.n).rev() {
            let mut s = b[i];
            for k in i + 1..(i + B + 1).min(self.n) {
                s -= self.get(k, i) * b[k];
            }
            b[i] = s / self.get(i, i);
        }
    }
}

impl PoseSpline {
    /// A spline with the given control points (`[px, py, pz, qw, qx, qy, qz]`), control point
    /// `k` at `t0 + (k − 1)·dt`. Needs ≥ 4 control points.
    pub fn from_control_points(t0: f64, dt: f64, ctrl: Vec<[f64; 7]>) -> Self {
        assert!(ctrl.len() >= 4 && dt > 0.0);
        Self { t0, dt, ctrl }
    }

    /// Least-squares fit to pose samples with knots every `dt` seconds; time is shifted so the
    /// first sample is at `t = 0`. Quaternion signs are made continuous before fitting.
    pub fn fit(samples: &[PoseSample], dt: f64) -> Result<Self, TrajectoryError> {
        if samples.len() < 4 {
            return Err(TrajectoryError::Unusable(format!(
                "{} samples, need at least 4",
                samples.len()
            )));
        }
        let t_first = samples[0].t;
        let span = samples[samples.len() - 1].t - t_first;
        if !(dt.is_finite() && dt > 0.0 && span.is_finite() && span > 0.0) {
            return Err(TrajectoryError::Unusable(format!(
                "knot spacing {dt} s over a span of {span} s: both must be finite and > 0"
            )));
        }
        let knots = span / dt;
        if knots > crate::limits::MAX_SPLINE_KNOTS {
            return Err(TrajectoryError::Unusable(format!(
                "{knots:.3e} spline knots (span {span:.6e} s / knot spacing {dt} s) exceed the limit of {:.0e}: are the timestamps in seconds?",
                crate::limits::MAX_SPLINE_KNOTS
            )));
        }
        let n = knots.ceil() as usize + 3;
        let mut a = Banded::<3>::new(n);
        let mut rhs = vec![[0.0; DIM]; n];
        let mut prev = Vector4::new(1.0, 0.0, 0.0, 0.0);
        for s in samples {
            let qc = s.q.quaternion();
            let mut qv = Vector4::new(qc.w, qc.i, qc.j, qc.k);
            if qv.dot(&prev) < 0.0 {
                qv = -qv;
            }
            prev = qv;
            let y = [s.p.x, s.p.y, s.p.z, qv[0], qv[1], qv[2], qv[3]];
            let (seg, u) = Self::locate_raw(s.t - t_first, dt, n);
            let (b, _, _) = basis(u);
            for r in 0..4 {
                for c in 0..=r {
                    a.add(seg + r, seg + c, b[r] * b[c]);
                }
                for d in 0..DIM {
                    rhs[seg + r][d] += b[r] * y[d];
                }
            }
        }
        // Second-difference penalty μ·Σ|c[k−1] − 2c[k] + c[k+1]|² (conditioning only).
        let mu = 1e-6;
        for k in 1..n - 1 {
            let idx = [k - 1, k, k + 1];
            let w = [1.0, -2.0, 1.0];
            for r in 0..3 {
                for c in 0..3 {
                    if idx[r] >= idx[c] {
                        a.add(idx[r], idx[c], mu * w[r] * w[c]);
                    }
                }
            }
        }
        if !a.factor() {
            return Err(TrajectoryError::Unusable(
                "spline fit is singular (samples too sparse for the knot spacing)".into(),
            ));
        }
        let mut ctrl = vec![[0.0; DIM]; n];
        let mut col = vec![0.0; n];
        for d in 0..DIM {
            for k in 0..n {
                col[k] = rhs[k][d];
            }
            a.solve(&mut col);
            for k in 0..n {
                ctrl[k][d] = col[k];
            }
        }
        Ok(Self { t0: 0.0, dt, ctrl })
    }

    fn locate_raw(t: f64, dt: f64, n: usize) -> (usize, f64) {
        let x = (t / dt).max(0.0);
        let seg = (x.floor() as usize).min(n - 4);
        (seg, (x - seg as f64).min(1.0))
    }

    /// End of the valid range (s).
    pub fn end_time(&self) -> f64 {
        self.t0 + (self.ctrl.len() - 3) as f64 * self.dt
    }

    /// The 7 channels and their first two time derivatives at `t` (inside the range).
    fn eval(&self, t: f64) -> ([f64; DIM], [f64; DIM], [f64; DIM]) {
        let (seg, u) = Self::locate_raw(t - self.t0, self.dt, self.ctrl.len());
        let (b, db, ddb) = basis(u);
        let mut y = [0.0; DIM];
        let mut dy = [0.0; DIM];
        let mut ddy = [0.0; DIM];
        for j in 0..4 {
            let c = &self.ctrl[seg + j];
            for d in 0..DIM {
                y[d] += b[j] * c[d];
                dy[d] += db[j] * c[d] / self.dt;
                ddy[d] += ddb[j] * c[d] / (self.dt * self.dt);
            }
        }
        (y, dy, ddy)
    }
}

impl Reference for PoseSpline {
    /// Inside the range: the spline. Outside: extrapolated at the end's constant linear and
    /// angular velocity (zero accelerations), so a body started slightly before the first
    /// sample (the IMU pre-roll) joins a moving recording without a jolt.
    fn state(&self, t: f64) -> RefState {
        let (lo, hi) = (self.t0, self.end_time());
        if t < lo || t > hi {
            let te = t.clamp(lo, hi);
            let e = self.state_inside(te);
            let dt = t - te;
            let q = e.q * UnitQuaternion::from_scaled_axis(e.q.inverse() * e.omega_w * dt);
            return RefState {
                p: e.p + e.v * dt,
                v: e.v,
                a: Vector3::zeros(),
                q,
                omega_w: e.omega_w,
                alpha_w: Vector3::zeros(),
            };
        }
        self.state_inside(t)
    }

    fn duration(&self) -> Option<f64> {
        Some(self.end_time())
    }
}

impl PoseSpline {
    fn state_inside(&self, t: f64) -> RefState {
        let (y, dy, ddy) = self.eval(t);
        let q = Quaternion::new(y[3], y[4], y[5], y[6]);
        let qd = Quaternion::new(dy[3], dy[4], dy[5], dy[6]);
        let qdd = Quaternion::new(ddy[3], ddy[4], ddy[5], ddy[6]);
        let n2 = q.norm_squared();
        let omega_b = (q.conjugate() * qd).imag() * (2.0 / n2);
        let alpha_b = (q.conjugate() * qdd).imag() * (2.0 / n2) - omega_b * (2.0 * q.dot(&qd) / n2);
        let qu = UnitQuaternion::new_normalize(q);
        RefState {
            p: Vector3::new(y[0], y[1], y[2]),
            v: Vector3::new(dy[0], dy[1], dy[2]),
            a: Vector3::new(ddy[0], ddy[1], ddy[2]),
            q: qu,
            omega_w: qu * omega_b,
            alpha_w: qu * alpha_b,
        }
    }
}

/// Replay of a recorded trajectory: the file's samples least-squares fitted by a [`PoseSpline`],
/// time shifted so the first sample is at `t = 0`.
#[derive(Clone, Debug)]
pub struct Replay {
    /// The fitted spline.
    pub spline: PoseSpline,
    /// File time (s) of the first sample (sim `t = 0`).
    pub t_file0: f64,
    /// The recorded samples (file clock).
    pub samples: Vec<PoseSample>,
}

impl Replay {
    /// Default knot spacing (s): resolves motion up to ≈ 5–10 Hz, smooths Vicon/Leica noise.
    pub const DEFAULT_KNOT_SPACING_S: f64 = 0.04;

    /// Fits recorded samples with knots every `knot_spacing_s`.
    pub fn from_samples(
        samples: Vec<PoseSample>,
        knot_spacing_s: f64,
    ) -> Result<Self, TrajectoryError> {
        let spline = PoseSpline::fit(&samples, knot_spacing_s)?;
        Ok(Self {
            spline,
            t_file0: samples[0].t,
            samples,
        })
    }

    /// The spline's state at a time of the file's clock (s).
    pub fn spline_state_at_file_time(&self, t_file: f64) -> RefState {
        self.spline.state(t_file - self.t_file0)
    }

    /// Largest position (m) and attitude (rad) difference between the spline and the recorded
    /// samples (the smoothing the fit applies).
    pub fn fit_residual_max(&self) -> (f64, f64) {
        let mut ep: f64 = 0.0;
        let mut er: f64 = 0.0;
        for s in &self.samples {
            let r = self.spline.state(s.t - self.t_file0);
            ep = ep.max((r.p - s.p).norm());
            er = er.max(r.q.angle_to(&s.q));
        }
        (ep, er)
    }
}

impl Reference for Replay {
    fn state(&self, t: f64) -> RefState {
        self.spline.state(t)
    }
    fn duration(&self) -> Option<f64> {
        self.spline.duration()
    }
}

/// Configuration of random smooth waypoints: control points drawn uniformly in a box.
#[derive(Clone, Debug, PartialEq)]
pub struct RandomWaypoints {
    /// Lower corner of the box the waypoints are drawn in (m).
    pub min: Vector3<f64>,
    /// Upper corner (m).
    pub max: Vector3<f64>,
    /// Time between waypoints (s); shorter is more aggressive.
    pub spacing_s: f64,
    /// Largest yaw change between consecutive waypoints (rad).
    pub max_yaw_step: f64,
    /// Largest roll/pitch (rad).
    pub max_tilt: f64,
    /// Length of the motion (s).
    pub duration_s: f64,
}

impl Default for RandomWaypoints {
    fn default() -> Self {
        Self {
            min: Vector3::new(-2.0, -2.0, 1.0),
            max: Vector3::new(2.0, 2.0, 2.0),
            spacing_s: 2.0,
            max_yaw_step: 0.8,
            max_tilt: 0.15,
            duration_s: 60.0,
        }
    }
}

impl RandomWaypoints {
    /// Aggressive preset: waypoints every 0.6 s with large yaw steps and tilts.
    pub fn aggressive() -> Self {
        Self {
            spacing_s: 0.6,
            max_yaw_step: 1.2,
            max_tilt: 0.4,
            ..Self::default()
        }
    }

    /// Builds the spline; the waypoints are the B-spline's control points, drawn from the
    /// stream `trajectory/waypoints` of `seed`.
    pub fn build(&self, seed: u64) -> PoseSpline {
        let mut rng = sensor_rng(seed, "trajectory/waypoints");
        let n = (self.duration_s / self.spacing_s).ceil() as usize + 3;
        let mut yaw: f64 = 0.0;
        let mut prev = Vector4::new(1.0, 0.0, 0.0, 0.0);
        let mut ctrl = Vec::with_capacity(n);
        for _ in 0..n {
            let mut p = [0.0; 3];
            for (i, pi) in p.iter_mut().enumerate() {
                *pi = rng.random_range(self.min[i]..=self.max[i]);
            }
            yaw += rng.random_range(-self.max_yaw_step..=self.max_yaw_step);
            let pitch = rng.random_range(-self.max_tilt..=self.max_tilt);
            let roll = rng.random_range(-self.max_tilt..=self.max_tilt);
            let q = attitude_from_ypr(yaw, pitch, roll);
            let qc = q.quaternion();
            let mut qv = Vector4::new(qc.w, qc.i, qc.j, qc.k);
            if qv.dot(&prev) < 0.0 {
                qv = -qv;
            }
            prev = qv;
            ctrl.push([p[0], p[1], p[2], qv[0], qv[1], qv[2], qv[3]]);
        }
        PoseSpline::from_control_points(0.0, self.spacing_s, ctrl)
    }
}
