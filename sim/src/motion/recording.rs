//! Replay that knows its input: a recorded trajectory is checked before it is fitted.
//!
//! - **Time unit**: TUM files are in seconds and EuRoC ASL files in nanoseconds by their
//!   format, but recordings in the wild come in milliseconds or nanoseconds too. Unless the unit
//!   is given, it is detected from the median stamp spacing: the unit that puts it between
//!   0.1 ms and 1 s (1 Hz to 10 kHz), seconds first; an ambiguous spacing is an error asking for
//!   the unit.
//! - **Glitches**: each sample is compared with the interpolation of its two neighbours. The
//!   allowed departure comes from the motion's own statistics: ten times the median departure
//!   (the recorder's noise), or three times what the recording's 99th-percentile acceleration
//!   (angular acceleration) can bend a path between those neighbours, whichever is larger, and
//!   never under 2 mm / 0.5°. Worst first, one at a time.
//! - **Jumps** (`jumps.rs`): a step between two samples far beyond what the motion can do and
//!   larger than the fit tolerance, and, within 2 s, the step back: the samples between are an
//!   excursion, dropped by `repair` with the glitches (and counted with them); a step that never
//!   comes back is refused with its line, or with `repair` bridged by a minimum-jerk blend
//!   within the motion's own accelerations (`step_blend.rs`; refused when the blend would need
//!   more than [`MAX_BLEND_S`] or two blends overlap).
//! - **Gaps**: a spacing over ten median spacings and over two knot spacings leaves spline knots
//!   without data, and the fit rings through them.
//! - **Fit**: the fitted spline must stay within a tolerance (default 1 cm / 1°) of every kept
//!   sample, and must not ring: its acceleration and angular acceleration stay within three
//!   times the recording's largest (plus 2 m/s², 10 rad/s²), or the simulated IMU would
//!   measure the fit instead of the motion.
//!
//! Without `repair` a glitch or a gap is an error naming the line; with it, glitches are dropped
//! and gaps up to [`MAX_BRIDGE_S`] are bridged by samples on cubic Hermite curves through both
//! ends with the rates measured on each side (position; attitude in the tangent space). Either way [`RecordingReport`] says
//! what was found and done.

use std::path::Path;

use nalgebra::{UnitQuaternion, Vector3};

use super::jumps::{Jump, MAX_EXCURSION_S, find_jumps};
use super::reference::Reference;
use super::sample_statistics::{median, percentile};
use super::step_blend::blend_steps;
pub use super::step_blend::{BlendedStep, MAX_BLEND_S};

use super::spline::{PoseSample, Replay, TrajectoryError, parse_recording};

/// Longest gap (s) `repair` bridges.
pub const MAX_BRIDGE_S: f64 = 2.0;
/// Most glitches `repair` drops, as a fraction of the samples.
const MAX_GLITCH_FRACTION: f64 = 0.01;
/// Smallest position departure (m) counted as a glitch.
const GLITCH_FLOOR_M: f64 = 2e-3;
/// Smallest attitude departure (rad) counted as a glitch (0.5°).
const GLITCH_FLOOR_RAD: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// Units of a recording's timestamps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeUnit {
    /// Seconds.
    Seconds,
    /// Milliseconds.
    Milliseconds,
    /// Microseconds.
    Microseconds,
    /// Nanoseconds.
    Nanoseconds,
}

impl TimeUnit {
    /// Seconds per unit.
    pub fn seconds(self) -> f64 {
        match self {
            TimeUnit::Seconds => 1.0,
            TimeUnit::Milliseconds => 1e-3,
            TimeUnit::Microseconds => 1e-6,
            TimeUnit::Nanoseconds => 1e-9,
        }
    }

    /// Its short name (`s`, `ms`, `us`, `ns`).
    pub fn name(self) -> &'static str {
        match self {
            TimeUnit::Seconds => "s",
            TimeUnit::Milliseconds => "ms",
            TimeUnit::Microseconds => "us",
            TimeUnit::Nanoseconds => "ns",
        }
    }
}

