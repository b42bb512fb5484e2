//! Monte-Carlo consistency (`vio nees`): N seeds of one scenario, each run deterministic and
//! independent (run in parallel, gathered in seed order), and the NEES of the estimator's
//! newest-state covariance averaged over the runs at every frame time, for the states an
//! IMU suite can observe:
//! - `velocity`: the body-frame velocity (3 dof; the world-frame one rotates with the
//!   unobservable yaw);
//! - `accel_bias`, `gyro_bias` (3 dof each);
//! - `roll_pitch`: the tilt, the world x and y components of the rotation error (2 dof), after
//!   the run's position+yaw alignment (the ATE's);
//! - `relative_pose`: the newest pose relative to the window frame about
//!   `relative_pose_interval_s` (0.5 s) earlier, `[δp in the earlier frame, δθ]` (6 dof). It
//!   needs no alignment: the relative motion is observable, yaw and position included.
//!
//! For N runs, `N · ε̄ₖ` of a consistent estimator is χ²(N·dof) at each time k, so ε̄ₖ lies in
//! `[χ²₀.₀₂₅(N·dof), χ²₀.₉₇₅(N·dof)] / N` with 95 % probability. A metric passes when its
//! average over time lies in that band. Only frames at which every run is tracking and has a
//! covariance count. Quantiles by the Wilson–Hilferty approximation (relative error < 1 % for
//! N·dof ≥ 10, < 0.02 % at N·dof = 75: 25 runs of 3 dof).
//!
//! An outside estimator (`estimator_adapter`) takes part when its adapter names a covariance
//! file (`external::state_covariance`): its newest state's NEES is read the same way, over
//! [`OUTSIDE_METRICS`].

use std::collections::BTreeMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use estimator::Estimate;
use estimator::geometry::{Pose, skew, so3_log};
use estimator::odometry::{FilterEstimate, RelativePose, chi2_quantile};
use nalgebra::{DMatrix, Matrix3, SMatrix, Vector3, Vector6};
use serde::Serialize;
use sim::stream::GroundTruth;

use crate::metrics::{self, Alignment, Sim3};
use crate::pipeline::{ReportedRun, RunInput, run_to_report};
use crate::run::{RunControl, RunError, RunOptions, RunOutput};
use crate::spec::{Scenario, SuiteSpec};

/// The metrics, in report order: name and degrees of freedom.
pub const METRICS: [(&str, usize); 5] = [
    ("velocity", 3),
    ("accel_bias", 3),
    ("gyro_bias", 3),
    ("roll_pitch", 2),
    ("relative_pose", 6),
];

/// The metrics of an outside estimator, whose covariance file holds the newest state's
/// covariance only (no relative pose's).
pub const OUTSIDE_METRICS: [&str; 4] = ["velocity", "accel_bias", "gyro_bias", "roll_pitch"];

/// Settings of a NEES study.
#[derive(Clone, Debug)]
pub struct NeesOptions {
    /// The seeds, one run each.
    pub seeds: Vec<u64>,
    /// Duration (s) instead of the scenario's.
    pub duration_s: Option<f64>,
    /// Worker threads (the result does not depend on it).
    pub threads: usize,
    /// Also solve the full-information filter at checkpoints (`vio run --batch-reference`)
    /// and compare its NEES with the window's there.
    pub batch_reference: bool,
}

/// One metric's NEES over time.
#[derive(Clone, Debug, Serialize)]
pub struct NeesMetric {
    /// Metric name (see [`METRICS`]).
    pub name: &'static str,
    /// Degrees of freedom.
    pub dof: usize,
    /// The two-sided 95 % band of the run-averaged NEES.
    pub band: [f64; 2],
    /// Run-averaged NEES averaged over time.
    pub time_average: f64,
    /// Whether `time_average` lies in `band`.
    pub inside: bool,
    /// Fraction of frame times whose run-averaged NEES lies in the band.
    pub fraction_in_band: f64,
    /// `(t s, run-averaged NEES)` at every counted frame time.
    pub series: Vec<(f64, f64)>,
}

/// `nees.json`.
#[derive(Clone, Debug, Serialize)]
pub struct NeesReport {
    /// Scenario name.
    pub scenario: String,
    /// The seeds run.
    pub seeds: Vec<u64>,
    /// Each run's position ATE (m), in seed order.
    pub ate_rmse_m: Vec<Option<f64>>,
    /// Median back-end time per frame with the covariance computed, over all runs (ms).
    pub backend_ms_median: f64,
    /// The metrics.
    pub metrics: Vec<NeesMetric>,
    /// Whether every metric's time average is inside its band.
    pub passed: bool,
    /// With `batch_reference`: the window's and the full-information filter's NEES at the
    /// filter checkpoints (every 2 s, a tenth of a shorter run).
    pub filter_reference: Option<FilterNees>,
}

