//! `report.json` ([`Report`]): what a run did, how well, what it expected and whether it
//! passed, built from its context, output and evaluation.

use estimator::EventKind as EstimatorEventKind;
use estimator::frontend::TrackSummary;
use serde::Serialize;

use super::calibration_error::{self, CalibrationReport};
use super::context::RunContext;
use super::evaluation::{Evaluation, RPE_DELTA_M};
use super::gnss::{self, GnssReport};
use super::recovery;
use super::replay::ReplayReport;
use super::rest::{self, RestReport, RestSpeeds};
use super::static_trajectory::StaticTrajectoryReport;
use super::window_vs_batch::{self, BatchReport};
use super::window_vs_filter::{self, FilterReport};
use crate::frontend::FrontendStats;
use crate::run_output::{EventKind, OutsideRun, RunOutput};

/// Median, 99th percentile and maximum (ms).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    /// Median.
    pub median: f64,
    /// 99th percentile (nearest rank).
    pub p99: f64,
    /// Maximum.
    pub max: f64,
}

impl Stats {
    /// Statistics of `values_s` (seconds) in milliseconds; zeros when empty.
    pub fn from_seconds(values_s: impl Iterator<Item = f64>) -> Self {
        let mut v: Vec<f64> = values_s.map(|s| s * 1e3).collect();
        if v.is_empty() {
            return Self::default();
        }
        v.sort_by(f64::total_cmp);
        let rank = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        Self {
            median: rank(0.5),
            p99: rank(0.99),
            max: v[v.len() - 1],
        }
    }
}

/// `timing_ms` of the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TimingReport {
    /// Front end per frame.
    pub frontend: Stats,
    /// Back end per frame.
    pub backend: Stats,
    /// Total per frame.
    pub total: Stats,
    /// Rendering per frame; `null` for feature-level scenarios.
    pub render: Option<Stats>,
}

/// One event of the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EventReport {
    /// Time (s).
    pub t_s: f64,
    /// `status_change`, `input_rejected`, `suite_switch`, `prior_dropped`, `reset`, `gnss_aligned`,
    /// `gnss_alignment_dropped` or `calibration_released`.
    pub kind: &'static str,
    /// Details.
    pub detail: String,
}

/// One fault of the report.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FaultReport {
    /// Fault kind.
    pub kind: String,
    /// Start (s).
    pub start_s: f64,
    /// End (s); `null` for permanent faults.
    pub end_s: Option<f64>,
    /// Delay (s) from the fault's end to the return of the sensor suite live at its start (0
    /// when it caused no suite switch; `null` when the suite never came back).
    pub back_s: Option<f64>,
    /// Position error (m, aligned as the ATE) of the first tracking frame at the fault's end.
    pub error_at_end_m: Option<f64>,
    /// Position error (m) 10 s after the fault's end.
    pub error_10s_after_m: Option<f64>,
    /// Resets from the fault's start to 10 s after its end.
    pub resets: usize,
}

/// One checked expectation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExpectationResult {
    /// Metric name (a report field).
    pub metric: &'static str,
    /// Lower bound.
    pub min: Option<f64>,
    /// Upper bound.
    pub max: Option<f64>,
    /// The measured value.
    pub value: Option<f64>,
    /// Whether the bound holds.
    pub passed: bool,
}