/// How a recording is read and fitted.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingOptions {
    /// The stamps' unit; `None`: the format's (TUM s, ASL ns) when its spacing is plausible,
    /// else detected.
    pub time_unit: Option<TimeUnit>,
    /// Drop glitches and bridge gaps instead of refusing the file.
    pub repair: bool,
    /// Spline knot spacing (s).
    pub knot_spacing_s: f64,
    /// Largest position departure (m) of the fitted spline from a kept sample.
    pub fit_tolerance_m: f64,
    /// Largest attitude departure (rad) of the fitted spline from a kept sample.
    pub fit_tolerance_rad: f64,
    /// Places the recording in the scene: `T_scene_file` applied to every sample.
    pub placement: Option<(UnitQuaternion<f64>, Vector3<f64>)>,
}

impl Default for RecordingOptions {
    fn default() -> Self {
        Self {
            time_unit: None,
            repair: false,
            knot_spacing_s: Replay::DEFAULT_KNOT_SPACING_S,
            fit_tolerance_m: 0.01,
            fit_tolerance_rad: 1f64.to_radians(),
            placement: None,
        }
    }
}

/// A sample judged a glitch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Glitch {
    /// 1-based line in the file.
    pub line: usize,
    /// Its time (s, file clock).
    pub t_s: f64,
    /// Departure from its neighbours' interpolation (m).
    pub position_m: f64,
    /// Departure from its neighbours' interpolation (deg).
    pub angle_deg: f64,
}

/// A stretch without samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Gap {
    /// 1-based line of the sample after the gap.
    pub line: usize,
    /// Start of the gap (s, file clock).
    pub t_s: f64,
    /// Its length (s).
    pub length_s: f64,
}

/// What was found in a recording and what was done about it.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordingReport {
    /// The stamps' unit.
    pub time_unit: TimeUnit,
    /// Whether it was detected rather than given or implied by the format.
    pub unit_detected: bool,
    /// Samples in the file.
    pub samples: usize,
    /// Median stamp spacing (s).
    pub median_spacing_s: f64,
    /// Glitches found (dropped when repairing).
    pub glitches: Vec<Glitch>,
    /// Steps found and bridged by a blend (repairing only; without `repair` a step is refused).
    pub steps: Vec<BlendedStep>,
    /// Gaps found (bridged when repairing).
    pub gaps: Vec<Gap>,
    /// Samples added to bridge the gaps.
    pub bridged_samples: usize,
    /// Largest departure of the fitted spline from a kept sample (m).
    pub fit_max_m: f64,
    /// Largest departure of the fitted spline from a kept sample (deg).
    pub fit_max_deg: f64,
}

impl RecordingReport {
    /// The blended steps for [`RecordingReport::summary`]: empty without any.
    fn steps_summary(&self) -> String {
        self.steps
            .iter()
            .map(|s| {
                format!(
                    " step at line {} (t = {:.3} s, {:.4} m / {:.2}°) blended over {:.2} s;",
                    s.line, s.t_s, s.position_m, s.angle_deg, s.blend_s
                )
            })
            .collect()
    }

    /// One line for summaries.
    pub fn summary(&self) -> String {
        let largest = |f: fn(&Glitch) -> f64| self.glitches.iter().map(f).fold(0.0, f64::max);
        format!(
            "{} samples, stamps in {}{}, median spacing {:.4} s; {} glitches (largest {:.3} m / {:.1}°),{} {} gaps (longest {:.3} s, {} samples bridged); fit within {:.4} m / {:.3}°",
            self.samples,
            self.time_unit.name(),
            if self.unit_detected {
                " (detected)"
            } else {
                ""
            },
            self.median_spacing_s,
            self.glitches.len(),
            largest(|g| g.position_m),
            largest(|g| g.angle_deg),
            self.steps_summary(),
            self.gaps.len(),
            self.gaps.iter().map(|g| g.length_s).fold(0.0, f64::max),
            self.bridged_samples,
            self.fit_max_m,
            self.fit_max_deg
        )
    }
}

