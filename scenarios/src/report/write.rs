//! The files of a run's output folder and the trajectory plot's data.

use std::path::Path;

use estimator::geometry::Pose;

use super::calibration_error;
use super::context::RunContext;
use super::evaluation::Evaluation;
use super::gnss;
use super::report_json::Report;
use crate::dataset::{self, StampedPose};
use crate::plot::{self, PlotData};
use crate::run_output::RunOutput;

/// The plot data of a run.
pub fn plot_data(ctx: &RunContext, run: &RunOutput, eval: &Evaluation) -> PlotData {
    let gt_all = run
        .frames
        .iter()
        .map(|f| (f.truth.pose.p.x, f.truth.pose.p.y))
        .collect();
    // Without an alignment (too few or degenerate positions) there is no estimate to draw in the
    // ground truth's frame, and no error.
    let est = match &eval.ate {
        Ok(ate) => eval
            .evaluated
            .iter()
            .map(|&i| {
                let p = ate
                    .alignment
                    .transform_pose(&run.frames[i].estimate.T_w_b)
                    .p;
                (p.x, p.y)
            })
            .collect(),
        Err(_) => Vec::new(),
    };
    let errors = eval.position_errors(run);
    let tracking_from_s = eval
        .evaluated
        .first()
        .map(|&i| run.frames[i].estimate.t_ns as f64 * 1e-9);
    PlotData {
        title: format!(
            "{} ({}, seed {})",
            run.scenario,
            ctx.suite.as_str(),
            run.seed
        ),
        ground_truth_xy: gt_all,
        estimate_xy: est,
        error_m: errors,
        duration_s: run.duration_s,
        tracking_from_s,
        faults: ctx
            .faults
            .iter()
            .map(|(k, a, b)| (k.clone(), *a, b.min(run.duration_s)))
            .collect(),
        ate_rmse_m: eval.ate_rmse_m(),
        alignment: eval.alignment_name(),
    }
}

/// Every file a run may write into its output folder. Each run first removes those of them a
/// previous run left there (and nothing else), so a folder never mixes two runs' outputs: a
/// plain run after a `--batch-reference` one no longer leaves the old `batch.tum` beside it.
pub const RUN_OUTPUT_FILES: [&str; 11] = [
    "estimate.tum",
    "estimate_source_time.tum",
    "groundtruth.tum",
    "batch.tum",
    "window.tum",
    "filter.tum",
    "report.json",
    "trajectory.png",
    "calibration.png",
    "gnss.png",
    "run.mcap",
];

/// Writes `estimate.tum`, `groundtruth.tum`, `report.json` and `trajectory.png` of a run
/// described by `ctx` into `dir` (created if needed), after removing what an earlier run left
/// there ([`RUN_OUTPUT_FILES`]); without ground truth
/// ([`RunContext::ground_truth`] false) only `estimate.tum`, `estimate_source_time.tum` and
/// `report.json`; and `run.mcap` ([`super::write_run_bag`]) when the run recorded its window
/// ([`crate::run::RunOptions::scene`], `--mcap`).
pub fn write_outputs(
    dir: &Path,
    ctx: &RunContext,
    run: &RunOutput,
    eval: &Evaluation,
    report: &Report,
) -> Result<(), String> {
    let io = |what: &str, e: std::io::Error| format!("cannot write {what}: {e}");
    std::fs::create_dir_all(dir).map_err(|e| io(&dir.display().to_string(), e))?;
    for name in RUN_OUTPUT_FILES {
        let p = dir.join(name);
        match std::fs::remove_file(&p) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(format!(
                    "cannot remove the earlier run's {}: {e}",
                    p.display()
                ));
            }
            _ => {}
        }
    }
    let est: Vec<StampedPose> = eval
        .evaluated
        .iter()
        .map(|&i| StampedPose::new(run.frames[i].estimate.t_ns, run.frames[i].estimate.T_w_b))
        .collect();
    let gt: Vec<StampedPose> = run
        .frames
        .iter()
        .map(|f| StampedPose::new(f.estimate.t_ns, f.truth.pose))
        .collect();
    dataset::write_tum(dir.join("estimate.tum"), &est).map_err(|e| e.to_string())?;
    // A recording's run starts its clock at 0: the same estimates on the source's clock, so
    // `vio eval --gt SOURCE.tum` associates.
    if let Some(shift_ns) = ctx.source_time_offset_ns {
        let source: Vec<StampedPose> = est
            .iter()
            .map(|s| StampedPose::new(s.t_ns + shift_ns, s.pose))
            .collect();
        dataset::write_tum(dir.join("estimate_source_time.tum"), &source)
            .map_err(|e| e.to_string())?;
    }
    if ctx.ground_truth {
        dataset::write_tum(dir.join("groundtruth.tum"), &gt).map_err(|e| e.to_string())?;
    }
    // Only where a batch was solved (a run that never tracked has none).
    if let Some(reference) = run.batch_reference.as_ref().filter(|r| r.summary.is_some()) {
        // Frames leave the window out of time order (a non-keyframe before older keyframes).
        let stamped = |poses: &[(i64, Pose)]| -> Vec<StampedPose> {
            let mut out: Vec<StampedPose> =
                poses.iter().map(|&(t, p)| StampedPose::new(t, p)).collect();
            out.sort_by_key(|s| s.t_ns);
            out
        };
        dataset::write_tum(dir.join("batch.tum"), &stamped(&reference.batch))
            .map_err(|e| e.to_string())?;
        dataset::write_tum(dir.join("window.tum"), &stamped(&reference.finalized))
            .map_err(|e| e.to_string())?;
    }
    // The full-information filter's estimate of each checkpoint's newest frame (the window's
    // own estimates of those frames are in `estimate.tum`).
    if let Some(reference) = run
        .batch_reference
        .as_ref()
        .filter(|r| !r.checkpoints.is_empty())
    {
        let filter: Vec<StampedPose> = reference
            .checkpoints
            .iter()
            .map(|c| StampedPose::new(c.t_ns, c.filter.pose))
            .collect();
        dataset::write_tum(dir.join("filter.tum"), &filter).map_err(|e| e.to_string())?;
    }
    let write = |name: &str, text: &str| {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| io(&p.display().to_string(), e))
    };
    let json = serde_json::to_string_pretty(report).map_err(|e| e.to_string())?;
    write("report.json", &(json + "\n"))?;
    if ctx.ground_truth {
        let png = plot::trajectory_png(&plot_data(ctx, run, eval))?;
        let p = dir.join("trajectory.png");
        std::fs::write(&p, png).map_err(|e| io(&p.display().to_string(), e))?;
    }
    if let Some(c) = &report.calibration {
        let png = calibration_error::calibration_png(&report.scenario, c)?;
        let p = dir.join("calibration.png");
        std::fs::write(&p, png).map_err(|e| io(&p.display().to_string(), e))?;
    }
    if let Some(g) = &report.gnss {
        let png = gnss::gnss_png(&report.scenario, g)?;
        let p = dir.join("gnss.png");
        std::fs::write(&p, png).map_err(|e| io(&p.display().to_string(), e))?;
    }
    if run.frames.iter().any(|f| f.scene.is_some()) {
        super::write_run_bag(&dir.join("run.mcap"), ctx, run, eval, report)?;
    }
    Ok(())
}
