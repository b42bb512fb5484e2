//! `vio eval`: ATE and RPE of a trajectory file against ground truth, with evo's definitions.

use std::path::{Path, PathBuf};

use clap::ValueEnum;
use scenarios::dataset::{StampedPose, read_groundtruth_csv, read_tum};
use scenarios::metrics::{
    Alignment, EvalOptions, PairsFrom, RpeDelta, RpeOptions, Stats, associate_trajectories,
    evaluate,
};
use scenarios::report::default_alignment;
use scenarios::spec::SuiteSpec;
use serde_json::json;

#[derive(Clone, Copy, ValueEnum)]
enum AlignArg {
    /// Rotation + translation (Umeyama; evo `-a`).
    Se3,
    /// Rotation + translation + scale (evo `-a --correct_scale`).
    Sim3,
    /// Translation + yaw (the 4 unobservable DoF of VIO).
    Posyaw,
    /// No alignment.
    None,
}

#[derive(Clone, Copy, ValueEnum)]
enum SuiteArg {
    /// Stereo camera and IMU.
    StereoImu,
    /// One camera and the IMU.
    MonoImu,
    /// Stereo camera only.
    Stereo,
}

#[derive(Clone, Copy, ValueEnum)]
enum UnitArg {
    /// Metres of travelled path.
    M,
    /// Frames (pose index distance).
    F,
}

#[derive(Clone, Copy, ValueEnum)]
enum PairsArg {
    /// Select RPE pairs by the ground truth's path (evo `--pairs_from_reference`).
    Gt,
    /// Select RPE pairs by the aligned estimate's path (evo's default).
    Est,
}

#[derive(clap::Args)]
pub(super) struct EvalArgs {
    /// Ground-truth trajectory (TUM: `t tx ty tz qx qy qz qw`), or a EuRoC ground-truth file
    /// (`mav0/state_groundtruth_estimate0/data.csv`, read by its `.csv` extension).
    #[arg(long)]
    gt: PathBuf,
    /// Estimated trajectory (TUM).
    #[arg(long)]
    est: PathBuf,
    /// Alignment of the estimate before computing errors [default: the suite's, as `vio run`,
    /// `sweep` and `regress` use: posyaw with an IMU, se3 for stereo].
    #[arg(long, value_enum)]
    align: Option<AlignArg>,
    /// The suite that made the estimate: picks the default alignment.
    #[arg(long, value_enum, default_value = "stereo-imu")]
    suite: SuiteArg,
    /// Print the results as JSON (one object: the alignment, each table's statistics, the
    /// thresholds and whether they hold).
    #[arg(long)]
    json: bool,
    /// Fail (exit 1) when the estimate's ATE translation RMSE exceeds this (m).
    #[arg(long)]
    max_ate: Option<f64>,
    /// Fail (exit 1) when the estimate's ATE rotation RMSE exceeds this (deg).
    #[arg(long)]
    max_rot: Option<f64>,
    /// Max. timestamp difference for association, in seconds (evo `--t_max_diff`).
    #[arg(long, default_value_t = 0.01)]
    t_max_diff: f64,
    /// RPE pair spacing (evo `--delta`).
    #[arg(long, default_value_t = 1.0)]
    rpe_delta: f64,
    /// Unit of the RPE spacing (evo `--delta_unit`).
    #[arg(long, value_enum, default_value = "m")]
    rpe_unit: UnitArg,
    /// Which trajectory's path selects distance-based RPE pairs.
    #[arg(long, value_enum, default_value = "gt")]
    rpe_pairs_from: PairsArg,
    /// Another estimate (TUM) to compare with on common frames: both are scored on the frames
    /// both produced (associated within `--t-max-diff`), so an estimator that starts later is
    /// not credited with skipping the start-up; the other's table follows.
    #[arg(long)]
    common_with: Option<PathBuf>,
}

/// The ground truth at `path`: a EuRoC ground-truth CSV (`.csv`) or a TUM file.
fn read_ground_truth(path: &Path) -> Result<Vec<StampedPose>, String> {
    if path.extension().is_some_and(|e| e == "csv") {
        let states = read_groundtruth_csv(path).map_err(|e| e.to_string())?;
        return Ok(states
            .iter()
            .map(|s| StampedPose::new(s.t_ns, s.pose))
            .collect());
    }
    read_tum(path).map_err(|e| e.to_string())
}

