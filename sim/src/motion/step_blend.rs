//! Steps in a recording bridged by a motion-limited blend (`repair = true`).
//!
//! A laser tracker or motion-capture system that loses the body and finds it again a few
//! centimetres off leaves a step that nothing undoes (EuRoC MH_03–MH_05 as OpenVINS republishes
//! them: 1.9–13 cm). Which side is true cannot be told, but a simulator replaying the motion
//! needs neither side exactly: it needs a motion the body could fly. The step `Δ` (its residual
//! against the velocities on both sides) is replaced by a minimum-jerk ramp
//! `s(u) = 10u³ − 15u⁴ + 6u⁵` over a window `T` centred on it: a sample at `t` moves by
//! `Δ·(s(u) − H)`, with `u` its place in the window and `H` 1 after the step and 0 before, so
//! the recording is untouched outside the window and continuous inside. The ramp's peak
//! acceleration is `(10/√3)·|Δ|/T²`; `T` is the shortest window keeping it at the recording's
//! own 99th-percentile acceleration (linear and angular), so the blend asks no more of the body
//! than the motion does anyway. The simulated motion then departs from the recorded file by up
//! to `|Δ|/2` near the step: scores against the run's own ground truth are exact, scores against
//! the raw file are not (which is why a recorded IMU log, flown along the file's true motion, is
//! never blended).

use nalgebra::UnitQuaternion;

use super::jumps::Jump;
use super::spline::{PoseSample, TrajectoryError};

/// Longest blend window (s): a step that needs more is too large for the motion to bridge.
pub const MAX_BLEND_S: f64 = 2.0;
/// Peak `|s''|` of the minimum-jerk ramp on `[0, 1]`.
const PEAK_ACCEL_PER_STEP: f64 = 5.773_502_691_896_258;

/// A step bridged by a blend (`report.json` → `replay.steps_blended` holds it as it is).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct BlendedStep {
    /// 1-based line of the first sample after the step.
    pub line: usize,
    /// The step's time (s, file clock): between the samples on its two sides.
    pub t_s: f64,
    /// Its position residual (m).
    pub position_m: f64,
    /// Its attitude residual (deg).
    pub angle_deg: f64,
    /// The blend window (s).
    pub blend_s: f64,
}

fn ramp(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
}

/// The window (s) that bridges `step` within the (linear, angular) accelerations `accel`.
fn blend_window(step: &Jump, accel: (f64, f64)) -> f64 {
    let (m, rad) = step.size();
    let need = |size: f64, a: f64| {
        if size == 0.0 {
            0.0
        } else {
            (PEAK_ACCEL_PER_STEP * size / a.max(f64::MIN_POSITIVE)).sqrt()
        }
    };
    need(m, accel.0).max(need(rad, accel.1))
}

/// Moves `samples` so that each step `(jump, window)` becomes its ramp (see the module's
/// documentation). The windows must not overlap.
fn blend(samples: &mut [PoseSample], steps: &[(Jump, f64)]) {
    for &(jump, window) in steps {
        let i = jump.index;
        let centre = 0.5 * (samples[i].t + samples[i + 1].t);
        let start = centre - 0.5 * window;
        for (k, s) in samples.iter_mut().enumerate() {
            if s.t < start || s.t > start + window {
                continue;
            }
            let after = if k > i { 1.0 } else { 0.0 };
            let w = ramp((s.t - start) / window) - after;
            s.p += jump.position * w;
            s.q *= UnitQuaternion::from_scaled_axis(jump.attitude * w);
        }
    }
}

/// Whether any two windows (centred between their samples) overlap.
fn overlapping(samples: &[PoseSample], steps: &[(Jump, f64)]) -> Option<(usize, usize)> {
    let span = |(j, w): &(Jump, f64)| {
        let c = 0.5 * (samples[j.index].t + samples[j.index + 1].t);
        (c - 0.5 * w, c + 0.5 * w)
    };
    steps
        .windows(2)
        .enumerate()
        .find_map(|(a, pair)| (span(&pair[0]).1 >= span(&pair[1]).0).then_some((a, a + 1)))
}

