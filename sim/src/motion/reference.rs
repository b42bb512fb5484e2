//! Reference trajectories the controller tracks: smooth generators and a time warp for a static
//! start. Replay of recorded files lives in [`super::spline`].

use nalgebra::{UnitQuaternion, Vector3};
use std::fmt::Debug;

/// The full kinematic state of a reference at one instant (world frame, z up).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefState {
    /// Position `p_w_b` (m).
    pub p: Vector3<f64>,
    /// Velocity (m/s).
    pub v: Vector3<f64>,
    /// Acceleration (m/s²).
    pub a: Vector3<f64>,
    /// Attitude `R_w_b`.
    pub q: UnitQuaternion<f64>,
    /// Angular velocity in the world frame (rad/s).
    pub omega_w: Vector3<f64>,
    /// Angular acceleration in the world frame (rad/s²).
    pub alpha_w: Vector3<f64>,
}

/// A smooth, time-parameterized reference motion (`t` in seconds from the start of the run).
pub trait Reference: Send + Sync + Debug {
    /// The reference state at time `t` (s). Defined for every `t`; outside
    /// [`Reference::duration`] implementations hold their end states.
    fn state(&self, t: f64) -> RefState;
    /// Length of the motion (s), or `None` for a motion without end.
    fn duration(&self) -> Option<f64>;
}

/// Angular velocity and acceleration (world frame) of an attitude function, by central
/// differences (step 1 ms, error O(h²) ≈ 1e-6 relative): used by the analytic generators, whose
/// attitude is a closed-form function of time.
pub fn attitude_derivatives(
    f: impl Fn(f64) -> UnitQuaternion<f64>,
    t: f64,
) -> (Vector3<f64>, Vector3<f64>) {
    let h = 1e-3;
    let omega = |t: f64| {
        let d = f(t + 0.5 * h) * f(t - 0.5 * h).inverse();
        d.scaled_axis() / h
    };
    let w = omega(t);
    let alpha = (omega(t + 0.5 * h) - omega(t - 0.5 * h)) / h;
    (w, alpha)
}

/// Attitude from yaw ψ (about z), pitch θ (about y), roll φ (about x): `Rz(ψ) Ry(θ) Rx(φ)`.
pub fn attitude_from_ypr(yaw: f64, pitch: f64, roll: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(roll, pitch, yaw)
}

/// A Lissajous curve with oscillating yaw, pitch and roll.
///
/// `p(t) = center + amplitude ⊙ sin(2π·freq_hz·t + phase)`; yaw `ψ(t) = yaw0 + yaw_rate·t +
/// yaw_amplitude·sin(2π·yaw_freq_hz·t)`, pitch and roll `tilt_amplitude·sin(…)` at `tilt_freq_hz`
/// with a quarter-period phase between them. Special cases: figure-eight, circle, aggressive.
#[derive(Clone, Debug, PartialEq)]
pub struct Lissajous {
    /// Centre of the curve (m).
    pub center: Vector3<f64>,
    /// Per-axis amplitude (m).
    pub amplitude: Vector3<f64>,
    /// Per-axis frequency (Hz).
    pub freq_hz: Vector3<f64>,
    /// Per-axis phase (rad).
    pub phase: Vector3<f64>,
    /// Initial yaw (rad).
    pub yaw0: f64,
    /// Constant yaw rate (rad/s).
    pub yaw_rate: f64,
    /// Yaw oscillation amplitude (rad).
    pub yaw_amplitude: f64,
    /// Yaw oscillation frequency (Hz).
    pub yaw_freq_hz: f64,
    /// Roll/pitch oscillation amplitude (rad).
    pub tilt_amplitude: f64,
    /// Roll/pitch oscillation frequency (Hz).
    pub tilt_freq_hz: f64,
    /// Length of the motion (s); `None` for endless.
    pub duration_s: Option<f64>,
}

impl Default for Lissajous {
    /// A gentle figure-eight in a room: 2 m × 1 m, 1.5 m high, 20 s period.
    fn default() -> Self {
        Self::figure_eight(Vector3::new(0.0, 0.0, 1.5), 2.0, 1.0, 20.0)
    }
}

impl Lissajous {
    /// Figure-eight of half-width `ax` (x) and half-height `ay` (y) at `center`, one loop per
    /// `period_s`, with a small vertical bob, yaw swinging ±0.6 rad and ±0.1 rad tilts.
    pub fn figure_eight(center: Vector3<f64>, ax: f64, ay: f64, period_s: f64) -> Self {
        let f = 1.0 / period_s;
        Self {
            center,
            amplitude: Vector3::new(ax, ay, 0.2),
            freq_hz: Vector3::new(f, 2.0 * f, 3.0 * f),
            phase: Vector3::zeros(),
            yaw0: 0.0,
            yaw_rate: 0.0,
            yaw_amplitude: 0.6,
            yaw_freq_hz: f,
            tilt_amplitude: 0.1,
            tilt_freq_hz: 2.0 * f,
            duration_s: None,
        }
    }