/// The window and the full-information filter at the same checkpoints, each against the truth
/// with its own covariance: a window as consistent as the filter it approximates reads like it.
#[derive(Clone, Debug, Serialize)]
pub struct FilterNees {
    /// The window's NEES at the checkpoints.
    pub window: Vec<NeesMetric>,
    /// The filter's.
    pub filter: Vec<NeesMetric>,
}

/// The two-sided 95 % band of the NEES averaged over `runs` runs.
pub fn band(runs: usize, dof: usize) -> [f64; 2] {
    const Z: f64 = 1.959_963_984_540_054;
    [
        chi2_quantile(runs * dof, -Z) / runs as f64,
        chi2_quantile(runs * dof, Z) / runs as f64,
    ]
}

/// Runs the study: every seed of `options`, then the metrics.
pub fn run_nees(scenario: &Scenario, options: &NeesOptions) -> Result<NeesReport, RunError> {
    run_nees_until(scenario, options, None).map(|r| r.expect("nothing stops it: every seed ran"))
}

/// [`run_nees`] that stops once `stop` is set (Ctrl-C): no seed starts, the runs under way
/// stop and are dropped, and the report covers the seeds that finished (`None` when none
/// did).
pub fn run_nees_until(
    scenario: &Scenario,
    options: &NeesOptions,
    stop: Option<&AtomicBool>,
) -> Result<Option<NeesReport>, RunError> {
    if scenario.spec.suite == SuiteSpec::Stereo {
        return Err(RunError::Estimator {
            file: scenario.file_label(),
            message: "vio nees needs an IMU suite (stereo_imu or mono_imu)".into(),
        });
    }
    if let Some(a) = scenario.adapter()
        && a.covariance.is_none()
    {
        return Err(RunError::Estimator {
            file: scenario.file_label(),
            message: format!(
                "vio nees needs the estimator's covariance, and the outside estimator `{}` (estimator_adapter) names no covariance file (the adapter's `covariance` key)",
                a.name
            ),
        });
    }
    if scenario.adapter().is_some() && options.batch_reference {
        return Err(RunError::Estimator {
            file: scenario.file_label(),
            message: "vio nees --batch-reference solves our estimator's full-information filter beside our window; an outside estimator (estimator_adapter) has neither".into(),
        });
    }
    let n = options.seeds.len();
    let results: Mutex<Vec<Option<Result<ReportedRun, RunError>>>> =
        Mutex::new((0..n).map(|_| None).collect());
    let next = AtomicUsize::new(0);
    let stopped = || stop.is_some_and(|s| s.load(Ordering::Relaxed));
    std::thread::scope(|s| {
        for _ in 0..options.threads.clamp(1, n.max(1)) {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= n || stopped() {
                        break;
                    }
                    let run_options = RunOptions {
                        seed: Some(options.seeds[i]),
                        duration_s: options.duration_s,
                        covariance: true,
                        batch_reference: options.batch_reference,
                        ..Default::default()
                    };
                    let control = RunControl {
                        progress: None,
                        stop,
                        workspace: None,
                    };
                    let out = run_to_report(RunInput::Scenario(scenario), &run_options, control);
                    if out
                        .as_ref()
                        .is_ok_and(|r| r.report.interrupted_at_s.is_some())
                    {
                        break;
                    }
                    results.lock().expect("no worker panicked")[i] = Some(out);
                }
            });
        }
    });
    let mut runs = Vec::with_capacity(n);
    let mut seeds = Vec::with_capacity(n);
    for (i, r) in results
        .into_inner()
        .expect("no worker panicked")
        .into_iter()
        .enumerate()
    {
        match r {
            Some(r) => {
                runs.push(r?);
                seeds.push(options.seeds[i]);
            }
            None if stopped() => {}
            None => unreachable!("every seed ran"),
        }
    }
    if runs.is_empty() {
        return Ok(None);
    }
    let finished = NeesOptions {
        seeds,
        ..options.clone()
    };
    Ok(Some(report(scenario, &finished, &runs)))
}

/// NEES of every metric at one frame of one run, `None` where it cannot be computed.
type FrameNees = [Option<f64>; METRICS.len()];

