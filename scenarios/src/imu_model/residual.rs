//! The IMU that the ground truth implies, and the measured IMU's relation to it.
//!
//! The ground-truth poses are fitted by the simulator's least-squares cubic B-spline
//! ([`sim::motion::PoseSpline`], the one that replays recordings) and differentiated:
//! `ω_b = R_wbᵀ·ω_w`, `f_b = R_wbᵀ(a_w − g)` with `g = (0, 0, −9.81)`, plus the ground truth's
//! biases (`b_w`, `b_a`, linearly interpolated). The residual is measured − implied.
//!
//! A spline through 20 Hz poses cannot follow motion above a few hertz: [`implied_bandwidth_hz`]
//! measures, for the ground truth's rate and the knot spacing, up to which frequency its first
//! and second derivatives are within 10 % of the true ones. Residual content above that is the
//! sensor's noise and the vehicle's vibration.

use estimator::imu::ImuSample;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::Serialize;
use sim::motion::{PoseSample, PoseSpline, Reference};

use crate::dataset::GroundTruthState;

/// Gravity in the world frame (m/s²).
pub const GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];
/// Shortest default spline knot spacing (s): the default is the ground truth's median period,
/// but no less than this, so that a fast ground truth's noise is not differentiated twice.
pub const MIN_DEFAULT_KNOT_SPACING_S: f64 = 0.05;
/// Rest: ground-truth speed below this (m/s; motion-capture velocities carry the noise of
/// their differentiation: EuRoC V1_01 at rest on the floor shows 3–6 mm/s on average, up to
/// 15 mm/s; `report.json`'s rest block counts a recording's rest with it too)…
pub const REST_SPEED_M_S: f64 = 0.02;
/// …and ground-truth angular rate below this (rad/s)…
pub const REST_RATE_RAD_S: f64 = 0.03;
/// …for at least this long (s).
pub const REST_MIN_S: f64 = 1.0;
/// A ground-truth interval longer than this many median periods is a gap (no implied IMU).
const GAP_FACTOR: f64 = 5.0;
/// Relative derivative error that bounds the implied IMU's valid bandwidth.
const BANDWIDTH_TOLERANCE: f64 = 0.1;

/// The ground-truth-implied IMU at each IMU sample.
#[derive(Clone, Debug, Default)]
pub struct Implied {
    /// Angular rate incl. the ground truth's gyro bias (rad/s).
    pub gyro: Vec<Vector3<f64>>,
    /// Specific force incl. the ground truth's accelerometer bias (m/s²).
    pub accel: Vec<Vector3<f64>>,
    /// The ground truth's gyro bias (rad/s).
    pub gyro_bias: Vec<Vector3<f64>>,
    /// Speed (m/s).
    pub speed: Vec<f64>,
    /// Angular rate magnitude without bias (rad/s).
    pub rate: Vec<f64>,
    /// Whether the sample lies inside the ground truth (not before, after or in a gap).
    pub covered: Vec<bool>,
}

/// The default knot spacing for ground truth every `period_s`.
pub fn default_knot_spacing_s(period_s: f64) -> f64 {
    period_s.max(MIN_DEFAULT_KNOT_SPACING_S)
}

fn median_period_s(gt: &[GroundTruthState]) -> f64 {
    let mut d: Vec<f64> = gt
        .windows(2)
        .map(|w| (w[1].t_ns - w[0].t_ns) as f64 * 1e-9)
        .collect();
    d.sort_by(f64::total_cmp);
    d.get(d.len() / 2).copied().unwrap_or(0.0)
}

/// The ground truth's median sample period (s) and its gaps (intervals longer than five
/// median periods).
pub fn gt_period_and_gaps(gt: &[GroundTruthState]) -> (f64, usize) {
    let p = median_period_s(gt);
    let gaps = gt
        .windows(2)
        .filter(|w| (w[1].t_ns - w[0].t_ns) as f64 * 1e-9 > GAP_FACTOR * p)
        .count();
    (p, gaps)
}

