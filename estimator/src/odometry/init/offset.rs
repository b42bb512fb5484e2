//! The camera–IMU time offset at initialization. The visual-inertial alignment compares the
//! camera's poses with IMU intervals cut at the frames' IMU times `t + td`; with a wrong `td`
//! every interval is shifted against its images, and the alignment bends gravity to explain the
//! difference (a 35 ms error started mono+IMU on the EuRoC V2_02 replay 13° tilted). Each
//! interval keeps its samples, so the intervals between the interior frames (all but the oldest
//! and the newest, whose neighbours outside the window are not at hand) can be cut again at
//! `t + td + δ` and aligned for each candidate shift δ; the smallest residual picks the shift
//! the window starts from, and the window's own estimation refines it.

use crate::imu::{ImuSample, Preintegration};
use crate::odometry::window::Window;

/// Step (s) between the shifts tried: the window estimates the offset to well under a
/// millisecond once it runs; the search only has to start it where the alignment is sound.
const STEP_S: f64 = 0.005;

/// The window's IMU samples from its oldest to its newest frame, in time order, each once (the
/// intervals share their boundary samples). `None` if a frame has no interval or one integrated
/// a clipped reading.
fn window_samples(window: &Window) -> Option<Vec<ImuSample>> {
    let mut out: Vec<ImuSample> = Vec::new();
    for f in window.frames.iter().skip(1) {
        let p = f.preint.as_ref().filter(|p| !p.clipped())?;
        for s in p.samples() {
            if out.last().is_none_or(|l| s.t_ns > l.t_ns) {
                out.push(*s);
            }
        }
    }
    Some(out)
}

/// The interval `[t0, t1]` cut from `samples` (time order, covering both ends; the ends
/// interpolated), linearized at the biases and with the noise model of `like`.
fn cut(samples: &[ImuSample], t0: i64, t1: i64, like: &Preintegration) -> Option<Preintegration> {
    let at = |t: i64| -> Option<ImuSample> {
        let i = samples.iter().position(|s| s.t_ns >= t)?;
        if samples[i].t_ns == t {
            return Some(samples[i]);
        }
        Some(ImuSample::interpolate(
            samples.get(i.checked_sub(1)?)?,
            &samples[i],
            t,
        ))
    };
    let mut p = Preintegration::new(
        at(t0)?,
        *like.linearized_ba(),
        *like.linearized_bg(),
        *like.noise(),
    )
    .ok()?;
    for s in samples.iter().filter(|s| s.t_ns > t0 && s.t_ns < t1) {
        p.push(*s).ok()?;
    }
    p.push(at(t1)?).ok()?;
    Some(p)
}

/// 99 % point of χ² with one degree of freedom: the likelihood-ratio test of one more parameter.
const CHI2_1_99: f64 = 6.63;

/// The shift (ns) of the interior frames' IMU times, within `±max_s` in steps of 5 ms, whose
/// intervals `residual` finds most consistent with the images. `residual` gets the intervals
/// between consecutive interior frames, cut at the shifted times, and returns the alignment's
/// `(χ² per degree of freedom, degrees of freedom)` (`None`: not aligned). A shift is taken only
/// where it is a minimum inside the range and it explains the alignment significantly better
/// than no shift: `(χ²(0) − χ²(δ)) / (χ²(δ) / dof)` above the 99 % point of χ² with one degree of
/// freedom (an F-type test, robust to a noise model that is off by a common factor). A gentle
/// start-up's residual drifts monotonically with the shift (EuRoC V1_01, true offset 0: 9.6 at
/// 0 to 5.8 at +45 ms per degree of freedom), which the edge rule refuses. 0 when no shift
/// passes, when the window has fewer than four frames, or when nothing aligns.
pub(super) fn best_shift(
    window: &Window,
    max_s: f64,
    mut residual: impl FnMut(&mut [Preintegration]) -> Option<(f64, usize)>,
) -> i64 {
    let n = window.frames.len();
    let Some(samples) = window_samples(window).filter(|_| n >= 4) else {
        return 0;
    };
    let times: Vec<i64> = window.frames.iter().map(|f| f.t_ns).collect();
    // Every shifted interior time stays strictly inside the oldest and newest frames' times.
    let room = times.windows(2).map(|w| w[1] - w[0]).min().unwrap_or(0) - 1;
    let step = (STEP_S * 1e9).round() as i64;
    let steps = ((max_s * 1e9) as i64).min(room) / step;
    let like = window.frames[1]
        .preint
        .as_ref()
        .expect("window_samples checked");
    let mut at_zero: Option<(f64, usize)> = None;
    let mut best: Option<(f64, i64)> = None;
    // 0 first, then outwards: ties keep the smaller shift.
    for k in std::iter::once(0).chain((1..=steps).flat_map(|k| [k, -k])) {
        let shift = k * step;
        let intervals: Option<Vec<Preintegration>> = times[1..n - 1]
            .windows(2)
            .map(|w| cut(&samples, w[0] + shift, w[1] + shift, like))
            .collect();
        let Some(mut intervals) = intervals else {
            continue;
        };
        let Some((r, dof)) = residual(&mut intervals).filter(|(r, _)| r.is_finite()) else {
            continue;
        };
        if k == 0 {
            at_zero = Some((r, dof));
        }
        if best.is_none_or(|(b, _)| r < b) {
            best = Some((r, shift));
        }
    }
    match (at_zero, best) {
        (Some((r0, dof)), Some((r, shift)))
            if shift.abs() < steps * step && (r0 - r) * dof as f64 > CHI2_1_99 * r =>
        {
            shift
        }
        _ => 0,
    }
}

