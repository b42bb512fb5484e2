//! Reports: evaluation of a run against ground truth, `report.json`, the TUM files, the
//! trajectory plot and the human summary `vio run` prints.
//!
//! Evaluation uses the estimates in tracking state only (during initialization the estimate is
//! not yet in a gravity-aligned world frame). Stereo+IMU estimates are aligned to ground truth by
//! position + yaw (the 4 unobservable degrees of freedom); vision-only estimates by a rigid SE(3)
//! alignment (their world frame is the first camera pose, not gravity-aligned).
//!
//! Files written to the output folder:
//! - `estimate.tum`: the tracking-state estimates `T_w_b`, unaligned, in the estimator's world;
//! - `groundtruth.tum`: ground truth at every processed frame's time (a superset of the estimate
//!   stamps, so `evo_ape tum groundtruth.tum estimate.tum` associates exactly);
//! - `report.json`: the fields below ([`Report`]);
//! - `trajectory.png`: top view of ground truth vs the aligned estimate, and the position error
//!   over time ([`crate::plot`]).

use std::fmt::Write as _;
use std::path::Path;

use estimator::estimator::Status;
use estimator::geometry::Pose;
use serde::Serialize;

use crate::interim::{self, Alignment};
use crate::plot::{self, PlotData};
use crate::run::{EventKind, RunOutput};
use crate::spec::{Scenario, SuiteSpec};

/// Time step of the relative pose error (s).
pub const RPE_DELTA_S: f64 = 1.0;

/// Metrics of a run against ground truth.
#[derive(Clone, Debug)]
pub struct Evaluation {
    /// `position_yaw` or `se3`.
    pub alignment_kind: &'static str,
    /// The alignment (identity without tracking frames).
    pub alignment: Alignment,
    /// Indices (into `RunOutput::frames`) of the evaluated frames (tracking state).
    pub evaluated: Vec<usize>,
    /// Position ATE RMSE (m).
    pub ate_rmse_m: Option<f64>,
    /// Rotation ATE RMSE (deg).
    pub ate_rot_rmse_deg: Option<f64>,
    /// Per evaluated frame: position error (m).
    pub errors_m: Vec<f64>,
    /// RPE translation RMSE over [`RPE_DELTA_S`] (m).
    pub rpe_trans_rmse_m: Option<f64>,
    /// Fraction of processed frames in tracking state.
    pub tracking_fraction: f64,
    /// Final gyroscope bias error (rad/s), with an IMU.
    pub gyro_bias_error_rad_s: Option<f64>,
    /// Final accelerometer bias error (m/s²), with an IMU.
    pub accel_bias_error_m_s2: Option<f64>,
}

/// Evaluates a run (see the module documentation).
pub fn evaluate(run: &RunOutput, suite: SuiteSpec) -> Evaluation {
    let evaluated: Vec<usize> = run
        .frames
        .iter()
        .enumerate()
        .filter(|(_, f)| f.estimate.status == Status::Tracking)
        .map(|(i, _)| i)
        .collect();
    let est: Vec<Pose> = evaluated
        .iter()
        .map(|&i| run.frames[i].estimate.T_w_b)
        .collect();
    let gt: Vec<Pose> = evaluated
        .iter()
        .map(|&i| run.frames[i].truth.pose)
        .collect();
    let pe: Vec<_> = est.iter().map(|p| p.p).collect();
    let pg: Vec<_> = gt.iter().map(|p| p.p).collect();
    let (alignment_kind, alignment) = match suite {
        SuiteSpec::StereoImu => ("position_yaw", interim::align_position_yaw(&pe, &pg)),
        SuiteSpec::Stereo => ("se3", interim::align_se3(&pe, &pg)),
    };
    let (ate_rmse_m, ate_rot_rmse_deg, errors_m) = if est.is_empty() {
        (None, None, Vec::new())
    } else {
        let a = interim::ate(&est, &gt, &alignment);
        (Some(a.rmse_m), Some(a.rot_rmse_deg), a.errors_m)
    };
    let stamped: Vec<interim::Stamped> = evaluated
        .iter()
        .map(|&i| (run.frames[i].estimate.t_ns, run.frames[i].estimate.T_w_b))
        .collect();
    let rpe_trans_rmse_m =
        interim::rpe_trans_rmse(&stamped, &gt, (RPE_DELTA_S * 1e9).round() as i64);
    let last = evaluated.last().map(|&i| &run.frames[i]);
    let (gyro_bias_error_rad_s, accel_bias_error_m_s2) = match (suite, last) {
        (SuiteSpec::StereoImu, Some(f)) => (
            Some((f.estimate.bg - f.truth.gyro_bias).norm()),
            Some((f.estimate.ba - f.truth.accel_bias).norm()),
        ),
        _ => (None, None),
    };
    Evaluation {
        alignment_kind,
        alignment,
        tracking_fraction: evaluated.len() as f64 / run.frames.len().max(1) as f64,
        evaluated,
        ate_rmse_m,
        ate_rot_rmse_deg,
        errors_m,
        rpe_trans_rmse_m,
        gyro_bias_error_rad_s,
        accel_bias_error_m_s2,
    }
}

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
    /// `status_change` or `input_rejected`.
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
    /// Frames in tracking state (evaluated).
    pub tracking_frames: usize,
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
    /// RPE translation RMSE (m) over `rpe_delta_s`.
    pub rpe_trans_rmse_m: Option<f64>,
    /// RPE time step (s).
    pub rpe_delta_s: f64,
    /// Estimator resets.
    pub resets: usize,
    /// Final gyroscope bias error (rad/s).
    pub gyro_bias_error_rad_s: Option<f64>,
    /// Final accelerometer bias error (m/s²).
    pub accel_bias_error_m_s2: Option<f64>,
    /// Per-frame timing statistics (ms).
    pub timing_ms: TimingReport,
    /// Events.
    pub events: Vec<EventReport>,
    /// The scenario's faults.
    pub faults: Vec<FaultReport>,
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
            "tracking_fraction" => Some(self.tracking_fraction),
            "gyro_bias_error_rad_s" => self.gyro_bias_error_rad_s,
            "accel_bias_error_m_s2" => self.accel_bias_error_m_s2,
            _ => None,
        }
    }
}