fn quadratic<const D: usize>(e: &SMatrix<f64, D, 1>, p: &SMatrix<f64, D, D>) -> Option<f64> {
    p.cholesky().map(|c| e.dot(&c.solve(e)))
}

/// A newest-state estimate with its covariance: the window's at a frame, or the
/// full-information filter's at a checkpoint.
struct NewestState<'a> {
    t_w_b: &'a Pose,
    v_w: &'a Vector3<f64>,
    ba: &'a Vector3<f64>,
    bg: &'a Vector3<f64>,
    /// 15×15 over `[δp, δθ, δv, δba, δbg]` (`Estimate::covariance`).
    covariance: &'a DMatrix<f64>,
    relative_pose: Option<&'a RelativePose>,
}

impl<'a> NewestState<'a> {
    /// The window's estimate, when it has an IMU suite's covariance.
    fn of_window(e: &'a Estimate) -> Option<Self> {
        Some(Self {
            t_w_b: &e.T_w_b,
            v_w: &e.v_w,
            ba: &e.ba,
            bg: &e.bg,
            covariance: e.covariance.as_ref().filter(|p| p.nrows() == 15)?,
            relative_pose: e.relative_pose.as_ref(),
        })
    }

    /// The filter's estimate at a checkpoint, when it has an IMU suite's covariance.
    fn of_filter(f: &'a FilterEstimate) -> Option<Self> {
        Some(Self {
            t_w_b: &f.pose,
            v_w: &f.v_w,
            ba: &f.ba,
            bg: &f.bg,
            covariance: f.covariance.as_ref().filter(|p| p.nrows() == 15)?,
            relative_pose: f.relative_pose.as_ref(),
        })
    }
}

/// The run's truth and its position+yaw alignment, for the NEES of its states.
struct RunTruth {
    align: Sim3,
    /// True pose at every processed frame time (IMU clock), for the relative poses.
    at: BTreeMap<i64, Pose>,
}

impl RunTruth {
    /// `None` when the run's estimates cannot be aligned (too few tracking frames).
    fn of(out: &RunOutput) -> Option<Self> {
        let frames = out
            .frames
            .iter()
            .filter(|f| f.estimate.status.initialized());
        let (gt, est): (Vec<_>, Vec<_>) = frames.map(|f| (f.truth.pose, f.estimate.T_w_b)).unzip();
        let align = metrics::estimate_alignment(&gt, &est, Alignment::PosYaw).ok()?;
        let at = out
            .frames
            .iter()
            .map(|f| (f.estimate.t_ns, f.truth.pose))
            .collect();
        Some(Self { align, at })
    }

    /// NEES of every metric of `e` against the truth `t`.
    fn nees(&self, e: &NewestState, t: &GroundTruth) -> FrameNees {
        let p = e.covariance;
        let r_est = e.t_w_b.q.to_rotation_matrix().into_inner();
        // Velocity in the body frame: δv_b = [v_b]× δθ + Rᵀ δv_w.
        let v_b = r_est.transpose() * e.v_w;
        let v_b_true = t.pose.q.to_rotation_matrix().into_inner().transpose() * t.v_w;
        let mut j = DMatrix::zeros(3, 15);
        j.view_mut((0, 3), (3, 3)).copy_from(&skew(&v_b));
        j.view_mut((0, 6), (3, 3)).copy_from(&r_est.transpose());
        let pv: Matrix3<f64> = (&j * p * j.transpose()).fixed_view::<3, 3>(0, 0).into();
        let velocity = quadratic(&(v_b_true - v_b), &pv);
        let block = |o: usize| -> Matrix3<f64> { p.fixed_view::<3, 3>(o, o).into() };
        let accel = quadratic(&(t.accel_bias - e.ba), &block(9));
        let gyro = quadratic(&(t.gyro_bias - e.bg), &block(12));
        // Tilt: the aligned estimate's rotation error in the world, x and y.
        let q_aligned = self.align.transform_pose(e.t_w_b).q;
        let r_aligned = q_aligned.to_rotation_matrix().into_inner();
        let dtheta_w: Vector3<f64> = r_aligned * so3_log(&(q_aligned.inverse() * t.pose.q));
        let jt = r_aligned.fixed_rows::<2>(0).into_owned();
        let p_tilt = jt * block(3) * jt.transpose();
        let tilt = quadratic(&dtheta_w.fixed_rows::<2>(0).into_owned(), &p_tilt);
        let relative = e.relative_pose.and_then(|r| {
            let t_a = self.at.get(&r.from_t_ns)?;
            let truth = t_a.inverse().compose(&t.pose);
            let mut err = Vector6::zeros();
            err.fixed_rows_mut::<3>(0).copy_from(&(truth.p - r.T_a_b.p));
            err.fixed_rows_mut::<3>(3)
                .copy_from(&so3_log(&(r.T_a_b.q.inverse() * truth.q)));
            quadratic(&err, &r.covariance)
        });
        [velocity, accel, gyro, tilt, relative]
    }
}