fn unusable(msg: String) -> TrajectoryError {
    TrajectoryError::Unusable(msg)
}

/// The unit that puts the median spacing `raw` (file units) between 0.1 ms and 1 s: `default`
/// when it does, else the one other unit that does.
fn detect_unit(raw: f64, default: TimeUnit) -> Result<(TimeUnit, bool), TrajectoryError> {
    let plausible = |u: TimeUnit| (1e-4..=1.0).contains(&(raw * u.seconds()));
    if plausible(default) {
        return Ok((default, false));
    }
    let all = [
        TimeUnit::Seconds,
        TimeUnit::Milliseconds,
        TimeUnit::Microseconds,
        TimeUnit::Nanoseconds,
    ];
    let fits: Vec<TimeUnit> = all.into_iter().filter(|u| plausible(*u)).collect();
    match fits.as_slice() {
        [u] => Ok((*u, true)),
        _ => Err(unusable(format!(
            "cannot tell the time unit: the median stamp spacing is {raw} file units, {}; set `time_unit` (s, ms, us or ns)",
            if fits.is_empty() {
                "no unit makes that a rate between 1 Hz and 10 kHz".to_string()
            } else {
                format!(
                    "which fits {}",
                    fits.iter()
                        .map(|u| u.name())
                        .collect::<Vec<_>>()
                        .join(" and ")
                )
            }
        ))),
    }
}

/// The recording's linear (m/s²) and angular (rad/s²) accelerations at the given percentile
/// (1: the largest), from differences over `h` seconds on each side (coarse enough that the
/// recorder's noise does not dominate).
fn motion_accelerations(s: &[PoseSample], h: f64, p: f64) -> (f64, f64) {
    let t: Vec<f64> = s.iter().map(|x| x.t).collect();
    let (mut lin, mut ang) = (Vec::new(), Vec::new());
    for i in 0..s.len() {
        // The last sample at least `h` before, the first at least `h` after.
        let (before, after) = (
            t.partition_point(|&x| x <= t[i] - h),
            t.partition_point(|&x| x < t[i] + h),
        );
        if before == 0 || after >= s.len() {
            continue;
        }
        let (j, k) = (before - 1, after);
        let (d1, d2) = (t[i] - t[j], t[k] - t[i]);
        if !(d1 >= 0.5 * h && d1 <= 2.0 * h && d2 >= 0.5 * h && d2 <= 2.0 * h) {
            continue;
        }
        let v1 = (s[i].p - s[j].p) / d1;
        let v2 = (s[k].p - s[i].p) / d2;
        lin.push((v2 - v1).norm() / (0.5 * (d1 + d2)));
        let w1 = (s[j].q.inverse() * s[i].q).scaled_axis() / d1;
        let w2 = (s[i].q.inverse() * s[k].q).scaled_axis() / d2;
        ang.push((w2 - w1).norm() / (0.5 * (d1 + d2)));
    }
    (percentile(lin, p), percentile(ang, p))
}

/// Departure `(m, rad)` of sample `c` from the line through `a` and `b` (interpolated or
/// extrapolated to its time: positions linearly, attitudes along the geodesic).
fn departure(a: &PoseSample, b: &PoseSample, c: &PoseSample) -> (f64, f64) {
    let x = (c.t - a.t) / (b.t - a.t);
    let p = a.p + (b.p - a.p) * x;
    let q = a.q * UnitQuaternion::from_scaled_axis((a.q.inverse() * b.q).scaled_axis() * x);
    ((c.p - p).norm(), c.q.angle_to(&q))
}