    /// Horizontal circle of `radius` at `center`, one turn per `period_s`, facing along the
    /// tangent (yaw rate = 2π/period).
    pub fn circle(center: Vector3<f64>, radius: f64, period_s: f64) -> Self {
        let f = 1.0 / period_s;
        Self {
            center,
            amplitude: Vector3::new(radius, radius, 0.0),
            freq_hz: Vector3::new(f, f, 0.0),
            phase: Vector3::new(std::f64::consts::FRAC_PI_2, 0.0, 0.0),
            yaw0: std::f64::consts::PI,
            yaw_rate: std::f64::consts::TAU * f,
            yaw_amplitude: 0.0,
            yaw_freq_hz: 0.0,
            tilt_amplitude: 0.0,
            tilt_freq_hz: 0.0,
            duration_s: None,
        }
    }

    /// Aggressive mode: a fast figure-eight (4 s period, 1.5 m × 1 m) with ±0.9 rad yaw and
    /// ±0.35 rad tilts — peak accelerations of several m/s² and rates above 2 rad/s.
    pub fn aggressive(center: Vector3<f64>) -> Self {
        let mut s = Self::figure_eight(center, 1.5, 1.0, 4.0);
        s.yaw_amplitude = 0.9;
        s.tilt_amplitude = 0.35;
        s
    }

    fn attitude(&self, t: f64) -> UnitQuaternion<f64> {
        let tau = std::f64::consts::TAU;
        let yaw =
            self.yaw0 + self.yaw_rate * t + self.yaw_amplitude * (tau * self.yaw_freq_hz * t).sin();
        let pitch = self.tilt_amplitude * (tau * self.tilt_freq_hz * t).sin();
        let roll = self.tilt_amplitude * (tau * self.tilt_freq_hz * t).cos() - self.tilt_amplitude;
        attitude_from_ypr(yaw, pitch, roll)
    }
}

impl Reference for Lissajous {
    fn state(&self, t: f64) -> RefState {
        let tt = match self.duration_s {
            Some(d) => t.clamp(0.0, d),
            None => t,
        };
        let moving = self.duration_s.is_none_or(|d| (0.0..=d).contains(&t));
        let tau = std::f64::consts::TAU;
        let mut p = self.center;
        let mut v = Vector3::zeros();
        let mut a = Vector3::zeros();
        for i in 0..3 {
            let w = tau * self.freq_hz[i];
            let arg = w * tt + self.phase[i];
            p[i] += self.amplitude[i] * arg.sin();
            v[i] = self.amplitude[i] * w * arg.cos();
            a[i] = -self.amplitude[i] * w * w * arg.sin();
        }
        let q = self.attitude(tt);
        let (mut omega_w, mut alpha_w) = attitude_derivatives(|s| self.attitude(s), tt);
        if !moving {
            v = Vector3::zeros();
            a = Vector3::zeros();
            omega_w = Vector3::zeros();
            alpha_w = Vector3::zeros();
        }
        RefState {
            p,
            v,
            a,
            q,
            omega_w,
            alpha_w,
        }
    }

    fn duration(&self) -> Option<f64> {
        self.duration_s
    }
}

/// The quintic smoothstep `s(x) = 6x⁵ − 15x⁴ + 10x³` on `[0, 1]`, its derivative `s'(x)` and its
/// integral `S(x) = ∫₀ˣ s = x⁶ − 3x⁵ + 2.5x⁴` (`S(1) = 1/2`: the smoothstep is symmetric).
fn smoothstep(x: f64) -> (f64, f64, f64) {
    (
        x * x * x * (10.0 + x * (-15.0 + 6.0 * x)),
        30.0 * x * x * (1.0 - x) * (1.0 - x),
        x.powi(4) * (2.5 + x * (-3.0 + x)),
    )
}

impl RefState {
    /// The state of a reference played through a time warp with rate `τ' = d1` and `τ'' = d2`
    /// (this state taken at `τ`): the chain rule, `v = v(τ)·τ'`, `a = a(τ)·τ'² + v(τ)·τ''`, the
    /// same for the attitude rates.
    fn time_warped(self, d1: f64, d2: f64) -> RefState {
        RefState {
            p: self.p,
            v: self.v * d1,
            a: self.a * d1 * d1 + self.v * d2,
            q: self.q,
            omega_w: self.omega_w * d1,
            alpha_w: self.alpha_w * d1 * d1 + self.omega_w * d2,
        }
    }
}

