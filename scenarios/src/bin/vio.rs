//! `vio`: the command-line entry point of the harness.
//!
//! Exit codes: 0 ok, 1 an expectation is not met, 2 bad input.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use scenarios::run::{RunOptions, run};
use scenarios::spec::Scenario;
use scenarios::{catalog, report};

/// Visual-inertial odometry estimator and its simulation harness.
#[derive(Parser)]
#[command(name = "vio", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scenario end to end (simulate, estimate, evaluate) and write a report.
    Run {
        /// A catalog scenario name (see `vio list`) or a path to a scenario .toml file; default:
        /// the built-in default scenario.
        scenario: Option<String>,
        /// Output folder [default: ./vio-out/NAME, NAME the scenario name].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Seed instead of the scenario's `world.seed`.
        #[arg(long)]
        seed: Option<u64>,
        /// Simulated duration (s) instead of the scenario's `trajectory.duration_s`.
        #[arg(long)]
        duration: Option<f64>,
    },
    /// List the built-in scenarios.
    List,
    /// Preintegrate a synthetic IMU interval and check every factor's Jacobians.
    Selfcheck,
}

/// Exit code for bad input.
const BAD_INPUT: u8 = 2;

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Run {
            scenario,
            out,
            seed,
            duration,
        } => run_command(scenario, out, seed, duration),
        Command::List => {
            for e in catalog::entries() {
                match Scenario::load(e.name) {
                    Ok(s) => {
                        let tag = if e.name == catalog::DEFAULT {
                            " [default]"
                        } else {
                            ""
                        };
                        println!("{:<34} {}{tag}", e.name, s.spec.description);
                    }
                    Err(err) => println!("{:<34} (broken: {err})", e.name),
                }
            }
            ExitCode::SUCCESS
        }
        Command::Selfcheck => {
            let result = scenarios::selfcheck::run();
            print!("{}", result.report);
            if result.ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
    }
}

fn run_command(
    scenario: Option<String>,
    out: Option<PathBuf>,
    seed: Option<u64>,
    duration: Option<f64>,
) -> ExitCode {
    let name = scenario.as_deref().unwrap_or(catalog::DEFAULT);
    let scenario = match Scenario::load(name) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    if let Some(d) = duration
        && !(d.is_finite() && d > 0.0)
    {
        eprintln!("error: --duration must be a finite number of seconds > 0");
        return ExitCode::from(BAD_INPUT);
    }
    let out_dir = out.unwrap_or_else(|| PathBuf::from("vio-out").join(&scenario.name));
    let bar = ProgressBar::with_draw_target(
        Some(1000),
        if std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:40}] {percent:>3}% sim time, {elapsed} ")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_prefix(scenario.name.clone());
    let options = RunOptions {
        seed,
        duration_s: duration,
    };
    let result = run(&scenario, &options, &mut |f| {
        bar.set_position((f * 1000.0).round() as u64)
    });
    bar.finish_and_clear();
    let output = match result {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    let eval = report::evaluate(&output, scenario.spec.suite);
    let rep = report::build_report(&scenario, &output, &eval);
    if let Err(e) = report::write_outputs(&out_dir, &scenario, &output, &eval, &rep) {
        eprintln!("error: {e}");
        return ExitCode::from(BAD_INPUT);
    }
    print!("{}", report::summary(&rep, Some(&out_dir)));
    if rep.passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