pub(super) fn eval(args: &EvalArgs) -> Result<Evaluated, String> {
    let gt = read_ground_truth(&args.gt)?;
    let est = read_tum(&args.est).map_err(|e| e.to_string())?;
    if !(args.t_max_diff.is_finite() && args.t_max_diff >= 0.0) {
        return Err(format!(
            "--t-max-diff must be ≥ 0 s, got {}",
            args.t_max_diff
        ));
    }
    let delta = match args.rpe_unit {
        UnitArg::M => {
            if !(args.rpe_delta.is_finite() && args.rpe_delta > 0.0) {
                return Err(format!(
                    "--rpe-delta must be a distance > 0 m with --rpe-unit m, got {}",
                    args.rpe_delta
                ));
            }
            RpeDelta::Meters(args.rpe_delta)
        }
        UnitArg::F => {
            if !(args.rpe_delta >= 1.0 && args.rpe_delta.fract() == 0.0) {
                return Err(format!(
                    "--rpe-delta must be a whole number ≥ 1 with --rpe-unit f, got {}",
                    args.rpe_delta
                ));
            }
            RpeDelta::Frames(args.rpe_delta as usize)
        }
    };
    let pairs_from = match args.rpe_pairs_from {
        PairsArg::Gt => PairsFrom::Reference,
        PairsArg::Est => PairsFrom::Estimate,
    };
    let suite = match args.suite {
        SuiteArg::StereoImu => SuiteSpec::StereoImu,
        SuiteArg::MonoImu => SuiteSpec::MonoImu,
        SuiteArg::Stereo => SuiteSpec::Stereo,
    };
    let alignment = match args.align {
        None => default_alignment(suite),
        Some(AlignArg::Se3) => Alignment::Se3,
        Some(AlignArg::Sim3) => Alignment::Sim3,
        Some(AlignArg::Posyaw) => Alignment::PosYaw,
        Some(AlignArg::None) => Alignment::None,
    };
    let alignment_note = match args.align {
        None => format!(
            "{alignment} (the {} default, as vio run uses)",
            suite.as_str()
        ),
        Some(_) => format!("{alignment} (--align)"),
    };
    for (name, v) in [("--max-ate", args.max_ate), ("--max-rot", args.max_rot)] {
        if let Some(v) = v
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(format!("{name} must be a bound ≥ 0, got {v}"));
        }
    }
    let mut rpe = vec![RpeOptions {
        delta,
        pairs_from,
        ..RpeOptions::default()
    }];
    if delta != RpeDelta::Frames(1) {
        rpe.push(RpeOptions::frames(1));
    }
    let opts = EvalOptions {
        alignment,
        max_diff_ns: (args.t_max_diff * 1e9).round() as i64,
        rpe,
    };
    let max_diff_ns = opts.max_diff_ns;
    let Some(other_path) = &args.common_with else {
        let scored = score(&gt, &est, &args.gt, &args.est, args.t_max_diff, &opts)?;
        return Ok(finish(args, &alignment_note, None, &[scored]));
    };
    let other = read_tum(other_path).map_err(|e| e.to_string())?;
    let common = associate_trajectories(&est, &other, max_diff_ns).map_err(|e| {
        format!(
            "{} and {} have no common frames: {e}",
            args.est.display(),
            other_path.display()
        )
    })?;
    let first = |v: &[StampedPose]| v.first().map_or(f64::NAN, |s| s.t_ns as f64 * 1e-9);
    let common_line = format!(
        "common frames: {} of {} ({}) and {} ({}), from {:.3} s (they start at {:.3} s and {:.3} s)\n\n",
        common.pairs.len(),
        est.len(),
        args.est.display(),
        other.len(),
        other_path.display(),
        first(&common.gt),
        first(&est),
        first(&other)
    );
    let tables = [
        score(&gt, &common.gt, &args.gt, &args.est, args.t_max_diff, &opts)?,
        score(
            &gt,
            &common.est,
            &args.gt,
            other_path,
            args.t_max_diff,
            &opts,
        )?,
    ];
    Ok(finish(
        args,
        &alignment_note,
        Some((common.pairs.len(), common_line)),
        &tables,
    ))
}

/// What `vio eval` prints and its verdict: `(output, thresholds hold)`.
pub(super) type Evaluated = (String, bool);

/// One estimate's scores against the ground truth: its table as text and its figures.
struct Scored {
    text: String,
    json: serde_json::Value,
    ate_m: Option<f64>,
    rot_deg: Option<f64>,
}

/// The thresholds checked on the first table (the `--est` estimate): the failures, in words.
fn threshold_failures(args: &EvalArgs, s: &Scored) -> Vec<String> {
    let mut out = Vec::new();
    for (name, bound, value, unit) in [
        ("--max-ate", args.max_ate, s.ate_m, "m"),
        ("--max-rot", args.max_rot, s.rot_deg, "deg"),
    ] {
        let Some(bound) = bound else { continue };
        match value {
            Some(v) if v <= bound => {}
            Some(v) => out.push(format!("ATE {v:.6} {unit} > {name} {bound}")),
            None => out.push(format!("no ATE to check against {name} {bound}")),
        }
    }
    out
}

