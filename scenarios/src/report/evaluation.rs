//! The evaluation of a run against its ground truth: the alignment, ATE, RPE and the static
//! checks (the definitions are the module doc of [`crate::report`]).

use estimator::Status;
use estimator::geometry::Pose;

use crate::metrics::{
    self, Alignment, AteResult, MetricsError, RpeOptions, RpeResult, StaticTrajectory,
};
use crate::run_output::RunOutput;
use crate::spec::SuiteSpec;

/// Pair spacing of the relative pose error: metres of ground-truth path.
pub const RPE_DELTA_M: f64 = 1.0;

impl Evaluation {
    /// `(time s, position error m)` of the evaluated frames after the ATE's alignment, in time
    /// order; empty without an ATE.
    pub fn position_errors(&self, run: &RunOutput) -> Vec<(f64, f64)> {
        match &self.ate {
            Ok(ate) => self
                .evaluated
                .iter()
                .zip(&ate.translation_errors)
                .map(|(&i, e)| (run.frames[i].estimate.t_ns as f64 * 1e-9, *e))
                .collect(),
            Err(_) => Vec::new(),
        }
    }
}

/// [`default_alignment`] in words, for the outputs of many runs (sweeps, regressions).
pub const ALIGNMENT_RULE: &str = "ATE after each run's suite alignment, as vio run and vio eval align it: position+yaw with an IMU, SE(3) for stereo";

/// The alignment a suite's estimate is scored with, by `vio run`, `sweep`, `regress` and (by
/// default) `vio eval`: position + yaw with an IMU (gravity is observed, 4 DoF are not), a rigid
/// SE(3) alignment for stereo-only (its world frame is the first camera pose).
pub fn default_alignment(suite: SuiteSpec) -> Alignment {
    match suite {
        SuiteSpec::StereoImu | SuiteSpec::MonoImu => Alignment::PosYaw,
        SuiteSpec::Stereo => Alignment::Se3,
    }
}

/// Metrics of a run against ground truth.
#[derive(Clone, Debug)]
pub struct Evaluation {
    /// [`Alignment::PosYaw`] (stereo+IMU) or [`Alignment::Se3`] (stereo-only).
    pub alignment: Alignment,
    /// Indices (into `RunOutput::frames`) of the evaluated frames (after initialization).
    pub evaluated: Vec<usize>,
    /// ATE over the evaluated frames, with the alignment's transform and per-frame errors (in
    /// `evaluated` order); why not, when it cannot be computed.
    pub ate: Result<AteResult, MetricsError>,
    /// RPE over [`RPE_DELTA_M`] of ground-truth path; why not, when no pair qualifies.
    pub rpe: Result<RpeResult, MetricsError>,
    /// Frames in tracking state.
    pub tracking_frames: usize,
    /// Fraction of processed frames in tracking state (visual constraints on the newest
    /// frame; [`Status::Tracking`]).
    pub tracking_fraction: f64,
    /// Frames initialized but without enough visual constraints ([`Status::Degraded`]).
    pub degraded_frames: usize,
    /// Final gyroscope bias error (rad/s), with an IMU.
    pub gyro_bias_error_rad_s: Option<f64>,
    /// Final accelerometer bias error (m/s²), with an IMU.
    pub accel_bias_error_m_s2: Option<f64>,
    /// A ground truth too short or static to determine the alignment: why, and the errors
    /// from the first evaluated pose. `ate` then holds the errors after that anchoring, and
    /// the report's ATE figures are `null`.
    pub static_trajectory: Option<StaticTrajectory>,
}

impl Evaluation {
    /// The alignment's name in `report.json`: `position_yaw` or `se3`; `first_pose` for a
    /// static trajectory.
    pub fn alignment_name(&self) -> &'static str {
        if self.static_trajectory.is_some() {
            return "first_pose";
        }
        alignment_name(self.alignment)
    }

    /// Position ATE RMSE (m); `None` for a static trajectory.
    pub fn ate_rmse_m(&self) -> Option<f64> {
        self.aligned_ate().map(|a| a.translation.rmse)
    }

    /// Rotation ATE RMSE (deg); `None` for a static trajectory.
    pub fn ate_rot_rmse_deg(&self) -> Option<f64> {
        self.aligned_ate().map(|a| a.rotation_deg.rmse)
    }

    /// The ATE after an alignment the ground truth determines.
    fn aligned_ate(&self) -> Option<&AteResult> {
        self.ate
            .as_ref()
            .ok()
            .filter(|_| self.static_trajectory.is_none())
    }

    /// RPE translation RMSE over [`RPE_DELTA_M`] (m).
    pub fn rpe_trans_rmse_m(&self) -> Option<f64> {
        self.rpe.as_ref().ok().map(|r| r.translation.rmse)
    }
}

/// The name `report.json` and the summary use for an alignment.
fn alignment_name(a: Alignment) -> &'static str {
    match a {
        Alignment::PosYaw => "position_yaw",
        other => other.name(),
    }
}

/// Evaluates a run (see the module documentation).
pub fn evaluate(run: &RunOutput, suite: SuiteSpec) -> Evaluation {
    let evaluated: Vec<usize> = run
        .frames
        .iter()
        .enumerate()
        .filter(|(_, f)| f.estimate.status.initialized())
        .map(|(i, _)| i)
        .collect();
    let tracking_frames = run
        .frames
        .iter()
        .filter(|f| f.estimate.status == Status::Tracking)
        .count();
    let est: Vec<Pose> = evaluated
        .iter()
        .map(|&i| run.frames[i].estimate.T_w_b)
        .collect();
    let gt: Vec<Pose> = evaluated
        .iter()
        .map(|&i| run.frames[i].truth.pose)
        .collect();
    let alignment = default_alignment(suite);
    let (ate, static_trajectory) = match metrics::ate_or_anchored(&gt, &est, alignment) {
        Ok((ate, st)) => (Ok(ate), st),
        Err(e) => (Err(e), None),
    };
    let rpe = metrics::rpe(&gt, &est, &RpeOptions::meters(RPE_DELTA_M));
    let last = evaluated.last().map(|&i| &run.frames[i]);
    let (gyro_bias_error_rad_s, accel_bias_error_m_s2) = match (suite, last) {
        (SuiteSpec::StereoImu | SuiteSpec::MonoImu, Some(f)) => (
            Some((f.estimate.bg - f.truth.gyro_bias).norm()),
            Some((f.estimate.ba - f.truth.accel_bias).norm()),
        ),
        _ => (None, None),
    };
    Evaluation {
        alignment,
        tracking_frames,
        tracking_fraction: tracking_frames as f64 / run.frames.len().max(1) as f64,
        degraded_frames: run
            .frames
            .iter()
            .filter(|f| f.estimate.status == Status::Degraded)
            .count(),
        evaluated,
        ate,
        rpe,
        gyro_bias_error_rad_s,
        accel_bias_error_m_s2,
        static_trajectory,
    }
}