/// Glitch indices (into `s`), worst first, with their departures.
///
/// Each sample is predicted three ways from the samples still alive: interpolated from its
/// neighbours, extrapolated from the two before, extrapolated from the two after. A prediction
/// from `a`, `b` to time `t` may miss by `accel·|t − t_a|·|t − t_b|/2` (the remainder of linear
/// interpolation), so each departure is divided by three times that bound (and never by less
/// than the noise floor). Predictions that reach over four times further than the closest one
/// (across a gap) are not asked. A sample is a glitch when even its best remaining prediction
/// misses: a glitch next to a gap is caught by the prediction from its other side, and the
/// neighbours of a glitch are not, because one of their predictions does not use it.
fn find_glitches(s: &[PoseSample], accel: (f64, f64)) -> Vec<(usize, f64, f64)> {
    let n = s.len();
    let mut alive: Vec<bool> = vec![true; n];
    let (mut noise_p, mut noise_q) = (Vec::new(), Vec::new());
    for i in 1..n - 1 {
        let (p, q) = departure(&s[i - 1], &s[i + 1], &s[i]);
        noise_p.push(p);
        noise_q.push(q);
    }
    let floor_p = GLITCH_FLOOR_M.max(10.0 * median(noise_p));
    let floor_q = GLITCH_FLOOR_RAD.max(10.0 * median(noise_q));
    let score = |a: &PoseSample, b: &PoseSample, c: &PoseSample| {
        let (dp, dq) = departure(a, b, c);
        let reach = 0.5 * ((c.t - a.t) * (c.t - b.t)).abs();
        let ratio =
            (dp / floor_p.max(3.0 * accel.0 * reach)).max(dq / floor_q.max(3.0 * accel.1 * reach));
        (ratio, dp, dq, reach)
    };
    let limit = ((n as f64 * MAX_GLITCH_FRACTION).ceil() as usize).max(10) + 1;
    let mut found = Vec::new();
    while found.len() < limit {
        let idx: Vec<usize> = (0..n).filter(|&i| alive[i]).collect();
        let mut worst: Option<(f64, usize, f64, f64)> = None;
        for k in 0..idx.len() {
            let at = |j: i64| (j >= 0 && (j as usize) < idx.len()).then(|| &s[idx[j as usize]]);
            let k = k as i64;
            let c = at(k).expect("in range");
            let candidates = [
                (at(k - 1), at(k + 1)),
                (at(k - 2), at(k - 1)),
                (at(k + 1), at(k + 2)),
            ];
            let scores: Vec<_> = candidates
                .iter()
                .filter_map(|(a, b)| Some(score((*a)?, (*b)?, c)))
                .collect();
            // Predictions across a gap reach far and vouch for anything: only those within
            // four times the closest one count.
            let closest = scores.iter().map(|x| x.3).fold(f64::INFINITY, f64::min);
            let best = scores
                .iter()
                .filter(|x| x.3 <= 4.0 * closest)
                .min_by(|x, y| x.0.total_cmp(&y.0));
            if let Some(&(ratio, dp, dq, _)) = best
                && ratio > 1.0
                && worst.is_none_or(|w| ratio > w.0)
            {
                worst = Some((ratio, idx[k as usize], dp, dq));
            }
        }
        let Some((_, i, dp, dq)) = worst else {
            break;
        };
        alive[i] = false;
        found.push((i, dp, dq));
    }
    found
}

/// One end of a gap: the sample and its velocity and body angular velocity, from the samples
/// within `h` on its outer side.
struct GapEnd {
    sample: PoseSample,
    v: Vector3<f64>,
    omega_b: Vector3<f64>,
}