/// The implied IMU at the samples' times. `Err` names what is unusable in the ground truth.
pub fn implied_imu(
    gt: &[GroundTruthState],
    samples: &[ImuSample],
    knot_spacing_s: f64,
) -> Result<Implied, String> {
    if gt.len() < 8 {
        return Err(format!(
            "{} ground-truth rows; the implied IMU needs at least 8",
            gt.len()
        ));
    }
    let t0 = gt[0].t_ns;
    let poses: Vec<PoseSample> = gt
        .iter()
        .map(|s| PoseSample {
            t: (s.t_ns - t0) as f64 * 1e-9,
            p: s.pose.p,
            q: s.pose.q,
        })
        .collect();
    let spline = PoseSpline::fit(&poses, knot_spacing_s).map_err(|e| e.to_string())?;
    let period = median_period_s(gt);
    let margin_ns = (2.0 * period * 1e9) as i64;
    let g = Vector3::from(GRAVITY);
    let mut out = Implied::default();
    for s in samples {
        // Bracketing rows: gt[j − 1].t ≤ t < gt[j].t.
        let j = gt.partition_point(|r| r.t_ns <= s.t_ns);
        let inside = j >= 1
            && j < gt.len()
            && s.t_ns >= t0 + margin_ns
            && s.t_ns <= gt[gt.len() - 1].t_ns - margin_ns;
        let (bw, ba, covered) = if inside {
            let (a, b) = (&gt[j - 1], &gt[j]);
            let span = (b.t_ns - a.t_ns) as f64;
            let u = (s.t_ns - a.t_ns) as f64 / span;
            (
                a.gyro_bias.lerp(&b.gyro_bias, u),
                a.accel_bias.lerp(&b.accel_bias, u),
                span * 1e-9 <= GAP_FACTOR * period,
            )
        } else {
            (Vector3::zeros(), Vector3::zeros(), false)
        };
        let r = spline.state((s.t_ns - t0) as f64 * 1e-9);
        let omega_b = r.q.inverse() * r.omega_w;
        let f_b = r.q.inverse() * (r.a - g);
        out.gyro.push(omega_b + bw);
        out.accel.push(f_b + ba);
        out.gyro_bias.push(bw);
        out.speed.push(r.v.norm());
        out.rate.push(omega_b.norm());
        out.covered.push(covered);
    }
    Ok(out)
}

/// Rest samples: covered, ground-truth speed below [`REST_SPEED_M_S`] and rate below
/// [`REST_RATE_RAD_S`], in stretches of at least [`REST_MIN_S`] (period `dt_s`).
pub fn detect_rest(implied: &Implied, dt_s: f64) -> Vec<bool> {
    let raw: Vec<bool> = (0..implied.covered.len())
        .map(|i| {
            implied.covered[i]
                && implied.speed[i] < REST_SPEED_M_S
                && implied.rate[i] < REST_RATE_RAD_S
        })
        .collect();
    let min_len = (REST_MIN_S / dt_s).ceil() as usize;
    let mut rest = vec![false; raw.len()];
    for r in super::spectrum::runs_of(&raw) {
        if r.len() >= min_len {
            rest[r].iter_mut().for_each(|v| *v = true);
        }
    }
    rest
}

/// First- and second-derivative gains of the spline fit for a sinusoid of `f_hz` sampled every
/// `period_s`: amplitude of the fitted derivative over the true one.
fn derivative_gains(f_hz: f64, period_s: f64, knot_spacing_s: f64) -> Option<(f64, f64)> {
    let w = 2.0 * std::f64::consts::PI * f_hz;
    let span = 40.0f64.max(8.0 / f_hz);
    let n = (span / period_s) as usize;
    let samples: Vec<PoseSample> = (0..n)
        .map(|k| {
            let t = k as f64 * period_s;
            PoseSample {
                t,
                p: Vector3::new((w * t).sin(), 0.0, 0.0),
                q: UnitQuaternion::identity(),
            }
        })
        .collect();
    let spline = PoseSpline::fit(&samples, knot_spacing_s).ok()?;
    // Least-squares amplitude of v ≈ c₁cos + s₁sin (and a) over the middle half.
    let mut ata = Matrix3::<f64>::zeros();
    let mut atv = Vector3::<f64>::zeros();
    let mut ata2 = Vector3::<f64>::zeros();
    let m = 2000;
    for i in 0..m {
        let t = span * (0.25 + 0.5 * (i as f64 + 0.5) / m as f64);
        let r = spline.state(t);
        let (c, s) = ((w * t).cos(), (w * t).sin());
        ata[(0, 0)] += c * c;
        ata[(0, 1)] += c * s;
        ata[(1, 1)] += s * s;
        atv += Vector3::new(c * r.v.x, s * r.v.x, 0.0);
        ata2 += Vector3::new(c * r.a.x, s * r.a.x, 0.0);
    }
    let det = ata[(0, 0)] * ata[(1, 1)] - ata[(0, 1)] * ata[(0, 1)];
    let solve = |b: &Vector3<f64>| {
        let x = (ata[(1, 1)] * b.x - ata[(0, 1)] * b.y) / det;
        let y = (ata[(0, 0)] * b.y - ata[(0, 1)] * b.x) / det;
        (x * x + y * y).sqrt()
    };
    Some((solve(&atv) / w, solve(&ata2) / (w * w)))
}

