//! What the checks of a replayed recording found and did, as `report.json` holds it
//! ([`sim::motion::recording`]), and the source-time estimate file.

use serde::Serialize;
use sim::motion::recording::{BlendedStep, RecordingReport};

use crate::report::recorded_imu::RecordedImuReport;

/// `report.json` → `replay`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ReplayReport {
    /// Samples in the file.
    pub samples: usize,
    /// Unit of the stamps (`s`, `ms`, `us`, `ns`).
    pub time_unit: &'static str,
    /// Whether the unit was detected from the stamp spacing.
    pub time_unit_detected: bool,
    /// Median stamp spacing (s).
    pub median_spacing_s: f64,
    /// Glitch samples (dropped: the scenario asked for `repair`).
    pub glitches_dropped: usize,
    /// Lines of the dropped samples.
    pub glitch_lines: Vec<usize>,
    /// Largest position departure of a dropped sample from its neighbours (m).
    pub largest_glitch_m: f64,
    /// Largest attitude departure of a dropped sample from its neighbours (deg).
    pub largest_glitch_deg: f64,
    /// Steps bridged by a motion-limited blend (`repair`): the simulated motion leaves the file
    /// by up to half a step near each, so score against the run's ground truth, not the file.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub steps_blended: Vec<BlendedStep>,
    /// Gaps bridged.
    pub gaps_bridged: usize,
    /// Longest bridged gap (s).
    pub longest_gap_s: f64,
    /// Samples added across the gaps.
    pub bridged_samples: usize,
    /// Largest departure of the fitted spline from a kept sample (m).
    pub fit_max_m: f64,
    /// Largest attitude departure of the fitted spline from a kept sample (deg).
    pub fit_max_deg: f64,
    /// The recorded IMU log the run used instead of the simulated IMU, and its checks (absent
    /// without `rig.imu.recorded`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recorded_imu: Option<RecordedImuReport>,
}

impl From<&RecordingReport> for ReplayReport {
    fn from(r: &RecordingReport) -> Self {
        let fold = |f: fn(&sim::motion::recording::Glitch) -> f64| {
            r.glitches.iter().map(f).fold(0.0, f64::max)
        };
        Self {
            samples: r.samples,
            time_unit: r.time_unit.name(),
            time_unit_detected: r.unit_detected,
            median_spacing_s: r.median_spacing_s,
            glitches_dropped: r.glitches.len(),
            glitch_lines: r.glitches.iter().map(|g| g.line).collect(),
            largest_glitch_m: fold(|g| g.position_m),
            largest_glitch_deg: fold(|g| g.angle_deg),
            steps_blended: r.steps.clone(),
            gaps_bridged: r.gaps.len(),
            longest_gap_s: r.gaps.iter().map(|g| g.length_s).fold(0.0, f64::max),
            bridged_samples: r.bridged_samples,
            fit_max_m: r.fit_max_m,
            fit_max_deg: r.fit_max_deg,
            recorded_imu: None,
        }
    }
}