/// The output (text or `--json`) of the tables, with the thresholds' verdict.
fn finish(
    args: &EvalArgs,
    alignment: &str,
    common: Option<(usize, String)>,
    tables: &[Scored],
) -> Evaluated {
    let failures = threshold_failures(args, &tables[0]);
    let thresholds = args.max_ate.is_some() || args.max_rot.is_some();
    let passed = failures.is_empty();
    if args.json {
        let v = json!({
            "alignment": alignment,
            "common_frames": common.as_ref().map(|c| c.0),
            "tables": tables.iter().map(|t| t.json.clone()).collect::<Vec<_>>(),
            "max_ate_m": args.max_ate,
            "max_rot_deg": args.max_rot,
            "failures": failures,
            "passed": passed,
        });
        return (
            serde_json::to_string_pretty(&v).expect("plain data") + "\n",
            passed,
        );
    }
    let mut out = common.map(|c| c.1).unwrap_or_default();
    out.push_str(&format!("alignment: {alignment}\n\n"));
    for (i, t) in tables.iter().enumerate() {
        if i > 0 {
            out.push('\n');
        }
        out.push_str(&t.text);
    }
    if thresholds {
        out.push_str(&if passed {
            "\nresult PASS\n".to_string()
        } else {
            format!("\nresult FAIL: {}\n", failures.join("; "))
        });
    }
    (out, passed)
}

/// The statistics as JSON.
fn stats_json(s: &Stats) -> serde_json::Value {
    json!({"n": s.count, "rmse": s.rmse, "mean": s.mean, "median": s.median, "std": s.std,
           "min": s.min, "max": s.max})
}

/// The metrics table of `est` against `gt`, as text and JSON.
fn score(
    gt: &[StampedPose],
    est: &[StampedPose],
    gt_path: &Path,
    est_path: &Path,
    t_max_diff: f64,
    opts: &EvalOptions,
) -> Result<Scored, String> {
    let alignment = opts.alignment;
    let ev = evaluate(gt, est, opts)
        .map_err(|e| format!("{} vs {}: {e}", gt_path.display(), est_path.display()))?;
    let mut out = String::new();
    let a = &ev.ate.alignment;
    out.push_str(&format!(
        "ground truth {} ({} poses), estimate {} ({} poses): {} matched (max Δt {} s)\n",
        gt_path.display(),
        gt.len(),
        est_path.display(),
        est.len(),
        ev.matched.pairs.len(),
        t_max_diff
    ));
    match &ev.static_trajectory {
        Some(st) => out.push_str(&format!(
            "alignment {alignment}: {}\nanchored at the first matched pose ({})",
            st.reason,
            if st.drift.gravity_aligned {
                "position+yaw; tilt needs no alignment"
            } else {
                "whole pose"
            }
        )),
        None => {
            out.push_str(&format!("alignment {alignment}"));
            if alignment == Alignment::Sim3 {
                out.push_str(&format!(", scale {:.9}", a.scale));
            }
        }
    }
    out.push_str("\n\n");
    out.push_str(&format!(
        "{:<24} {:>6} {:>12} {:>12} {:>12} {:>12} {:>12} {:>12}\n",
        "metric", "n", "rmse", "mean", "median", "std", "min", "max"
    ));
    let mut rows: Vec<(String, serde_json::Value)> = Vec::new();
    let mut row = |name: String, s: &scenarios::metrics::Stats| {
        out.push_str(&format!(
            "{:<24} {:>6} {:>12.9} {:>12.9} {:>12.9} {:>12.9} {:>12.9} {:>12.9}\n",
            name, s.count, s.rmse, s.mean, s.median, s.std, s.min, s.max
        ));
        rows.push((name, stats_json(s)));
    };
    match &ev.static_trajectory {
        // Too short or static to align: errors from the first pose instead of the ATE.
        Some(st) => {
            let d = &st.drift;
            let stats = |v: &[f64]| scenarios::metrics::Stats::from_errors(v);
            if let Some(s) = stats(&d.position_errors) {
                row("drift trans (m)".into(), &s);
            }
            if let Some(s) = stats(&d.rotation_errors_deg) {
                row("drift rot (deg)".into(), &s);
            }
            if let Some(s) = d.tilt_deg() {
                row("tilt error (deg)".into(), &s);
            }
        }
        None => {
            row("ATE trans (m)".into(), &ev.ate.translation);
            row("ATE rot (deg)".into(), &ev.ate.rotation_deg);
        }
    }
    let mut missing = Vec::new();
    for (o, r) in opts.rpe.iter().zip(&ev.rpe) {
        match r {
            Ok(r) => {
                row(format!("RPE trans (m) Δ={}", o.delta), &r.translation);
                row(format!("RPE rot (deg) Δ={}", o.delta), &r.rotation_deg);
            }
            Err(e) => missing.push(format!("RPE Δ={}: {e}", o.delta)),
        }
    }
    for m in &missing {
        out.push_str(m);
        out.push('\n');
    }
    let (ate_m, rot_deg) = match &ev.static_trajectory {
        Some(_) => (None, None),
        None => (
            Some(ev.ate.translation.rmse),
            Some(ev.ate.rotation_deg.rmse),
        ),
    };
    let json = json!({
        "ground_truth": gt_path.display().to_string(),
        "estimate": est_path.display().to_string(),
        "matched": ev.matched.pairs.len(),
        "static_trajectory": ev.static_trajectory.as_ref().map(|s| s.reason.clone()),
        "metrics": rows.into_iter().collect::<serde_json::Map<_, _>>(),
        "missing": missing,
    });
    Ok(Scored {
        text: out,
        json,
        ate_m,
        rot_deg,
    })
}
