//! `vio`: the command-line entry point of the harness.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Visual-inertial odometry estimator and its simulation harness.
#[derive(Parser)]
#[command(name = "vio", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Preintegrate a synthetic IMU interval and check every factor's Jacobians.
    Selfcheck,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
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