impl GapEnd {
    /// The end at sample `i`, with rates from the samples within `h` on side `dir` (−1 before,
    /// +1 after): the derivative at `i` of the parabola through `i`, the sample about `h/2`
    /// away and the one about `h` away (a one-sided difference would lag by `h/2`).
    fn new(s: &[PoseSample], i: usize, h: f64, dir: i64) -> Self {
        let find = |reach: f64| {
            let mut j = i as i64;
            loop {
                let next = j + dir;
                if next < 0 || next >= s.len() as i64 || (s[next as usize].t - s[i].t).abs() > reach
                {
                    break;
                }
                j = next;
            }
            j as usize
        };
        let (j, k) = (find(0.5 * h), find(h));
        let zero = Self {
            sample: s[i],
            v: Vector3::zeros(),
            omega_b: Vector3::zeros(),
        };
        if j == i || k == j {
            return zero;
        }
        let (t0, t1, t2) = (s[i].t, s[j].t, s[k].t);
        // Lagrange weights of the derivative at t0 of the parabola through t0, t1, t2.
        let w0 = (2.0 * t0 - t1 - t2) / ((t0 - t1) * (t0 - t2));
        let w1 = (t0 - t2) / ((t1 - t0) * (t1 - t2));
        let w2 = (t0 - t1) / ((t2 - t0) * (t2 - t1));
        let v = s[i].p * w0 + s[j].p * w1 + s[k].p * w2;
        // Attitude in the tangent space at the end: r(t0) = 0.
        let r = |m: usize| (s[i].q.inverse() * s[m].q).scaled_axis();
        let omega_b = r(j) * w1 + r(k) * w2;
        Self {
            sample: s[i],
            v,
            omega_b,
        }
    }
}

/// The inverse right Jacobian of SO(3) at `phi`: maps a body angular velocity to the rate of
/// `phi` in `q = q_0 · exp(phi)`.
fn right_jacobian_inverse(phi: &Vector3<f64>) -> nalgebra::Matrix3<f64> {
    let theta = phi.norm();
    let k = phi.cross_matrix();
    if theta < 1e-6 {
        return nalgebra::Matrix3::identity() + k * 0.5;
    }
    let c = 1.0 / (theta * theta) - (1.0 + theta.cos()) / (2.0 * theta * theta.sin());
    nalgebra::Matrix3::identity() + k * 0.5 + k * k * c
}

/// Samples bridging the gap `a` → `b` (exclusive) every `step` seconds: cubic Hermite curves
/// through both ends with their rates, for the position and for the attitude in the tangent
/// space at `a` (`q = q_a · exp(r(x))`, `r(0) = 0`, `r(1) = log(q_a⁻¹ q_b)`, end slopes the
/// body angular velocities).
fn bridge(a: &GapEnd, b: &GapEnd, step: f64) -> Vec<PoseSample> {
    let (sa, sb) = (&a.sample, &b.sample);
    let len = sb.t - sa.t;
    let n = (len / step).floor() as usize;
    let r1 = (sa.q.inverse() * sb.q).scaled_axis();
    (1..n)
        .map(|k| {
            let x = k as f64 / n as f64;
            let (x2, x3) = (x * x, x * x * x);
            let h00 = 2.0 * x3 - 3.0 * x2 + 1.0;
            let h10 = x3 - 2.0 * x2 + x;
            let h01 = -2.0 * x3 + 3.0 * x2;
            let h11 = x3 - x2;
            let slope_b = right_jacobian_inverse(&r1) * b.omega_b;
            let r = a.omega_b * (h10 * len) + r1 * h01 + slope_b * (h11 * len);
            PoseSample {
                t: sa.t + x * len,
                p: sa.p * h00 + a.v * (h10 * len) + sb.p * h01 + b.v * (h11 * len),
                q: sa.q * UnitQuaternion::from_scaled_axis(r),
            }
        })
        .collect()
}

/// Refuses a fitted spline that accelerates far beyond anything the recording does (three
/// times its largest acceleration plus 2 m/s², or angular acceleration plus 10 rad/s²): the
/// simulated IMU would measure the fit's ringing, not the motion. Sampled every 5 ms.
fn check_ringing(replay: &Replay, accel_max: f64, alpha_max: f64) -> Result<(), TrajectoryError> {
    let (lim_a, lim_alpha) = (3.0 * accel_max + 2.0, 3.0 * alpha_max + 10.0);
    let end = replay.spline.end_time();
    let n = (end / 0.005).ceil() as usize;
    for k in 0..=n {
        let t = (k as f64 * 0.005).min(end);
        let st = replay.spline.state(t);
        let (a, alpha) = (st.a.norm(), st.alpha_w.norm());
        if a > lim_a || alpha > lim_alpha {
            return Err(unusable(format!(
                "the fitted spline rings at t = {:.3} s (file time {:.6} s): {a:.1} m/s² and {alpha:.1} rad/s², where the recording never exceeds {accel_max:.1} m/s² and {alpha_max:.1} rad/s²; the simulated IMU would measure the fit, not the motion (irregular stamps? try a larger knot spacing or repair)",
                t,
                t + replay.t_file0
            )));
        }
    }
    Ok(())
}