/// Per tracking frame with a covariance: `(camera stamp, NEES of each metric)`. Runs are
/// matched by camera stamp: an estimate's `t_ns` is on the IMU clock (`stamp + td`), and with
/// the offset estimated every seed has its own `td`.
fn run_nees_series(out: &RunOutput, truth: &RunTruth) -> Vec<(i64, FrameNees)> {
    out.frames
        .iter()
        .filter(|f| f.estimate.status.initialized())
        .filter_map(|f| {
            let e = NewestState::of_window(&f.estimate)?;
            Some((f.estimate.stamp_ns, truth.nees(&e, &f.truth)))
        })
        .collect()
}

/// At every filter checkpoint of the run (`--batch-reference`) where both have a covariance:
/// `(camera stamp, NEES of the window, NEES of the filter)`, the same newest frame.
fn checkpoint_nees_series(out: &RunOutput, truth: &RunTruth) -> Vec<(i64, FrameNees, FrameNees)> {
    let Some(reference) = out.batch_reference.as_ref() else {
        return Vec::new();
    };
    reference
        .checkpoints
        .iter()
        .filter_map(|c| {
            let f = out.frames.iter().find(|f| f.estimate.t_ns == c.t_ns)?;
            let window = NewestState::of_window(&f.estimate)?;
            let filter = NewestState::of_filter(&c.filter)?;
            Some((
                f.estimate.stamp_ns,
                truth.nees(&window, &f.truth),
                truth.nees(&filter, &f.truth),
            ))
        })
        .collect()
}

/// Per metric: frame time → (sum of NEES, runs with a value).
type NeesSums = Vec<BTreeMap<i64, (f64, usize)>>;

fn add_to_sums(sums: &mut NeesSums, t: i64, values: &FrameNees) {
    for (m, v) in values.iter().enumerate() {
        if let Some(v) = v {
            let e = sums[m].entry(t).or_insert((0.0, 0));
            e.0 += v;
            e.1 += 1;
        }
    }
}

/// The metrics of `n` runs' sums: the run-averaged NEES at the times every run has a value,
/// against the band of `n` runs.
fn metrics_of(sums: &NeesSums, n: usize) -> Vec<NeesMetric> {
    METRICS
        .iter()
        .zip(sums)
        .map(|(&(name, dof), by_t)| {
            let band = band(n, dof);
            let series: Vec<(f64, f64)> = by_t
                .iter()
                .filter(|(_, (_, c))| *c == n)
                .map(|(t, (s, _))| (*t as f64 * 1e-9, s / n as f64))
                .collect();
            let k = series.len().max(1) as f64;
            let time_average = series.iter().map(|(_, v)| v).sum::<f64>() / k;
            let in_band = series
                .iter()
                .filter(|(_, v)| (band[0]..=band[1]).contains(v))
                .count();
            NeesMetric {
                name,
                dof,
                band,
                time_average,
                inside: !series.is_empty() && (band[0]..=band[1]).contains(&time_average),
                fraction_in_band: in_band as f64 / k,
                series,
            }
        })
        .collect()
}

