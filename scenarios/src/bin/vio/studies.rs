//! The commands that run many scenarios: `vio nees`, `vio regress`, `vio sweep`, `vio bench`.

use std::path::PathBuf;
use std::process::ExitCode;

use super::{BAD_INPUT, check_duration, check_out_dir, load_scenario_with, say};

/// `vio sweep`'s switches.
pub(super) struct SweepFlags {
    /// `--resume`: run only what an interrupted sweep left.
    pub resume: bool,
    /// `--force`: replace a previous sweep's results.
    pub force: bool,
    /// `--keep-runs`: keep each run's folder under `OUT/runs/`.
    pub keep_runs: bool,
}

/// `vio sweep`: exit 0 done, 2 bad input (or a run that failed), 130 interrupted (the runs
/// done are kept for `--resume`).
pub(super) fn sweep_command(
    file: &std::path::Path,
    out: &std::path::Path,
    shard: Option<&str>,
    jobs: Option<usize>,
    flags: SweepFlags,
) -> ExitCode {
    use scenarios::studies::sweep::partial::{forget_rows, keep_row, kept_rows, partial_dir};
    use scenarios::studies::sweep::run::{RUNS_DIR, Shard, SweepControl};
    let SweepFlags {
        resume,
        force,
        keep_runs,
    } = flags;
    let bad = |e: String| {
        eprintln!("vio sweep: error: {e}");
        ExitCode::from(BAD_INPUT)
    };
    let (sweep, shard_spec) = match load_sweep(file, shard) {
        Ok(loaded) => loaded,
        Err(e) => return bad(e),
    };
    let shard = shard_spec.unwrap_or(Shard::ALL);
    if let Err(code) = check_out_dir(out) {
        return code;
    }
    let json = serde_json::to_string_pretty(&sweep.json()).expect("plain data") + "\n";
    if let Err(e) = prepare_sweep_out(out, &json, resume, force) {
        return bad(e);
    }
    let kept = if resume {
        match kept_rows(out, &sweep, shard) {
            Ok(rows) => rows,
            Err(e) => return bad(e),
        }
    } else {
        Vec::new()
    };
    if let Err(e) = std::fs::write(out.join("sweep.json"), &json) {
        return bad(format!("--out {}: {e}", out.display()));
    }
    let runs_dir = out.join(RUNS_DIR);
    if keep_runs && let Err(e) = std::fs::create_dir_all(&runs_dir) {
        return bad(format!("--keep-runs: {}: {e}", runs_dir.display()));
    }
    let jobs = default_jobs(jobs);
    let stop = super::interrupt::on_ctrl_c(
        "stopping: the runs under way are dropped, the finished ones kept for --resume",
    );
    let started = std::time::Instant::now();
    let terminal = std::io::IsTerminal::is_terminal(&std::io::stderr());
    // A terminal gets a bar with the runs done and an estimate of the time left; a log, a
    // plain line per tenth of the runs.
    let bar = indicatif::ProgressBar::with_draw_target(
        None,
        if terminal {
            indicatif::ProgressDrawTarget::stderr()
        } else {
            indicatif::ProgressDrawTarget::hidden()
        },
    );
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "[{bar:40}] {pos}/{len} runs, {elapsed} elapsed, about {eta} left ",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    let control = SweepControl {
        done: kept.iter().map(|r| r.run).collect(),
        stop: Some(stop),
        keep: &|row| keep_row(out, &sweep, row),
        progress: &|done, total| {
            if terminal {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            } else if done == total || done % total.div_ceil(10).max(1) == 0 {
                eprintln!(
                    "{done}/{total} runs after {:.0} s",
                    started.elapsed().as_secs_f64()
                );
            }
        },
        runs_dir: keep_runs.then_some(runs_dir.as_path()),
    };
    let new_rows = sweep.run(shard, jobs, &control);
    bar.finish_and_clear();
    let mut rows = match new_rows {
        Ok(r) => r,
        Err(e) => return bad(e),
    };
    let shard_runs = (0..sweep.points().len() * sweep.spec.seeds.len())
        .filter(|&r| shard.has(r))
        .count();
    if super::interrupt::interrupted() {
        let done = kept.len() + rows.len();
        eprintln!(
            "vio sweep: interrupted after {done} of {shard_runs} runs, kept in {}; `vio sweep {} --out {}{} --resume` runs the rest",
            partial_dir(out).display(),
            file.display(),
            out.display(),
            shard_spec.map_or(String::new(), |s| format!(
                " --shard {}/{}",
                s.index, s.count
            ))
        );
        return ExitCode::from(130);
    }
    rows.extend(kept);
    rows.sort_by_key(|r| r.run);
    if let Err(e) = std::fs::write(out.join("results.csv"), sweep.csv(&rows)) {
        return bad(format!("--out {}: {e}", out.display()));
    }
    if let Err(e) = forget_rows(out) {
        return bad(e);
    }
    if shard_spec.is_none()
        && let Err(e) = scenarios::studies::sweep::merge::merge(&[out.to_path_buf()], out)
    {
        return bad(e);
    }
    if shard_spec.is_none()
        && let Ok(table) = std::fs::read_to_string(out.join("summary.md"))
    {
        say(&format!("{table}\n"));
    }
    say(&format!(
        "{} runs of {} in {:.1} s on {jobs} threads → {}\n",
        rows.len(),
        sweep.spec.description,
        started.elapsed().as_secs_f64(),
        out.display()
    ));
    ExitCode::SUCCESS
}