/// Reads, checks, repairs (when asked), places and fits a recorded trajectory.
pub fn load_recording(
    text: &str,
    options: &RecordingOptions,
) -> Result<(Replay, RecordingReport), TrajectoryError> {
    let rec = parse_recording(text)?;
    let raw: Vec<f64> = rec.samples.iter().map(|s| s.t).collect();
    let spacing_raw = median(raw.windows(2).map(|w| w[1] - w[0]).collect());
    let default = if rec.asl {
        TimeUnit::Nanoseconds
    } else {
        TimeUnit::Seconds
    };
    let (unit, unit_detected) = match options.time_unit {
        Some(u) => (u, false),
        None => detect_unit(spacing_raw, default)?,
    };
    let lines = rec.lines;
    let samples: Vec<PoseSample> = rec
        .samples
        .into_iter()
        .map(|s| PoseSample {
            t: s.t * unit.seconds(),
            ..s
        })
        .collect();
    if let Some(w) = samples.windows(2).position(|w| w[1].t <= w[0].t) {
        return Err(unusable(format!(
            "line {}: timestamp {} does not follow the previous one ({}): stamps must increase strictly",
            lines[w + 1],
            samples[w + 1].t,
            samples[w].t
        )));
    }
    let median_spacing_s = spacing_raw * unit.seconds();
    let span = samples[samples.len() - 1].t - samples[0].t;
    let knots = span / options.knot_spacing_s;
    if knots > crate::limits::MAX_SPLINE_KNOTS {
        return Err(unusable(format!(
            "{knots:.3e} spline knots (span {span:.1} s / knot spacing {} s) exceed the limit of {:.0e}",
            options.knot_spacing_s,
            crate::limits::MAX_SPLINE_KNOTS
        )));
    }
    // Glitches.
    let h = (5.0 * median_spacing_s).max(0.05);
    let accel = motion_accelerations(&samples, h, 0.99);
    let found = find_glitches(&samples, accel);
    let mut glitches: Vec<Glitch> = found
        .iter()
        .map(|&(i, dp, dq)| Glitch {
            line: lines[i],
            t_s: samples[i].t,
            position_m: dp,
            angle_deg: dq.to_degrees(),
        })
        .collect();
    glitches.sort_by_key(|g| g.line);
    if let Some(g) = glitches.first()
        && !options.repair
    {
        return Err(unusable(format!(
            "line {}: the sample at t = {:.6} s departs {:.4} m / {:.2}° from its neighbours, far beyond the motion's own statistics ({} such samples); set `repair = true` to drop them",
            g.line,
            g.t_s,
            g.position_m,
            g.angle_deg,
            glitches.len()
        )));
    }
    let limit = ((samples.len() as f64 * MAX_GLITCH_FRACTION).ceil() as usize).max(10);
    if glitches.len() > limit {
        return Err(unusable(format!(
            "more than {limit} glitches (first at line {}): the recording is not a trajectory to repair",
            glitches[0].line
        )));
    }
    let mut drop = vec![false; samples.len()];
    for &(i, _, _) in &found {
        drop[i] = true;
    }
    let mut kept: Vec<(usize, PoseSample)> = samples
        .iter()
        .enumerate()
        .filter(|(i, _)| !drop[*i])
        .map(|(i, s)| (lines[i], *s))
        .collect();
    // Jumps: excursions (dropped when repairing, like glitches) and steps (never repaired).
    let kept_samples: Vec<PoseSample> = kept.iter().map(|(_, s)| *s).collect();
    // Jumps within the fit tolerance are the fit's to absorb (as they always were).
    let mut jumps = find_jumps(&kept_samples, accel);
    let beyond = |j: &Jump| {
        let (m, rad) = j.size();
        m > options.fit_tolerance_m || rad > options.fit_tolerance_rad
    };
    jumps.steps.retain(beyond);
    jumps.excursions.retain(|e| beyond(&e.2));
    if let Some(step) = jumps.steps.first()
        && !options.repair
    {
        let (m, rad) = step.size();
        return Err(unusable(format!(
            "line {}: the recording jumps {m:.4} m / {:.2}° at t = {:.6} s, far beyond what the motion can do in {:.4} s, and does not jump back within {MAX_EXCURSION_S} s: a step (the tracker found the body elsewhere), not a glitch; which side is true cannot be told from the recording: set `repair = true` to bridge it with a motion-limited blend (the simulated motion then leaves the file near the step), or cut the recording at this line",
            kept[step.index + 1].0,
            rad.to_degrees(),
            kept_samples[step.index].t,
            kept_samples[step.index + 1].t - kept_samples[step.index].t
        )));
    }
    let steps = blend_steps(&mut kept, &jumps.steps, accel)?;
    if let Some(&(first, last, jump)) = jumps.excursions.first()
        && !options.repair
    {
        let (m, rad) = jump.size();
        return Err(unusable(format!(
            "lines {}–{}: the recording jumps {m:.4} m / {:.2}° at t = {:.6} s and back {:.3} s later ({} samples off the path; {} such excursions); set `repair = true` to drop them",
            kept[first].0,
            kept[last].0,
            rad.to_degrees(),
            kept_samples[first].t,
            kept_samples[last + 1].t - kept_samples[first].t,
            last + 1 - first,
            jumps.excursions.len()
        )));
    }
    let mut off_path = vec![false; kept.len()];
    for &(first, last, jump) in &jumps.excursions {
        for (k, flag) in off_path.iter_mut().enumerate().take(last + 1).skip(first) {
            *flag = true;
            let (dp, dq) = jump.size();
            glitches.push(Glitch {
                line: kept[k].0,
                t_s: kept_samples[k].t,
                position_m: dp,
                angle_deg: dq.to_degrees(),
            });
        }
    }
    glitches.sort_by_key(|g| g.line);
    let kept: Vec<(usize, PoseSample)> = kept
        .into_iter()
        .zip(off_path)
        .filter(|(_, off)| !off)
        .map(|(k, _)| k)
        .collect();
    // Gaps.
    let gap_s = (10.0 * median_spacing_s).max(2.0 * options.knot_spacing_s);
    let gaps: Vec<Gap> = kept
        .windows(2)
        .filter(|w| w[1].1.t - w[0].1.t > gap_s)
        .map(|w| Gap {
            line: w[1].0,
            t_s: w[0].1.t,
            length_s: w[1].1.t - w[0].1.t,
        })
        .collect();
    if let Some(g) = gaps.first() {
        if !options.repair {
            return Err(unusable(format!(
                "line {}: no samples for {:.3} s after t = {:.6} s (the median spacing is {:.4} s): the spline would ring through the gap; set `repair = true` to bridge it",
                g.line, g.length_s, g.t_s, median_spacing_s
            )));
        }
        if let Some(g) = gaps.iter().find(|g| g.length_s > MAX_BRIDGE_S) {
            return Err(unusable(format!(
                "line {}: a gap of {:.3} s after t = {:.6} s is longer than the {MAX_BRIDGE_S} s that can be bridged",
                g.line, g.length_s, g.t_s
            )));
        }
    }
    let kept_samples: Vec<PoseSample> = kept.iter().map(|(_, s)| *s).collect();
    let mut filled = Vec::with_capacity(kept_samples.len());
    let mut bridged_samples = 0;
    for i in 0..kept_samples.len() {
        filled.push(kept_samples[i]);
        if i + 1 < kept_samples.len() && kept_samples[i + 1].t - kept_samples[i].t > gap_s {
            let b = bridge(
                &GapEnd::new(&kept_samples, i, h, -1),
                &GapEnd::new(&kept_samples, i + 1, h, 1),
                median_spacing_s,
            );
            bridged_samples += b.len();
            filled.extend(b);
        }
    }
    if let Some((r, t)) = options.placement {
        for s in &mut filled {
            s.p = r * s.p + t;
            s.q = r * s.q;
        }
    }
    let (accel_max, alpha_max) = motion_accelerations(&filled, h, 1.0);
    let replay = Replay::from_samples(filled, options.knot_spacing_s)?;
    check_ringing(&replay, accel_max, alpha_max)?;
    // Fit check against the kept (recorded) samples.
    let (mut fit_m, mut fit_rad, mut worst) = (0.0f64, 0.0f64, (0.0f64, 0usize));
    for (line, s) in &kept {
        let (p, q) = match options.placement {
            Some((r, t)) => (r * s.p + t, r * s.q),
            None => (s.p, s.q),
        };
        let state = replay.spline_state_at_file_time(s.t);
        let (dp, dq) = ((state.p - p).norm(), state.q.angle_to(&q));
        let ratio = (dp / options.fit_tolerance_m).max(dq / options.fit_tolerance_rad);
        if ratio > worst.0 {
            worst = (ratio, *line);
        }
        fit_m = fit_m.max(dp);
        fit_rad = fit_rad.max(dq);
    }
    let worst_line = worst.1;
    if fit_m > options.fit_tolerance_m || fit_rad > options.fit_tolerance_rad {
        return Err(unusable(format!(
            "the fitted spline departs from the recording by up to {fit_m:.4} m / {:.2}° (worst near line {worst_line}), beyond the tolerance of {} m / {:.2}°: the knot spacing ({} s) is too coarse for this motion",
            fit_rad.to_degrees(),
            options.fit_tolerance_m,
            options.fit_tolerance_rad.to_degrees(),
            options.knot_spacing_s
        )));
    }
    let report = RecordingReport {
        time_unit: unit,
        unit_detected,
        samples: samples.len(),
        median_spacing_s,
        glitches,
        steps,
        gaps,
        bridged_samples,
        fit_max_m: fit_m,
        fit_max_deg: fit_rad.to_degrees(),
    };
    Ok((replay, report))
}