/// Builds the report of a run and checks the scenario's expectations.
pub fn build_report(scenario: &Scenario, run: &RunOutput, eval: &Evaluation) -> Report {
    let spec = &scenario.spec;
    let frames = &run.frames;
    let timing_ms = TimingReport {
        frontend: Stats::from_seconds(frames.iter().map(|f| f.timing.frontend_s)),
        backend: Stats::from_seconds(frames.iter().map(|f| f.timing.backend_s)),
        total: Stats::from_seconds(frames.iter().map(|f| f.timing.total_s)),
        render: None,
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
            };
            EventReport {
                t_s: e.t_ns as f64 * 1e-9,
                kind,
                detail,
            }
        })
        .collect();
    let faults = scenario
        .fault_intervals()
        .into_iter()
        .map(|(kind, a, b)| FaultReport {
            kind,
            start_s: a,
            end_s: b.is_finite().then_some(b),
        })
        .collect();
    let mut report = Report {
        scenario: run.scenario.clone(),
        description: spec.description.clone(),
        suite: spec.suite.as_str(),
        seed: run.seed,
        frames: frames.len(),
        tracking_frames: eval.evaluated.len(),
        tracking_fraction: eval.tracking_fraction,
        duration_s: run.duration_s,
        alignment: eval.alignment_kind,
        ate_rmse_m: eval.ate_rmse_m,
        ate_rot_rmse_deg: eval.ate_rot_rmse_deg,
        rpe_trans_rmse_m: eval.rpe_trans_rmse_m,
        rpe_delta_s: RPE_DELTA_S,
        resets: run.resets,
        gyro_bias_error_rad_s: eval.gyro_bias_error_rad_s,
        accel_bias_error_m_s2: eval.accel_bias_error_m_s2,
        timing_ms,
        events,
        faults,
        expectations: Vec::new(),
        passed: true,
        vio_version: env!("CARGO_PKG_VERSION"),
    };
    report.expectations = spec
        .expectations
        .bounds()
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
    report.passed = report.expectations.iter().all(|e| e.passed);
    report
}

fn opt(v: Option<f64>, digits: usize, unit: &str) -> String {
    match v {
        Some(v) => format!("{v:.digits$}{unit}"),
        None => "n/a".into(),
    }
}