/// Highest frequency (Hz) up to which the spline's velocity and acceleration (and so the
/// implied rate and specific force) are within 10 % of the truth, for ground truth every
/// `period_s` and knots every `knot_spacing_s`; searched in steps of 1/200 of the ground
/// truth's Nyquist frequency (a ground truth faster than 1 kHz is taken as 1 kHz).
pub fn implied_bandwidth_hz(period_s: f64, knot_spacing_s: f64) -> f64 {
    let period_s = period_s.max(1e-3);
    let nyquist = 0.5 / period_s;
    let step = nyquist / 200.0;
    let mut ok = 0.0;
    for i in 1..200 {
        let f = step * i as f64;
        match derivative_gains(f, period_s, knot_spacing_s) {
            Some((g1, g2))
                if (g1 - 1.0).abs() <= BANDWIDTH_TOLERANCE
                    && (g2 - 1.0).abs() <= BANDWIDTH_TOLERANCE =>
            {
                ok = f
            }
            _ => break,
        }
    }
    ok
}

/// The clock relation of measured and implied gyro signals.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ClockLag {
    /// Lag (ms) that best aligns them: the measured sample stamped `t` matches the implied one
    /// at `t − lag` (positive: the IMU's stamps are late against the ground truth's clock).
    pub lag_ms: f64,
    /// Correlation at the best integer lag.
    pub correlation: f64,
    /// Correlation at zero lag.
    pub correlation_at_zero: f64,
    /// Whether the best lag is at the edge of the search (±`search_ms`): the true lag may be
    /// outside.
    pub at_search_limit: bool,
    /// Search range (± ms).
    pub search_ms: f64,
    /// Samples compared.
    pub samples: usize,
}

/// Correlation of several channels at once: `Σ_c Σ (x − x̄_c)(y − ȳ_c)` over the square root
/// of the two sums of squares (for one channel Pearson's), over the index pairs given.
fn correlation(x: &[&[f64]], y: &[&[f64]], pairs: &[(usize, usize)]) -> Option<f64> {
    let n = pairs.len();
    if n < 3 {
        return None;
    }
    let (mut cxy, mut cxx, mut cyy) = (0.0, 0.0, 0.0);
    for (xc, yc) in x.iter().zip(y) {
        let mx = pairs.iter().map(|p| xc[p.0]).sum::<f64>() / n as f64;
        let my = pairs.iter().map(|p| yc[p.1]).sum::<f64>() / n as f64;
        for &(i, j) in pairs {
            let (a, b) = (xc[i] - mx, yc[j] - my);
            cxy += a * b;
            cxx += a * a;
            cyy += b * b;
        }
    }
    (cxx > 0.0 && cyy > 0.0).then(|| cxy / (cxx * cyy).sqrt())
}

/// Cross-correlates the `measured` channels with the `implied` ones (same stamps, period
/// `dt_s`) over lags of up to `max_lag` samples either way, on the samples where `mask` holds at
/// both ends; the best integer lag refined by a parabola through its neighbours.
pub fn clock_lag(
    measured: &[&[f64]],
    implied: &[&[f64]],
    mask: &[bool],
    dt_s: f64,
    max_lag: usize,
) -> Option<ClockLag> {
    let n = mask.len() as isize;
    let lags: Vec<isize> = (-(max_lag as isize)..=max_lag as isize).collect();
    let mut corr = Vec::with_capacity(lags.len());
    let mut counted = 0;
    for &l in &lags {
        let pairs: Vec<(usize, usize)> = (l.max(0)..n + l.min(0))
            .map(|i| (i as usize, (i - l) as usize))
            .filter(|&(i, j)| mask[i] && mask[j])
            .collect();
        let count = pairs.len();
        let c = correlation(measured, implied, &pairs)?;
        if l == 0 {
            counted = count;
        }
        corr.push(c);
    }
    let best = (0..corr.len()).max_by(|&a, &b| corr[a].total_cmp(&corr[b]))?;
    let mut shift = 0.0;
    if best > 0 && best + 1 < corr.len() {
        let (a, b, c) = (corr[best - 1], corr[best], corr[best + 1]);
        let den = a - 2.0 * b + c;
        if den < 0.0 {
            shift = (0.5 * (a - c) / den).clamp(-0.5, 0.5);
        }
    }
    Some(ClockLag {
        lag_ms: (lags[best] as f64 + shift) * dt_s * 1e3,
        correlation: corr[best],
        correlation_at_zero: corr[max_lag],
        at_search_limit: best == 0 || best + 1 == corr.len(),
        search_ms: max_lag as f64 * dt_s * 1e3,
        samples: counted,
    })
}

