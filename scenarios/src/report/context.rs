//! [`RunContext`]: where a run came from, as far as its report, plot and files are concerned.

use super::recorded_imu::RecordedImuReport;
use super::replay::ReplayReport;
use crate::run_output::RunOutput;
use crate::spec::{Bound, CalibrationTruth, Scenario, SuiteSpec};

/// Where a run came from, as far as its report, plot and files are concerned: a scenario
/// ([`RunContext::of`]) or a recorded dataset (`vio euroc`).
#[derive(Clone, Debug)]
pub struct RunContext {
    /// One-line description.
    pub description: String,
    /// The sensor suite (picks the alignment and the bias metrics).
    pub suite: SuiteSpec,
    /// Fault intervals `(kind, start s, end s)` (end infinite for permanent faults).
    pub faults: Vec<(String, f64, f64)>,
    /// Bounds to check, `(metric, bound)`.
    pub expectations: Vec<(&'static str, Bound)>,
    /// What the checks of a replayed recording found and did.
    pub replay: Option<ReplayReport>,
    /// The recording's own clock: added to the estimate stamps (ns) for
    /// `estimate_source_time.tum`; `None`: that file is not written.
    pub source_time_offset_ns: Option<i64>,
    /// The true calibration when the run studies it (the report then has a `calibration`
    /// block).
    pub calibration_truth: Option<CalibrationTruth>,
    /// A recorded dataset (`vio euroc`) rather than a simulation.
    pub recorded: bool,
    /// Whether the run's frames carry ground truth. Without it the report's error metrics are
    /// `null`, only expectations that need no ground truth are checked (tracking, resets, the
    /// IMU counts), and neither `groundtruth.tum` nor the plot is written.
    pub ground_truth: bool,
}

impl RunContext {
    /// The context of a scenario run: what its files and plot need. The checks of a recorded
    /// IMU log, which need the run, are added by [`RunContext::with_run`].
    pub fn of(scenario: &Scenario) -> Self {
        let spec = &scenario.spec;
        Self {
            description: spec.description.clone(),
            suite: spec.suite,
            faults: scenario.fault_intervals(),
            expectations: spec.expectations.bounds(),
            replay: scenario.recording_report().map(ReplayReport::from),
            // A replay without a static start runs on the recording's clock shifted to start
            // at 0.
            source_time_offset_ns: scenario
                .recording_start_ns()
                .filter(|_| spec.trajectory.static_start.is_none()),
            calibration_truth: scenario.calibration_truth(),
            recorded: false,
            ground_truth: true,
        }
    }

    /// The context of a recorded dataset's run (`description`, fused with `suite`): no
    /// expectations; the dataset's stamp of the run's 0 is `t0_ns`; `ground_truth` whether it
    /// has any.
    pub fn recorded(description: String, suite: SuiteSpec, t0_ns: i64, ground_truth: bool) -> Self {
        Self {
            description,
            suite,
            faults: Vec::new(),
            expectations: Vec::new(),
            replay: None,
            source_time_offset_ns: Some(t0_ns),
            calibration_truth: None,
            recorded: true,
            ground_truth,
        }
    }

    /// [`RunContext::of`] with the checks of the scenario's recorded IMU log over the run's
    /// span (`replay.recorded_imu`): what its report needs.
    pub fn with_run(scenario: &Scenario, run: &RunOutput) -> Self {
        let mut ctx = Self::of(scenario);
        if let (Some(replay), Some(log)) = (ctx.replay.as_mut(), scenario.recorded_imu()) {
            let end_ns = (run.duration_s * 1e9).round() as i64;
            replay.recorded_imu = Some(RecordedImuReport::new(log, end_ns, &scenario.imu_noise()));
        }
        ctx
    }
}