fn report(scenario: &Scenario, options: &NeesOptions, runs: &[ReportedRun]) -> NeesReport {
    let n = runs.len();
    let mut sums: NeesSums = vec![BTreeMap::new(); METRICS.len()];
    let (mut window_sums, mut filter_sums) = (sums.clone(), sums.clone());
    for r in runs {
        // A run whose estimates cannot be aligned (too few tracking frames) adds nothing.
        let Some(truth) = RunTruth::of(&r.output) else {
            continue;
        };
        for (t, values) in run_nees_series(&r.output, &truth) {
            add_to_sums(&mut sums, t, &values);
        }
        for (t, window, filter) in checkpoint_nees_series(&r.output, &truth) {
            add_to_sums(&mut window_sums, t, &window);
            add_to_sums(&mut filter_sums, t, &filter);
        }
    }
    let mut metrics = metrics_of(&sums, n);
    if scenario.adapter().is_some() {
        metrics.retain(|m| OUTSIDE_METRICS.contains(&m.name));
    }
    let filter_reference = options.batch_reference.then(|| FilterNees {
        window: metrics_of(&window_sums, n),
        filter: metrics_of(&filter_sums, n),
    });
    let mut backend: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.output.frames.iter().map(|f| f.timing.backend_s * 1e3))
        .collect();
    backend.sort_by(f64::total_cmp);
    let ate_rmse_m = runs.iter().map(|r| r.evaluation.ate_rmse_m()).collect();
    NeesReport {
        scenario: scenario.name.clone(),
        seeds: options.seeds.clone(),
        ate_rmse_m,
        backend_ms_median: backend.get(backend.len() / 2).copied().unwrap_or(0.0),
        passed: metrics.iter().all(|m| m.inside),
        metrics,
        filter_reference,
    }
}

/// The lines `vio nees` prints.
pub fn summary(r: &NeesReport) -> String {
    let mut s = format!(
        "scenario      {} ({} seeds: {}..={})\n",
        r.scenario,
        r.seeds.len(),
        r.seeds.first().copied().unwrap_or(0),
        r.seeds.last().copied().unwrap_or(0)
    );
    for m in &r.metrics {
        s += &format!(
            "  {:<13} dof {}  NEES {:>8.3}  band [{:.3}, {:.3}]  {}  ({:.0} % of {} frame times in band)\n",
            m.name,
            m.dof,
            m.time_average,
            m.band[0],
            m.band[1],
            if m.inside { "inside " } else { "OUTSIDE" },
            100.0 * m.fraction_in_band,
            m.series.len()
        );
    }
    if let Some(f) = &r.filter_reference {
        let points = f.window.first().map_or(0, |m| m.series.len());
        s += &format!(
            "filter ref    at {points} checkpoints, NEES window / full-information filter (band):\n"
        );
        for (w, fi) in f.window.iter().zip(&f.filter) {
            s += &format!(
                "  {:<13} {:>8.3} / {:>8.3}  [{:.3}, {:.3}]  window {}, filter {}\n",
                w.name,
                w.time_average,
                fi.time_average,
                w.band[0],
                w.band[1],
                if w.inside { "inside" } else { "OUTSIDE" },
                if fi.inside { "inside" } else { "OUTSIDE" },
            );
        }
    }
    s += &format!(
        "backend       {:.2} ms per frame (median, covariance included)\nresult        {}\n",
        r.backend_ms_median,
        if r.passed {
            "PASS"
        } else {
            "FAIL (a time-averaged NEES leaves its band)"
        }
    );
    s
}

/// Writes `nees.json` and `nees.png` into `dir` (created if needed); the written paths.
pub fn write_outputs(dir: &std::path::Path, r: &NeesReport) -> Result<Vec<String>, String> {
    let fail = |p: &std::path::Path, e: &dyn std::fmt::Display| format!("{}: {e}", p.display());
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, &e))?;
    let json_path = dir.join("nees.json");
    let json = serde_json::to_string_pretty(r).map_err(|e| fail(&json_path, &e))?;
    std::fs::write(&json_path, json + "\n").map_err(|e| fail(&json_path, &e))?;
    let panels: Vec<crate::plot::NeesPanel> = r
        .metrics
        .iter()
        .map(|m| crate::plot::NeesPanel {
            title: format!(
                "{} ({} dof): time average {:.2}, 95 % band [{:.2}, {:.2}]",
                m.name, m.dof, m.time_average, m.band[0], m.band[1]
            ),
            series: m.series.clone(),
            band: m.band,
        })
        .collect();
    let title = format!("{}: NEES averaged over {} seeds", r.scenario, r.seeds.len());
    let png = crate::plot::nees_png(&title, &panels)?;
    let png_path = dir.join("nees.png");
    std::fs::write(&png_path, png).map_err(|e| fail(&png_path, &e))?;
    Ok(vec![
        json_path.display().to_string(),
        png_path.display().to_string(),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_band_is_the_chi2_tables_over_the_runs() {
        // χ² tables, k = 75: 52.942 (2.5 %), 100.839 (97.5 %).
        let b = band(25, 3);
        assert!((b[0] - 52.942 / 25.0).abs() < 0.01 && (b[1] - 100.839 / 25.0).abs() < 0.01);
    }
}
