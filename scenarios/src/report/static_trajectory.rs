//! `report.json` → `static_trajectory`: a run whose ground truth is too short or static to
//! determine the alignment ([`crate::metrics::static_trajectory`]) is scored from its first evaluated
//! pose: position drift, rotation drift and tilt error replace the aligned ATE (see
//! `metrics::anchored`).

use serde::Serialize;

use crate::metrics::StaticTrajectory;

/// `report.json` → `static_trajectory`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StaticTrajectoryReport {
    /// Why the run is scored from its first pose.
    pub reason: String,
    /// The ground truth's spread in the directions the alignment needs (m).
    pub ground_truth_spread_m: f64,
    /// How the estimate was placed on the ground truth at the first evaluated pose:
    /// `position_yaw` (gravity-aligned estimates) or `pose`.
    pub anchored: &'static str,
    /// The largest position error after the anchoring (m).
    pub position_drift_m: f64,
    /// The last evaluated frame's position error (m).
    pub position_drift_final_m: f64,
    /// The last evaluated frame's rotation error after the anchoring (deg).
    pub rotation_drift_final_deg: f64,
    /// RMS of the tilt error (deg): the angle between the estimated and the true gravity
    /// direction in the body frame (gravity-aligned estimates; `null` otherwise).
    pub tilt_error_rms_deg: Option<f64>,
    /// The largest tilt error (deg).
    pub tilt_error_max_deg: Option<f64>,
}

impl StaticTrajectoryReport {
    /// The report section of a trajectory scored from its first pose.
    pub fn new(st: &StaticTrajectory) -> Self {
        let d = &st.drift;
        let tilt = d.tilt_deg();
        Self {
            reason: st.reason.clone(),
            ground_truth_spread_m: st.spread_m,
            anchored: if d.gravity_aligned {
                "position_yaw"
            } else {
                "pose"
            },
            position_drift_m: d.max_position_m(),
            position_drift_final_m: d.final_position_m(),
            rotation_drift_final_deg: d.final_rotation_deg(),
            tilt_error_rms_deg: tilt.map(|t| t.rmse),
            tilt_error_max_deg: tilt.map(|t| t.max),
        }
    }
}