/// Static start: the body rests at the inner reference's initial pose for `hold_s`, then the
/// inner motion starts through a smooth time warp.
///
/// Time warp `τ(t)`: `τ = 0` for `t < hold_s`; over the next `ramp_s` the warp rate `τ'` rises
/// from 0 to 1 along the quintic smoothstep `s(x) = 6x⁵ − 15x⁴ + 10x³` (so `τ''` is continuous);
/// afterwards `τ' = 1`. The state is the chain rule: `v = v_ref(τ)·τ'`,
/// `a = a_ref(τ)·τ'² + v_ref(τ)·τ''` (the same for attitude rates). The inner reference
/// should start at rest or slowly for the ramp to look natural.
#[derive(Debug)]
pub struct StaticStart {
    /// The motion after the rest.
    pub inner: Box<dyn Reference>,
    /// Rest duration (s).
    pub hold_s: f64,
    /// Ramp duration (s), > 0.
    pub ramp_s: f64,
}

impl StaticStart {
    /// `(τ, τ', τ'')` at time `t`.
    fn warp(&self, t: f64) -> (f64, f64, f64) {
        let x = (t - self.hold_s) / self.ramp_s;
        if x <= 0.0 {
            (0.0, 0.0, 0.0)
        } else if x >= 1.0 {
            // ∫₀¹ s(x) dx = 1/2 (the smoothstep is symmetric).
            (t - self.hold_s - 0.5 * self.ramp_s, 1.0, 0.0)
        } else {
            let (s, ds, int) = smoothstep(x);
            (int * self.ramp_s, s, ds / self.ramp_s)
        }
    }
}

impl Reference for StaticStart {
    fn state(&self, t: f64) -> RefState {
        let (tau, d1, d2) = self.warp(t);
        self.inner.state(tau).time_warped(d1, d2)
    }

    fn duration(&self) -> Option<f64> {
        self.inner
            .duration()
            .map(|d| d + self.hold_s + 0.5 * self.ramp_s)
    }
}

/// One stop of [`Stops`]: the motion slows to rest from `at_s` over `ramp_s`, rests for
/// `duration_s` and speeds up again over `ramp_s`, then continues where it stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// Run time (s) at which the slow-down starts.
    pub at_s: f64,
    /// Time at rest (s).
    pub duration_s: f64,
    /// Slow-down and speed-up time (s), > 0.
    pub ramp_s: f64,
}

impl Stop {
    /// Run time (s) at which the motion is back to full speed.
    pub fn end_s(&self) -> f64 {
        self.at_s + self.duration_s + 2.0 * self.ramp_s
    }

    /// The interval `[start, end]` (s) during which the body is at rest.
    pub fn rest_s(&self) -> (f64, f64) {
        let start = self.at_s + self.ramp_s;
        (start, start + self.duration_s)
    }

    /// `(time lost so far, warp rate τ', τ'')` at run time `t`: the rate falls along the
    /// quintic smoothstep `1 − s(x)`, stays 0, and rises along `s(x)`.
    fn warp(&self, t: f64) -> (f64, f64, f64) {
        let (r, d) = (self.ramp_s, self.duration_s);
        let u = t - self.at_s;
        if u <= 0.0 {
            (0.0, 1.0, 0.0)
        } else if u < r {
            let (s, ds, int) = smoothstep(u / r);
            (r * int, 1.0 - s, -ds / r)
        } else if u <= r + d {
            (0.5 * r + (u - r), 0.0, 0.0)
        } else if u < 2.0 * r + d {
            let x = (u - r - d) / r;
            let (s, ds, int) = smoothstep(x);
            // Lost while speeding up: ∫ (1 − s) = x − S(x).
            (0.5 * r + d + r * (x - int), s, ds / r)
        } else {
            (r + d, 1.0, 0.0)
        }
    }
}

/// Stops inserted into a motion by a smooth time warp `τ(t)`: during each [`Stop`] the body
/// slows to rest, rests and resumes, with `τ'` and `τ''` continuous (so are velocity and
/// acceleration). Stops must be sorted and not overlap.
#[derive(Debug)]
pub struct Stops {
    /// The motion being stopped.
    pub inner: Box<dyn Reference>,
    /// The stops, sorted by `at_s`, each ending before the next starts.
    pub stops: Vec<Stop>,
}

impl Stops {
    /// `(τ, τ', τ'')` at run time `t`.
    fn warp(&self, t: f64) -> (f64, f64, f64) {
        let (mut lost, mut d1, mut d2) = (0.0, 1.0, 0.0);
        for s in &self.stops {
            let (l, r1, r2) = s.warp(t);
            lost += l;
            if t > s.at_s && t < s.end_s() {
                (d1, d2) = (r1, r2);
            }
        }
        (t - lost, d1, d2)
    }
}

impl Reference for Stops {
    fn state(&self, t: f64) -> RefState {
        let (tau, d1, d2) = self.warp(t);
        self.inner.state(tau).time_warped(d1, d2)
    }

    fn duration(&self) -> Option<f64> {
        let lost: f64 = self.stops.iter().map(|s| s.duration_s + s.ramp_s).sum();
        self.inner.duration().map(|d| d + lost)
    }
}