/// The rotation that best maps the implied angular rate onto the measured one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FrameCheck {
    /// Its angle (degrees): near 0 when the ground truth is the IMU frame.
    pub angle_deg: f64,
    /// Its axis (unit, in the IMU frame); zero for the identity.
    pub axis: [f64; 3],
    /// RMS of measured − implied rate before (rad/s)…
    pub rms_before: f64,
    /// …and after the rotation (rad/s).
    pub rms_after: f64,
    /// Smallest over largest singular value of the correlation matrix: near 0 when the
    /// motion turned about one axis only, so that the rotation about it is not determined.
    pub conditioning: f64,
    /// Samples used.
    pub samples: usize,
}

/// Kabsch: the rotation `R` minimizing `Σ |m_i − R·i_i|²` over the samples where `mask` holds.
pub fn frame_rotation(
    measured: &[Vector3<f64>],
    implied: &[Vector3<f64>],
    mask: &[bool],
) -> Option<FrameCheck> {
    let mut h = Matrix3::<f64>::zeros();
    let mut count = 0;
    for i in (0..measured.len()).filter(|&i| mask[i]) {
        h += implied[i] * measured[i].transpose();
        count += 1;
    }
    if count < 3 {
        return None;
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let v = vt.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let rot = nalgebra::Rotation3::from_matrix_unchecked(r);
    let axis = rot.axis().map_or([0.0; 3], |a| {
        [a.into_inner().x, a.into_inner().y, a.into_inner().z]
    });
    let mut before = 0.0;
    let mut after = 0.0;
    for i in (0..measured.len()).filter(|&i| mask[i]) {
        before += (measured[i] - implied[i]).norm_squared();
        after += (measured[i] - r * implied[i]).norm_squared();
    }
    let s = svd.singular_values;
    Some(FrameCheck {
        angle_deg: rot.angle().to_degrees(),
        axis,
        rms_before: (before / count as f64).sqrt(),
        rms_after: (after / count as f64).sqrt(),
        conditioning: if s.max() > 0.0 {
            s.min() / s.max()
        } else {
            0.0
        },
        samples: count,
    })
}

/// Centred moving average over `2·half + 1` samples (shorter at the ends): a zero-phase
/// low-pass.
pub fn moving_average(x: &[f64], half: usize) -> Vec<f64> {
    let mut s = Vec::with_capacity(x.len() + 1);
    s.push(0.0);
    for v in x {
        s.push(s[s.len() - 1] + v);
    }
    (0..x.len())
        .map(|i| {
            let a = i.saturating_sub(half);
            let b = (i + half + 1).min(x.len());
            (s[b] - s[a]) / (b - a) as f64
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lag_of_a_shifted_signal_is_found() {
        let n = 4000;
        let dt = 0.005;
        let f = |t: f64| (1.3 * t).sin() + 0.5 * (3.1 * t).cos();
        // The measured signal is the implied one 12.5 ms late (2.5 samples).
        let implied: Vec<f64> = (0..n).map(|k| f(k as f64 * dt)).collect();
        let measured: Vec<f64> = (0..n).map(|k| f(k as f64 * dt - 0.0125)).collect();
        let mask = vec![true; n];
        let c = clock_lag(&[&measured], &[&implied], &mask, dt, 10).unwrap();
        assert!((c.lag_ms - 12.5).abs() < 0.5, "{c:?}");
        assert!(!c.at_search_limit);
    }

    #[test]
    fn a_known_rotation_is_recovered() {
        let r = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 2f64.to_radians()));
        let implied: Vec<Vector3<f64>> = (0..500)
            .map(|k| {
                let t = k as f64 * 0.01;
                Vector3::new(t.sin(), (2.0 * t).cos(), (0.7 * t).sin())
            })
            .collect();
        let measured: Vec<Vector3<f64>> = implied.iter().map(|w| r * w).collect();
        let f = frame_rotation(&measured, &implied, &vec![true; 500]).unwrap();
        assert!((f.angle_deg - 2.0).abs() < 1e-9, "{f:?}");
        assert!((f.axis[2] - 1.0).abs() < 1e-9);
        assert!(f.rms_after < 1e-12);
    }

    #[test]
    fn bandwidth_grows_with_denser_knots() {
        let coarse = implied_bandwidth_hz(0.05, 0.2);
        let fine = implied_bandwidth_hz(0.05, 0.1);
        assert!(
            coarse > 0.5 && fine > coarse && fine < 10.0,
            "{coarse} {fine}"
        );
    }
}