/// The steps (indices into `kept`) bridged in `kept` (lines and samples), each by the window its
/// size needs at the motion's accelerations `accel`; refused when a step needs more than
/// [`MAX_BLEND_S`] or two windows overlap.
pub(super) fn blend_steps(
    kept: &mut [(usize, PoseSample)],
    steps: &[Jump],
    accel: (f64, f64),
) -> Result<Vec<BlendedStep>, TrajectoryError> {
    let mut samples: Vec<PoseSample> = kept.iter().map(|k| k.1).collect();
    let windows: Vec<(Jump, f64)> = steps.iter().map(|j| (*j, blend_window(j, accel))).collect();
    let line = |j: &Jump| kept[j.index + 1].0;
    if let Some((j, w)) = windows.iter().find(|(_, w)| *w > MAX_BLEND_S) {
        let (m, rad) = j.size();
        return Err(TrajectoryError::Unusable(format!(
            "line {}: the step of {m:.4} m / {:.2}° at t = {:.6} s needs a {w:.2} s blend at the motion's own accelerations ({:.2} m/s², {:.2} rad/s²), longer than the {MAX_BLEND_S} s that can be bridged: cut the recording at this line",
            line(j),
            rad.to_degrees(),
            samples[j.index].t,
            accel.0,
            accel.1
        )));
    }
    if let Some((a, b)) = overlapping(&samples, &windows) {
        return Err(TrajectoryError::Unusable(format!(
            "lines {} and {}: two steps {:.3} s apart, closer than their blends ({:.2} s, {:.2} s): cut the recording between them",
            line(&windows[a].0),
            line(&windows[b].0),
            samples[windows[b].0.index].t - samples[windows[a].0.index].t,
            windows[a].1,
            windows[b].1
        )));
    }
    let report = windows
        .iter()
        .map(|(j, w)| {
            let (m, rad) = j.size();
            BlendedStep {
                line: line(j),
                t_s: 0.5 * (samples[j.index].t + samples[j.index + 1].t),
                position_m: m,
                angle_deg: rad.to_degrees(),
                blend_s: *w,
            }
        })
        .collect();
    blend(&mut samples, &windows);
    for (k, s) in kept.iter_mut().zip(samples) {
        k.1 = s;
    }
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn jump(index: usize, p: Vector3<f64>, q: Vector3<f64>) -> Jump {
        Jump {
            index,
            position: p,
            attitude: q,
        }
    }

    /// A 1 m/s line at 100 Hz with a 5 cm step after sample 499.
    fn stepped() -> Vec<PoseSample> {
        (0..1000)
            .map(|i| {
                let t = i as f64 * 0.01;
                let step = if i >= 500 { 0.05 } else { 0.0 };
                PoseSample {
                    t,
                    p: Vector3::new(t + step, 0.0, 1.0),
                    q: UnitQuaternion::identity(),
                }
            })
            .collect()
    }

    #[test]
    fn a_blend_is_continuous_within_the_acceleration_and_leaves_the_rest_alone() {
        let mut s = stepped();
        let j = jump(499, Vector3::new(0.05, 0.0, 0.0), Vector3::zeros());
        let accel = (2.0, 1.0);
        let w = blend_window(&j, accel);
        // (10/√3)·0.05/T² = 2 m/s².
        assert!((w - (5.7735 * 0.05 / 2.0f64).sqrt()).abs() < 1e-3, "{w}");
        let before = s.clone();
        blend(&mut s, &[(j, w)]);
        let centre = 4.995;
        for (a, b) in before.iter().zip(&s) {
            if (a.t - centre).abs() > 0.5 * w + 1e-9 {
                assert_eq!(a, b, "outside the window at {}", a.t);
            }
        }
        // No step left, and the second difference stays within the allowance.
        let dt = 0.01;
        let mut peak = 0.0f64;
        for k in 1..s.len() - 1 {
            let acc = (s[k + 1].p - 2.0 * s[k].p + s[k - 1].p).norm() / (dt * dt);
            peak = peak.max(acc);
        }
        assert!(peak < 1.05 * accel.0, "peak acceleration {peak}");
        let jumpiest = s
            .windows(2)
            .map(|w| (w[1].p - w[0].p).norm())
            .fold(0.0, f64::max);
        assert!(jumpiest < 0.0125, "largest step {jumpiest}");
    }

    #[test]
    fn overlapping_windows_are_found() {
        let s = stepped();
        let j = |i| jump(i, Vector3::new(0.05, 0.0, 0.0), Vector3::zeros());
        assert_eq!(overlapping(&s, &[(j(100), 0.4), (j(200), 0.4)]), None);
        assert_eq!(
            overlapping(&s, &[(j(100), 0.4), (j(130), 0.4)]),
            Some((0, 1))
        );
    }
}