/// `report.json`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Scenario name.
    pub scenario: String,
    /// Its one-line description.
    pub description: String,
    /// `stereo_imu` or `stereo`.
    pub suite: &'static str,
    /// Seed used.
    pub seed: u64,
    /// Processed frames (estimates).
    pub frames: usize,
    /// Frames in tracking state: initialized, with at least
    /// `EstimatorConfig::min_tracking_observations` landmark observations in the newest frame.
    pub tracking_frames: usize,
    /// Frames initialized but degraded: too few visual constraints (IMU propagation, a dead
    /// camera, no features); evaluated with the tracking frames.
    pub degraded_frames: usize,
    /// `tracking_frames / frames`.
    pub tracking_fraction: f64,
    /// Simulated duration (s).
    pub duration_s: f64,
    /// `position_yaw` or `se3`.
    pub alignment: &'static str,
    /// Position ATE RMSE (m).
    pub ate_rmse_m: Option<f64>,
    /// Rotation ATE RMSE (deg).
    pub ate_rot_rmse_deg: Option<f64>,
    /// RPE translation RMSE (m): relative poses over `rpe_delta_m` of ground-truth path (see
    /// the module documentation); `null` when the path is shorter.
    pub rpe_trans_rmse_m: Option<f64>,
    /// RPE pair spacing (m of ground-truth path): [`RPE_DELTA_M`].
    pub rpe_delta_m: f64,
    /// Estimator resets.
    pub resets: usize,
    /// Sensor-suite switches (a sensor went silent or came back; see `events`).
    pub suite_switches: usize,
    /// IMU samples excluded as spikes.
    pub imu_samples_excluded: usize,
    /// IMU samples on the sensor's range (clipped; the intervals over them carry no IMU factor).
    pub imu_samples_saturated: usize,
    /// Persistent points given a new first estimate (`point_relinearize_fraction`).
    pub points_relinearized: usize,
    /// Final gyroscope bias error (rad/s).
    pub gyro_bias_error_rad_s: Option<f64>,
    /// Final accelerometer bias error (m/s²).
    pub accel_bias_error_m_s2: Option<f64>,
    /// Per-frame timing statistics (ms).
    pub timing_ms: TimingReport,
    /// Camera mode: `features` or `rendered` (simulated), `recorded` (`vio euroc`).
    pub camera_mode: &'static str,
    /// The graphics adapter that rendered the images (`null` for feature-level scenarios).
    pub renderer: Option<String>,
    /// The image front end's statistics against ground truth (`null` unless the estimator
    /// tracked rendered images).
    pub frontend: Option<FrontendStats>,
    /// What the image front end did, no ground truth needed: features, track lengths, stereo
    /// matches, rejections (runs on images, rendered or recorded; absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frontend_tracks: Option<TrackSummary>,
    /// Events.
    pub events: Vec<EventReport>,
    /// The scenario's faults.
    pub faults: Vec<FaultReport>,
    /// The window against the full batch over its keyframes (`vio run --batch-reference`;
    /// `null` otherwise).
    pub batch_reference: Option<BatchReport>,
    /// The window against the full-information filter at checkpoints during the run (`vio run
    /// --batch-reference`; `null` otherwise).
    pub filter_reference: Option<FilterReport>,
    /// What the checks of a replayed recording found and did (`null` for generated motions).
    pub replay: Option<ReplayReport>,
    /// The estimated time offset and extrinsics against the truth (`null` unless the scenario
    /// studies calibration: a calibration error, a camera time offset or online estimation).
    pub calibration: Option<CalibrationReport>,
    /// A ground truth too short or static to align: the drift and tilt from the first pose that
    /// replace the ATE (absent otherwise).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub static_trajectory: Option<StaticTrajectoryReport>,
    /// Zero-velocity detection against the truth and the drift during rests (`null` when the
    /// body never rests and nothing was detected, or without ground truth).
    pub rest: Option<RestReport>,
    /// The fused position in the GNSS receiver's frame against the truth (`null` unless the
    /// estimator aligned with a receiver, or without ground truth).
    pub gnss: Option<GnssReport>,
    /// Simulated time (s) at which the run was interrupted (Ctrl-C); `null` when complete. An
    /// interrupted run does not pass.
    pub interrupted_at_s: Option<f64>,
    /// The outside estimator that produced the estimates: its adapter, command, how it ended,
    /// and why the run fails when it does (absent for ours).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimator: Option<OutsideRun>,
    /// Checked expectations.
    pub expectations: Vec<ExpectationResult>,
    /// True when every expectation holds.
    pub passed: bool,
    /// `vio` version.
    pub vio_version: &'static str,
}

impl Report {
    /// The value of a metric an expectation may bound.
    pub fn metric(&self, name: &str) -> Option<f64> {
        match name {
            "ate_rmse_m" => self.ate_rmse_m,
            "ate_rot_rmse_deg" => self.ate_rot_rmse_deg,
            "rpe_trans_rmse_m" => self.rpe_trans_rmse_m,
            "resets" => Some(self.resets as f64),
            "suite_switches" => Some(self.suite_switches as f64),
            "imu_samples_excluded" => Some(self.imu_samples_excluded as f64),
            "imu_samples_saturated" => Some(self.imu_samples_saturated as f64),
            // The slowest return of the full suite over the faults (none if one never did).
            "recovery_s" => self
                .faults
                .iter()
                .map(|f| f.back_s)
                .try_fold(0.0f64, |m, b| Some(m.max(b?))),
            "tracking_fraction" => Some(self.tracking_fraction),
            "position_drift_m" => self.static_trajectory.as_ref().map(|s| s.position_drift_m),
            "tilt_error_deg" => self
                .static_trajectory
                .as_ref()
                .and_then(|s| s.tilt_error_max_deg),
            "gyro_bias_error_rad_s" => self.gyro_bias_error_rad_s,
            "accel_bias_error_m_s2" => self.accel_bias_error_m_s2,
            "frontend_features_min" => self.frontend.map(|f| f.features_min as f64),
            "frontend_track_error_median_px" => self.frontend.map(|f| f.track_error_median_px),
            "frontend_track_error_p95_px" => self.frontend.map(|f| f.track_error_p95_px),
            "frontend_wrong_after_ransac" => self.frontend.map(|f| f.wrong_after_ransac),
            "frontend_stereo_error_median_px" => self.frontend.map(|f| f.stereo_error_median_px),
            "gnss_global_rmse_m" => self.gnss.as_ref().map(|g| g.global_rmse_m),
            "gnss_aligned_at_s" => self.gnss.as_ref().map(|g| g.aligned_at_s),
            _ => None,
        }
    }
}