impl Replay {
    /// Reads a TUM or EuRoC ASL file and fits it, with the checks of
    /// [`load_recording`] (no repair). Bytes that are not UTF-8 (a Latin-1
    /// comment) are replaced, not refused: only the numbers matter.
    pub fn from_file(path: &Path, knot_spacing_s: f64) -> Result<Self, TrajectoryError> {
        let bytes = crate::input_file::read(path).map_err(|e| TrajectoryError::Io {
            path: path.display().to_string(),
            source: e,
        })?;
        let options = RecordingOptions {
            knot_spacing_s,
            ..Default::default()
        };
        load_recording(&String::from_utf8_lossy(&bytes), &options).map(|(replay, _)| replay)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stationary recording with one sample 30° off after a 0.25 s gap, fitted without the
    /// glitch and gap checks: the spline rings, and the check says so.
    #[test]
    fn a_ringing_fit_is_refused() {
        let mut samples = Vec::new();
        let mut t = 0.0;
        for k in 0..400 {
            let q = if k == 200 {
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 30f64.to_radians())
            } else {
                UnitQuaternion::identity()
            };
            samples.push(PoseSample {
                t,
                p: Vector3::new(0.0, 0.0, 1.0),
                q,
            });
            t += if k == 199 { 0.25 } else { 0.005 };
        }
        let clean: Vec<PoseSample> = samples
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != 200)
            .map(|(_, s)| *s)
            .collect();
        let (a, alpha) = motion_accelerations(&clean, 0.05, 1.0);
        let replay = Replay::from_samples(samples, 0.04).unwrap();
        let err = check_ringing(&replay, a, alpha).unwrap_err().to_string();
        assert!(err.contains("rings"), "{err}");
        let fine = Replay::from_samples(clean, 0.04).unwrap();
        assert!(check_ringing(&fine, a, alpha).is_ok());
    }
}
