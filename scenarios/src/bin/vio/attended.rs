//! A run the user watches: a progress bar on a terminal (a line every 10 % of the run's time
//! otherwise, once it takes a while), Ctrl-C to stop it and keep what it has, then its files
//! and its summary. Serves `vio run` and `vio euroc`.

use std::io::IsTerminal;
use std::path::Path;
use std::process::ExitCode;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use scenarios::pipeline::{ReportedRun, RunInput, run_to_report};
use scenarios::report;
use scenarios::run::{RunControl, RunError, RunOptions};

use super::{BAD_INPUT, say};

/// Runs `input` (called `label` on the progress bar) to its report; an outside estimator's files
/// go to `OUT/estimator/`.
pub fn run_attended(
    label: &str,
    input: RunInput,
    options: &RunOptions,
    out_dir: &Path,
) -> Result<ReportedRun, RunError> {
    let stop = super::interrupt::on_ctrl_c("stopping the run and writing what it has");
    let terminal = std::io::stderr().is_terminal();
    let bar = ProgressBar::with_draw_target(
        Some(1000),
        if terminal {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:40}] {percent:>3}% of its time, {elapsed} ")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(label.to_string());
    let started = std::time::Instant::now();
    let mut reported = 0u64;
    let mut progress = |f: f64| {
        bar.set_position((f * 1000.0).round() as u64);
        let decile = (f * 10.0).floor() as u64;
        if !terminal && decile > reported && started.elapsed().as_secs_f64() > 2.0 {
            reported = decile;
            eprintln!(
                "{label}: {decile}0 % of its time after {:.0} s",
                started.elapsed().as_secs_f64()
            );
        }
    };
    let control = RunControl {
        progress: Some(&mut progress),
        stop: Some(stop),
        workspace: Some(&out_dir.join("estimator")),
    };
    let result = run_to_report(input, options, control);
    bar.finish_and_clear();
    result
}

/// Writes `run`'s files into `out_dir`, prints `preface` and its summary; the exit code: 0
/// (every expectation holds), 1 (one failed), 2 (the files cannot be written), 130 (stopped
/// by Ctrl-C).
pub fn finish_attended(out_dir: &Path, run: &ReportedRun, preface: &str) -> ExitCode {
    if let Err(e) = run.write_outputs(out_dir) {
        eprintln!("error: {e}");
        return ExitCode::from(BAD_INPUT);
    }
    say(preface);
    say(&report::summary(&run.report, Some(out_dir)));
    if run.report.interrupted_at_s.is_some() {
        ExitCode::from(130)
    } else if run.report.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