/// Moves the interior frames' IMU times by `shift_ns` (what [`best_shift`] found): their
/// intervals are cut again from the window's samples (the oldest and newest frames keep their
/// times), their measurements are stamped with the offset `td + shift` they now stand for, and
/// the window's offset estimate starts there; the oldest and newest frames' measurements keep
/// their stamps, so the visual factors shift them along their image velocities. `false` (window
/// untouched) when the samples do not cover the new intervals.
pub(super) fn apply_shift(window: &mut Window, shift_ns: i64) -> bool {
    let n = window.frames.len();
    if shift_ns == 0 || n < 4 {
        return shift_ns == 0;
    }
    let Some(samples) = window_samples(window) else {
        return false;
    };
    let times: Vec<i64> = (0..n)
        .map(|k| window.frames[k].t_ns + if k == 0 || k == n - 1 { 0 } else { shift_ns })
        .collect();
    let intervals: Option<Vec<Preintegration>> = (1..n)
        .map(|k| {
            let like = window.frames[k].preint.as_ref()?;
            cut(&samples, times[k - 1], times[k], like)
        })
        .collect();
    let Some(intervals) = intervals else {
        return false;
    };
    let shift_s = shift_ns as f64 * 1e-9;
    let interior: Vec<u64> = window
        .frames
        .iter()
        .skip(1)
        .take(n - 2)
        .map(|f| f.seq)
        .collect();
    for (k, p) in (1..n).zip(intervals) {
        window.frames[k].t_ns = times[k];
        window.frames[k].preint = Some(p);
    }
    for t in window.features.tracks.values_mut() {
        for o in t.obs.iter_mut().filter(|o| interior.contains(&o.seq)) {
            for m in o.meas.iter_mut().flatten() {
                m.td += shift_s;
            }
        }
    }
    window.td += shift_s;
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imu::ImuNoise;
    use nalgebra::Vector3;

    /// A cut interval integrates exactly the samples of its span, interpolated at both ends:
    /// under a constant rate and acceleration its deltas are the analytic ones over the span.
    #[test]
    fn a_cut_interval_covers_its_shifted_span() {
        let (w, a) = (Vector3::new(0.0, 0.0, 0.5), Vector3::new(0.3, 0.0, 9.81));
        let samples: Vec<ImuSample> = (0..=80)
            .map(|k| ImuSample::new(k * 5_000_000, w, a).unwrap())
            .collect();
        let zero = Vector3::zeros();
        let mut like = Preintegration::new(samples[0], zero, zero, ImuNoise::euroc()).unwrap();
        for s in &samples[1..] {
            like.push(*s).unwrap();
        }
        // 0.1025 s to 0.3125 s: both ends between samples.
        let p = cut(&samples, 102_500_000, 312_500_000, &like).unwrap();
        let dt = 0.21;
        assert!((p.dt() - dt).abs() < 1e-12, "dt {}", p.dt());
        assert!((p.delta_q().angle() - 0.5 * dt).abs() < 1e-9);
        // Δv = ∫ R(t) a dt with R a rotation about z at 0.5 rad/s: its z part is exact.
        assert!((p.delta_v().z - 9.81 * dt).abs() < 1e-9);
        // A span reaching past the samples cannot be cut.
        assert!(cut(&samples, 300_000_000, 400_000_001, &like).is_none());
        assert!(cut(&samples, -1, 100_000_000, &like).is_none());
    }
}