/// The metrics an expectation may bound for an outside estimator: its trajectory's.
const OUTSIDE_ESTIMATOR_METRICS: [&str; 6] = [
    "ate_rmse_m",
    "ate_rot_rmse_deg",
    "rpe_trans_rmse_m",
    "tracking_fraction",
    "position_drift_m",
    "tilt_error_deg",
];

/// The metrics an expectation may bound without ground truth.
const GROUND_TRUTH_FREE: [&str; 5] = [
    "tracking_fraction",
    "resets",
    "suite_switches",
    "imu_samples_excluded",
    "imu_samples_saturated",
];

/// An estimator event's `kind` and `detail` in `report.json`.
fn estimator_event(kind: &EstimatorEventKind) -> (&'static str, String) {
    match kind {
        EstimatorEventKind::SuiteSwitch { from, to, reason } => {
            ("suite_switch", format!("{from} -> {to} ({reason})"))
        }
        EstimatorEventKind::ImuSamplesExcluded { t_ns } => {
            ("imu_samples_excluded", t_ns.len().to_string())
        }
        EstimatorEventKind::ImuSamplesSaturated { count } => {
            ("imu_samples_saturated", count.to_string())
        }
        EstimatorEventKind::PriorDropped => ("prior_dropped", String::new()),
        EstimatorEventKind::GnssAligned => ("gnss_aligned", String::new()),
        EstimatorEventKind::GnssAlignmentDropped => ("gnss_alignment_dropped", String::new()),
        EstimatorEventKind::CalibrationReleased { detail } => {
            ("calibration_released", detail.clone())
        }
        EstimatorEventKind::Reset { reason } => ("reset", reason.clone()),
    }
}