/// The short human summary `vio run` prints.
pub fn summary(report: &Report, out_dir: Option<&Path>) -> String {
    let mut s = String::new();
    let r = report;
    let _ = writeln!(
        s,
        "scenario      {} ({}, seed {})",
        r.scenario, r.suite, r.seed
    );
    let _ = writeln!(
        s,
        "frames        {} processed, {} tracking ({:.1} %), {:.1} s simulated",
        r.frames,
        r.tracking_frames,
        100.0 * r.tracking_fraction,
        r.duration_s
    );
    let _ = writeln!(
        s,
        "ATE           {} RMSE, rotation {} RMSE ({} alignment)",
        opt(r.ate_rmse_m, 4, " m"),
        opt(r.ate_rot_rmse_deg, 3, "°"),
        r.alignment.replace('_', "+")
    );
    let _ = writeln!(
        s,
        "RPE           {} translation RMSE over {} s",
        opt(r.rpe_trans_rmse_m, 4, " m"),
        r.rpe_delta_s
    );
    if r.gyro_bias_error_rad_s.is_some() {
        let _ = writeln!(
            s,
            "final biases  gyro error {}, accel error {}",
            opt(r.gyro_bias_error_rad_s, 5, " rad/s"),
            opt(r.accel_bias_error_m_s2, 4, " m/s²")
        );
    }
    let t = &r.timing_ms;
    let _ = writeln!(
        s,
        "timing        per frame median / p99 / max: backend {:.2} / {:.2} / {:.2} ms, total {:.2} / {:.2} / {:.2} ms, frontend {:.3} ms",
        t.backend.median,
        t.backend.p99,
        t.backend.max,
        t.total.median,
        t.total.p99,
        t.total.max,
        t.frontend.median
    );
    let _ = writeln!(s, "resets        {}", r.resets);
    if r.expectations.is_empty() {
        let _ = writeln!(s, "expectations  none");
    } else {
        let _ = writeln!(s, "expectations");
        for e in &r.expectations {
            let bound = match (e.min, e.max) {
                (Some(a), Some(b)) => format!("in [{a}, {b}]"),
                (Some(a), None) => format!("≥ {a}"),
                (None, Some(b)) => format!("≤ {b}"),
                (None, None) => String::new(),
            };
            let _ = writeln!(
                s,
                "  {:<24} {:<14} {:>12}  {}",
                e.metric,
                bound,
                opt(e.value, 4, ""),
                if e.passed { "pass" } else { "FAIL" }
            );
        }
    }
    let _ = write!(
        s,
        "result        {}",
        if r.passed {
            "PASS"
        } else {
            "FAIL (an expectation is not met)"
        }
    );
    if let Some(d) = out_dir {
        let _ = write!(s, "; files in {}", d.display());
    }
    s.push('\n');
    s
}

/// The plot data of a run.
pub fn plot_data(scenario: &Scenario, run: &RunOutput, eval: &Evaluation) -> PlotData {
    let gt_all = run
        .frames
        .iter()
        .map(|f| (f.truth.pose.p.x, f.truth.pose.p.y))
        .collect();
    let est = eval
        .evaluated
        .iter()
        .map(|&i| {
            let p = eval.alignment.apply(&run.frames[i].estimate.T_w_b).p;
            (p.x, p.y)
        })
        .collect();
    let errors = eval
        .evaluated
        .iter()
        .zip(&eval.errors_m)
        .map(|(&i, e)| (run.frames[i].estimate.t_ns as f64 * 1e-9, *e))
        .collect();
    let tracking_from_s = eval
        .evaluated
        .first()
        .map(|&i| run.frames[i].estimate.t_ns as f64 * 1e-9);
    PlotData {
        title: format!(
            "{} ({}, seed {})",
            run.scenario,
            scenario.spec.suite.as_str(),
            run.seed
        ),
        ground_truth_xy: gt_all,
        estimate_xy: est,
        error_m: errors,
        duration_s: run.duration_s,
        tracking_from_s,
        faults: scenario
            .fault_intervals()
            .into_iter()
            .map(|(k, a, b)| (k, a, b.min(run.duration_s)))
            .collect(),
        ate_rmse_m: eval.ate_rmse_m,
        alignment: eval.alignment_kind,
    }
}

/// Writes `estimate.tum`, `groundtruth.tum`, `report.json` and `trajectory.png` into `dir`
/// (created if needed).
pub fn write_outputs(
    dir: &Path,
    scenario: &Scenario,
    run: &RunOutput,
    eval: &Evaluation,
    report: &Report,
) -> Result<(), String> {
    let io = |what: &str, e: std::io::Error| format!("cannot write {what}: {e}");
    std::fs::create_dir_all(dir).map_err(|e| io(&dir.display().to_string(), e))?;
    let est: Vec<interim::Stamped> = eval
        .evaluated
        .iter()
        .map(|&i| (run.frames[i].estimate.t_ns, run.frames[i].estimate.T_w_b))
        .collect();
    let gt: Vec<interim::Stamped> = run
        .frames
        .iter()
        .map(|f| (f.estimate.t_ns, f.truth.pose))
        .collect();
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| io(&p.display().to_string(), e))
    };
    write("estimate.tum", &interim::tum_string(&est))?;
    write("groundtruth.tum", &interim::tum_string(&gt))?;
    let json = serde_json::to_string_pretty(report).map_err(|e| e.to_string())?;
    write("report.json", &(json + "\n"))?;
    let png = plot::trajectory_png(&plot_data(scenario, run, eval))?;
    let p = dir.join("trajectory.png");
    std::fs::write(&p, png).map_err(|e| io(&p.display().to_string(), e))?;
    Ok(())
}