/// The sweep file read and checked, and `--shard i/n` parsed (`None`: every run).
fn load_sweep(
    file: &std::path::Path,
    shard: Option<&str>,
) -> Result<
    (
        scenarios::studies::sweep::Sweep,
        Option<scenarios::studies::sweep::run::Shard>,
    ),
    String,
> {
    use scenarios::studies::sweep::{Sweep, run::Shard};
    let sweep = Sweep::load(file).map_err(|e| e.to_string())?;
    let shard = shard.map(Shard::parse).transpose()?;
    Ok((sweep, shard))
}

/// Worker threads: as asked, else the machine's cores.
fn default_jobs(jobs: Option<usize>) -> usize {
    jobs.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    })
}

/// `vio sweep --plan`: the shard's runs, checked, and an estimate of their wall time; runs
/// nothing of the sweep and writes nothing. Exit 0, or 2 on a sweep that would fail to start.
pub(super) fn sweep_plan_command(
    file: &std::path::Path,
    shard: Option<&str>,
    jobs: Option<usize>,
) -> ExitCode {
    use scenarios::studies::sweep::plan::estimate_wall_s;
    use scenarios::studies::sweep::run::Shard;
    let bad = |e: String| {
        eprintln!("vio sweep --plan: error: {e}");
        ExitCode::from(BAD_INPUT)
    };
    let (sweep, shard) = match load_sweep(file, shard) {
        Ok((sweep, shard)) => (sweep, shard.unwrap_or(Shard::ALL)),
        Err(e) => return bad(e),
    };
    let runs = match sweep.plan(shard) {
        Ok(r) => r,
        Err(e) => return bad(e.to_string()),
    };
    let (points, seeds) = (sweep.points().len(), sweep.spec.seeds.len());
    let mut text = format!(
        "{} ({}): {points} points × {seeds} seeds = {} runs{}\n\nrun\tpoint\tseed\tsimulated_s",
        sweep.spec.description,
        file.display(),
        points * seeds,
        if shard == Shard::ALL {
            String::new()
        } else {
            format!(", {} in shard {}/{}", runs.len(), shard.index, shard.count)
        },
    );
    for a in &sweep.spec.axes {
        text += &format!("\t{}", a.name);
    }
    text.push('\n');
    for r in &runs {
        text += &format!("{}\t{}\t{}\t{}", r.run, r.point, r.seed, r.simulated_s);
        for (a, &i) in sweep.point(r.point).iter().enumerate() {
            text += &format!("\t{}", sweep.label(a, i));
        }
        text.push('\n');
    }
    let simulated: f64 = runs.iter().map(|r| r.simulated_s).sum();
    text += &format!("\n{simulated} simulated seconds in all\n");
    say(&text);
    // Probes of the first and last point (one when they are the same), 2 s each at most.
    let mut probe_points: Vec<(usize, f64)> = Vec::new();
    for r in [runs.first(), runs.last()].into_iter().flatten() {
        if probe_points.iter().all(|&(p, _)| p != r.point) {
            probe_points.push((r.point, r.simulated_s.min(2.0)));
        }
    }
    let mut probes = Vec::new();
    for (p, s) in probe_points {
        match sweep.probe(p, s) {
            Ok(probe) => probes.push(probe),
            Err(e) => return bad(e),
        }
    }
    let jobs = default_jobs(jobs);
    if let Some(wall) = estimate_wall_s(&runs, &probes, jobs) {
        let measured = probes
            .iter()
            .map(|p| {
                format!(
                    "point {}: {} s in {:.2} s",
                    p.point, p.simulated_s, p.wall_s
                )
            })
            .collect::<Vec<_>>()
            .join(", ");
        say(&format!(
            "estimated wall time ≈ {wall:.0} s on {jobs} threads (from probes of {measured}; points that render more, or run longer, take longer)\n"
        ));
    }
    ExitCode::SUCCESS
}