/// Builds the report of a run described by `ctx` and checks its expectations.
pub fn build_report(ctx: &RunContext, run: &RunOutput, eval: &Evaluation) -> Report {
    let frames = &run.frames;
    let timing_ms = TimingReport {
        frontend: Stats::from_seconds(frames.iter().map(|f| f.timing.frontend_s)),
        backend: Stats::from_seconds(frames.iter().map(|f| f.timing.backend_s)),
        total: Stats::from_seconds(frames.iter().map(|f| f.timing.total_s)),
        render: run
            .renderer
            .is_some()
            .then(|| Stats::from_seconds(frames.iter().map(|f| f.timing.render_s))),
    };
    let events = run
        .events
        .iter()
        .map(|e| {
            let (kind, detail) = match &e.kind {
                EventKind::StatusChange { from, to } => {
                    ("status_change", format!("{from:?} -> {to:?}"))
                }
                EventKind::InputRejected(m) => ("input_rejected", m.clone()),
                EventKind::Estimator(kind) => estimator_event(kind),
            };
            EventReport {
                t_s: e.t_ns as f64 * 1e-9,
                kind,
                detail,
            }
        })
        .collect();
    let switches: Vec<recovery::Switch> = run
        .events
        .iter()
        .filter_map(|e| match &e.kind {
            EventKind::Estimator(EstimatorEventKind::SuiteSwitch { from, to, .. }) => {
                Some(recovery::Switch {
                    t_s: e.t_ns as f64 * 1e-9,
                    from: from.to_string(),
                    to: to.to_string(),
                })
            }
            _ => None,
        })
        .collect();
    let errors = eval.position_errors(run);
    let faults = ctx
        .faults
        .iter()
        .map(|&(ref kind, a, b)| FaultReport {
            kind: kind.clone(),
            start_s: a,
            end_s: b.is_finite().then_some(b),
            back_s: recovery::back_after(&switches, a, b),
            error_at_end_m: recovery::error_at(&errors, b),
            error_10s_after_m: recovery::error_at(&errors, b + recovery::AFTER_S),
            resets: run
                .events
                .iter()
                .filter(|e| {
                    matches!(
                        e.kind,
                        EventKind::Estimator(EstimatorEventKind::Reset { .. })
                    )
                })
                .filter(|e| (a..=b + recovery::AFTER_S).contains(&(e.t_ns as f64 * 1e-9)))
                .count(),
        })
        .collect();
    let mut report = Report {
        scenario: run.scenario.clone(),
        description: ctx.description.clone(),
        suite: ctx.suite.as_str(),
        seed: run.seed,
        frames: frames.len(),
        tracking_frames: eval.tracking_frames,
        degraded_frames: eval.degraded_frames,
        tracking_fraction: eval.tracking_fraction,
        duration_s: run.duration_s,
        alignment: eval.alignment_name(),
        ate_rmse_m: eval.ate_rmse_m(),
        ate_rot_rmse_deg: eval.ate_rot_rmse_deg(),
        rpe_trans_rmse_m: eval.rpe_trans_rmse_m(),
        rpe_delta_m: RPE_DELTA_M,
        resets: run.resets,
        suite_switches: run.suite_switches,
        imu_samples_excluded: run.imu_samples_excluded,
        imu_samples_saturated: run.imu_samples_saturated,
        points_relinearized: run.points_relinearized,
        gyro_bias_error_rad_s: eval.gyro_bias_error_rad_s,
        accel_bias_error_m_s2: eval.accel_bias_error_m_s2,
        timing_ms,
        camera_mode: if ctx.recorded {
            "recorded"
        } else if run.renderer.is_some() {
            "rendered"
        } else {
            "features"
        },
        renderer: run.renderer.clone(),
        frontend: run.frontend,
        frontend_tracks: run.frontend_tracks,
        events,
        faults,
        batch_reference: window_vs_batch::batch_report(run, eval.alignment),
        filter_reference: window_vs_filter::filter_report(run, eval.alignment),
        replay: ctx.replay.clone(),
        // An outside estimator reports poses only: no calibration, velocity or GNSS frame.
        calibration: ctx
            .calibration_truth
            .as_ref()
            .filter(|_| run.outside.is_none())
            .and_then(|t| calibration_error::calibration_report(t, run)),
        static_trajectory: eval
            .static_trajectory
            .as_ref()
            .filter(|_| ctx.ground_truth)
            .map(StaticTrajectoryReport::new),
        rest: rest::rest_report(
            run,
            if ctx.recorded {
                RestSpeeds::RECORDED
            } else {
                RestSpeeds::SIMULATED
            },
        )
        .filter(|_| ctx.ground_truth && run.outside.is_none()),
        gnss: gnss::gnss_report(run).filter(|_| ctx.ground_truth),
        interrupted_at_s: run.interrupted_at_s,
        estimator: run.outside.clone(),
        expectations: Vec::new(),
        passed: true,
        vio_version: env!("CARGO_PKG_VERSION"),
    };
    let mut bounds = ctx.expectations.clone();
    let path_m: f64 = frames
        .windows(2)
        .map(|w| (w[1].truth.pose.p - w[0].truth.pose.p).norm())
        .sum();
    let defaults = recovery::default_bounds(path_m, &bounds, eval.static_trajectory.is_some());
    bounds.extend(defaults);
    if !ctx.ground_truth {
        report.ate_rmse_m = None;
        report.ate_rot_rmse_deg = None;
        report.rpe_trans_rmse_m = None;
        report.gyro_bias_error_rad_s = None;
        report.accel_bias_error_m_s2 = None;
        report.faults.clear();
        // Without ground truth only what needs none is checked: a run that never tracked does
        // not pass.
        bounds.retain(|(metric, _)| GROUND_TRUTH_FREE.contains(metric));
    }
    if run.outside.is_some() {
        // An outside estimator is judged on its trajectory: bounds on our estimator's own
        // figures (its front end, biases, events) do not apply to it.
        bounds.retain(|(metric, _)| OUTSIDE_ESTIMATOR_METRICS.contains(metric));
    }
    report.expectations = bounds
        .into_iter()
        .map(|(metric, b)| {
            let value = report.metric(metric);
            ExpectationResult {
                metric,
                min: b.min,
                max: b.max,
                value,
                passed: b.check(value),
            }
        })
        .collect();
    let outside_failed = run.outside.as_ref().is_some_and(|o| o.failure.is_some());
    report.passed = report.expectations.iter().all(|e| e.passed)
        && report.interrupted_at_s.is_none()
        && !outside_failed;
    report
}
