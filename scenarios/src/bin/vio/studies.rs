//! The commands that run many scenarios: `vio nees`, `vio regress`, `vio sweep`, `vio bench`.

use std::path::PathBuf;
use std::process::ExitCode;

use super::{BAD_INPUT, check_duration, check_out_dir, load_scenario, say};

pub(super) fn sweep_command(
    file: &std::path::Path,
    out: &std::path::Path,
    shard: Option<&str>,
    jobs: Option<usize>,
) -> ExitCode {
    use scenarios::studies::sweep::{Sweep, run::Shard};
    let bad = |e: String| {
        eprintln!("vio sweep: error: {e}");
        ExitCode::from(BAD_INPUT)
    };
    let sweep = match Sweep::load(file) {
        Ok(s) => s,
        Err(e) => return bad(e.to_string()),
    };
    let shard_spec = match shard.map(Shard::parse).transpose() {
        Ok(s) => s,
        Err(e) => return bad(e),
    };
    if let Err(code) = check_out_dir(out) {
        return code;
    }
    let jobs = jobs.unwrap_or_else(|| {
        std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get)
    });
    let started = std::time::Instant::now();
    let rows = match sweep.run(shard_spec.unwrap_or(Shard::ALL), jobs, &|done, total| {
        eprint!("\r{done}/{total} runs");
    }) {
        Ok(r) => r,
        Err(e) => return bad(e),
    };
    eprintln!();
    let json = serde_json::to_string_pretty(&sweep.json()).expect("plain data") + "\n";
    for (name, text) in [("results.csv", sweep.csv(&rows)), ("sweep.json", json)] {
        if let Err(e) = std::fs::write(out.join(name), text) {
            return bad(format!("--out {}: {e}", out.display()));
        }
    }
    if shard_spec.is_none()
        && let Err(e) = scenarios::studies::sweep::merge::merge(&[out.to_path_buf()], out)
    {
        return bad(e);
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
    let mut rows = Vec::new();
    for &(name, ..) in bench::SCENARIOS {
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
    ExitCode::SUCCESS
}

pub(super) fn regress_command(
    catalog: &std::path::Path,
    baseline: Option<PathBuf>,
    junit: Option<PathBuf>,
    update: bool,
) -> ExitCode {
    use scenarios::studies::regress;
    let bad = |e: String| {
        eprintln!("vio regress: error: {e}");
        ExitCode::from(BAD_INPUT)
    };
    let baseline_path = baseline.unwrap_or_else(|| catalog.join("baseline.json"));
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
    let reports = match regress::run_catalog(&files, &mut |name| eprintln!("running {name}")) {
        Ok(r) => r,
        Err(e) => return bad(e),
    };
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
    if checks.iter().any(|c| c.failed()) {
        for c in checks.iter().filter(|c| c.failed()) {
            eprintln!("regression: {}", c.describe());
        }
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

/// Loads a catalog scenario or file (default: the default scenario); bad input prints the
/// error and becomes exit code 2.
pub(super) fn nees_command(
    scenario: Option<String>,
    seeds: u64,
    duration: Option<f64>,
    out: Option<PathBuf>,
    threads: Option<usize>,
) -> ExitCode {
    let scenario = match load_scenario(scenario.as_deref()) {
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
    };
    let r = match scenarios::studies::nees_monte_carlo::run_nees(&scenario, &options) {
        Ok(r) => r,
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
    if r.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