/// What a sweep finds in `--out` before it starts: a folder of another sweep's results is
/// refused (or, with `force`, emptied of them); with `resume` the folder's `sweep.json`, if
/// any, must be this sweep's.
fn prepare_sweep_out(
    out: &std::path::Path,
    json: &str,
    resume: bool,
    force: bool,
) -> Result<(), String> {
    use scenarios::studies::sweep::partial::{PARTIAL_DIR, forget_rows};
    let previous = out.join("sweep.json");
    if resume {
        return match std::fs::read_to_string(&previous) {
            Ok(text) if text != json => Err(format!(
                "--resume: {} is another sweep's (its definition differs from this file's); resume with the sweep file that started it, or use another --out",
                previous.display()
            )),
            _ => Ok(()),
        };
    }
    let entries = std::fs::read_dir(out).map_err(|e| format!("--out {}: {e}", out.display()))?;
    let ours: Vec<std::path::PathBuf> = entries
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| {
            let name = p
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            name == "sweep.json"
                || name == "results.csv"
                || name == "summary.csv"
                || name == "summary.md"
                || name == PARTIAL_DIR
                || name == scenarios::studies::sweep::run::RUNS_DIR
                || (name.contains("_vs_") && name.ends_with(".png"))
        })
        .collect();
    if ours.is_empty() {
        return Ok(());
    }
    if !force {
        return Err(format!(
            "--out {} holds a previous sweep's results ({}): --resume to finish it, --force to replace it",
            out.display(),
            ours.iter()
                .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    forget_rows(out)?;
    for p in &ours {
        if p.is_file() {
            std::fs::remove_file(p).map_err(|e| format!("{}: {e}", p.display()))?;
        } else if p
            .file_name()
            .is_some_and(|n| n == scenarios::studies::sweep::run::RUNS_DIR)
        {
            std::fs::remove_dir_all(p).map_err(|e| format!("{}: {e}", p.display()))?;
        }
    }
    Ok(())
}

pub(super) fn bench_command(quick: bool, out: Option<PathBuf>, one: Option<String>) -> ExitCode {
    use scenarios::studies::bench;
    let bad = |e: String| {
        eprintln!("vio bench: error: {e}");
        ExitCode::from(BAD_INPUT)
    };
    if let Some(name) = one {
        return match bench::bench_one(&name, quick) {
            Ok(row) => {
                say(&(serde_json::to_string(&row).expect("plain data") + "\n"));
                ExitCode::SUCCESS
            }
            Err(e) => bad(e),
        };
    }
    let out = out.unwrap_or_else(|| PathBuf::from("vio-out").join("bench"));
    if let Err(code) = check_out_dir(&out) {
        return code;
    }
    let exe = match std::env::current_exe() {
        Ok(e) => e,
        Err(e) => return bad(format!("cannot find the vio executable: {e}")),
    };
    // Ctrl-C reaches the child too (one process group): it stops there, and so does the table.
    let _ = super::interrupt::on_ctrl_c("stopping: the table and bench.json cover the rows done");
    let mut rows = Vec::new();
    for name in bench::SCENARIOS.iter().map(|c| c.name) {
        if super::interrupt::interrupted() {
            break;
        }
        eprintln!("bench {name}");
        let mut cmd = std::process::Command::new(&exe);
        cmd.args(["bench", "--one", name]);
        if quick {
            cmd.arg("--quick");
        }
        let child = match cmd.output() {
            Ok(o) => o,
            Err(e) => return bad(format!("{name}: {e}")),
        };
        if super::interrupt::interrupted() {
            break;
        }
        if !child.status.success() {
            return bad(format!(
                "{name}: {}",
                String::from_utf8_lossy(&child.stderr).trim()
            ));
        }
        match serde_json::from_slice::<bench::BenchRow>(&child.stdout) {
            Ok(r) => rows.push(r),
            Err(e) => return bad(format!("{name}: unreadable result: {e}")),
        }
    }
    let json = bench::BenchJson {
        date_utc: bench::now_utc(),
        machine: bench::machine(),
        quick,
        vio_version: env!("CARGO_PKG_VERSION"),
        rows,
    };
    say(&format!(
        "{} on {}{}\n{}",
        json.date_utc,
        json.machine,
        if quick { " (--quick)" } else { "" },
        bench::table(&json.rows)
    ));
    let path = out.join("bench.json");
    let text = serde_json::to_string_pretty(&json).expect("plain data") + "\n";
    if let Err(e) = std::fs::write(&path, text) {
        return bad(format!("{}: {e}", path.display()));
    }
    say(&format!("written: {}\n", path.display()));
    if super::interrupt::interrupted() {
        eprintln!(
            "vio bench: interrupted after {} of {} scenarios",
            json.rows.len(),
            bench::SCENARIOS.len()
        );
        return ExitCode::from(130);
    }
    ExitCode::SUCCESS
}

pub(super) fn regress_command(
    catalog: &std::path::Path,
    baseline: Option<PathBuf>,
    junit: Option<PathBuf>,
    update: bool,
    estimator: Option<String>,
) -> ExitCode {
    use scenarios::studies::regress;
    let bad = |e: String| {
        eprintln!("vio regress: error: {e}");
        ExitCode::from(BAD_INPUT)
    };
    let settings = match estimator.as_deref().filter(|e| *e != "ours") {
        None => Vec::new(),
        Some(e) => match scenarios::spec::parse_setting(&super::estimator_setting(e)) {
            Ok(s) => vec![s],
            Err(m) => return bad(m),
        },
    };
    // Each estimator has its own baseline.
    let default_baseline = match estimator.as_deref().filter(|e| *e != "ours") {
        None => "baseline.json".to_string(),
        Some(e) => format!(
            "baseline.{}.json",
            std::path::Path::new(e)
                .file_stem()
                .map_or(e.into(), |s| s.to_string_lossy())
        ),
    };
    let baseline_path = baseline.unwrap_or_else(|| catalog.join(default_baseline));
    let files = match regress::catalog_files(catalog) {
        Ok(f) => f,
        Err(e) => return bad(e),
    };
    let old = match regress::read_baseline(&baseline_path) {
        Ok(b) => b,
        Err(e) => return bad(e),
    };
    match &old {
        None if !update => {
            return bad(format!(
                "no baseline at {} (write one with --update-baseline)",
                baseline_path.display()
            ));
        }
        Some((b, text)) if !update => {
            let names = regress::catalog_names(&files);
            if let Err(e) = regress::check_baseline(b, text, &baseline_path, &names) {
                return bad(e);
            }
        }
        _ => {}
    }
    let old = old.map(|(b, _)| b);
    // The JUnit file is opened before the catalog runs, so a path that cannot be written is
    // found in a second, not after every scenario has run.
    if let Some(path) = &junit
        && let Err(e) = std::fs::File::create(path)
    {
        return bad(format!("--junit {}: {e}", path.display()));
    }
    let stop = super::interrupt::on_ctrl_c(
        "stopping: the scenario under way is dropped, the finished ones compared",
    );
    let reports = match regress::run_catalog(
        &files,
        &settings,
        &mut |name| eprintln!("running {name}"),
        Some(stop),
    ) {
        Ok(r) => r,
        Err(e) => return bad(e),
    };
    let interrupted = super::interrupt::interrupted();
    if interrupted && update {
        eprintln!(
            "vio regress: interrupted after {} of {} scenarios: the baseline is left as it was",
            reports.len(),
            files.len()
        );
        return ExitCode::from(130);
    }
    if update {
        let b = regress::updated_baseline(&reports, &old.unwrap_or_default());
        let text = serde_json::to_string_pretty(&b).expect("plain data") + "\n";
        if let Err(e) = std::fs::write(&baseline_path, text) {
            return bad(format!("--baseline {}: {e}", baseline_path.display()));
        }
        say(&format!(
            "baseline of {} scenarios written to {}\n",
            reports.len(),
            baseline_path.display()
        ));
        return ExitCode::SUCCESS;
    }
    let old = old.unwrap_or_default();
    let checks: Vec<_> = reports
        .iter()
        .flat_map(|(name, r)| regress::compare(name, r, &old))
        .collect();
    say(&regress::table(&checks));
    if let Some(path) = junit
        && let Err(e) = std::fs::write(&path, regress::junit(&checks))
    {
        return bad(format!("--junit {}: {e}", path.display()));
    }
    for c in checks.iter().filter(|c| c.failed()) {
        eprintln!("regression: {}", c.describe());
    }
    if interrupted {
        eprintln!(
            "vio regress: interrupted after {} of {} scenarios: the table covers those",
            reports.len(),
            files.len()
        );
        ExitCode::from(130)
    } else if checks.iter().any(|c| c.failed()) {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// Loads a catalog scenario or file (default: the default scenario); bad input prints the
/// error and becomes exit code 2.
pub(super) fn nees_command(
    scenario: Option<String>,
    settings: &[String],
    seeds: u64,
    duration: Option<f64>,
    out: Option<PathBuf>,
    threads: Option<usize>,
    batch_reference: bool,
) -> ExitCode {
    let scenario = match load_scenario_with(scenario.as_deref(), settings) {
        Ok(s) => s,
        Err(code) => return code,
    };
    if seeds == 0 {
        eprintln!("error: --seeds must be >= 1");
        return ExitCode::from(BAD_INPUT);
    }
    if let Err(code) = check_duration(duration) {
        return code;
    }
    let options = scenarios::studies::nees_monte_carlo::NeesOptions {
        seeds: (1..=seeds).collect(),
        duration_s: duration,
        threads: threads.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
        }),
        batch_reference,
    };
    let stop = super::interrupt::on_ctrl_c(
        "stopping: the seeds under way are dropped, the NEES of the finished ones written",
    );
    let r =
        match scenarios::studies::nees_monte_carlo::run_nees_until(&scenario, &options, Some(stop))
        {
            Ok(Some(r)) => r,
            Ok(None) => {
                eprintln!("vio nees: interrupted before any seed finished: nothing written");
                return ExitCode::from(130);
            }
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::from(BAD_INPUT);
            }
        };
    let out_dir =
        out.unwrap_or_else(|| PathBuf::from("vio-out").join(format!("{}-nees", scenario.name)));
    say(&scenarios::studies::nees_monte_carlo::summary(&r));
    match scenarios::studies::nees_monte_carlo::write_outputs(&out_dir, &r) {
        Ok(files) => say(&format!("files         {}\n", files.join(", "))),
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    }
    if super::interrupt::interrupted() {
        eprintln!(
            "vio nees: interrupted: {} of {seeds} seeds finished; the files cover those",
            r.seeds.len()
        );
        ExitCode::from(130)
    } else if r.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
