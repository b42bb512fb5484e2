//! `vio`: the command-line entry point of the harness.
//!
//! Exit codes: 0 ok, 1 an expectation is not met, 2 bad input.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use scenarios::catalog;
use scenarios::pipeline::RunInput;
use scenarios::run::RunOptions;
use scenarios::spec::Scenario;

#[path = "vio/attended.rs"]
mod attended;
#[path = "vio/bag.rs"]
mod bag;
#[path = "vio/euroc.rs"]
mod euroc;
#[path = "vio/eval.rs"]
mod eval;
#[path = "vio/image_stats.rs"]
mod image_stats;
#[path = "vio/imu_model.rs"]
mod imu_model;
#[path = "vio/interrupt.rs"]
mod interrupt;
#[path = "vio/recording.rs"]
mod recording;
#[path = "vio/studies.rs"]
mod studies;

use attended::{finish_attended, run_attended};
use bag::{BagArgs, bag_command};
use euroc::{EurocArgs, euroc_command};
use eval::{EvalArgs, eval};
use image_stats::{ImageStatsArgs, image_stats_command};
use imu_model::{ImuModelArgs, imu_model_command};
use studies::{
    SweepFlags, bench_command, nees_command, regress_command, sweep_command, sweep_plan_command,
};

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
        /// Also solve the full batch over the window's keyframes at the end and report the
        /// window's and the causal ATE against it (`batch_reference` in report.json).
        #[arg(long)]
        batch_reference: bool,
        /// Also write `run.mcap` for viewers (Foxglove, Rerun): poses, paths, the window's
        /// frames and points, the pose covariance, errors and state over time, events.
        #[arg(long)]
        mcap: bool,
        /// The estimator: `ours` (default), a built-in adapter (`openvins-tracks`,
        /// `openvins-images`) or an adapter .toml file (the scenario key `estimator_adapter`;
        /// the book's "Bring your own estimator"). Its files go to `OUT/estimator/`.
        #[arg(long)]
        estimator: Option<String>,
        /// Set a scenario key before the run: `--set rig.imu.rate_hz=400` (repeatable; the
        /// value as TOML, else as a string; checked like the file's own keys).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        settings: Vec<String>,
    },
    /// Monte-Carlo consistency: run the scenario with seeds 1..=N and write the NEES of the
    /// observable states (body velocity, biases, roll/pitch, relative pose over 0.5 s) averaged over the runs, with their
    /// 95 % χ² bands, as `OUT/nees.json` and `OUT/nees.png`. Exit 1 when a time-averaged NEES
    /// leaves its band.
    Nees {
        /// A catalog scenario name or a path to a scenario .toml file; default: the default
        /// scenario.
        scenario: Option<String>,
        /// Number of seeds (runs): seeds 1..=N.
        #[arg(long, default_value_t = 25)]
        seeds: u64,
        /// Simulated duration (s) instead of the scenario's `trajectory.duration_s`.
        #[arg(long)]
        duration: Option<f64>,
        /// Output folder [default: ./vio-out/NAME-nees].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads [default: the machine's cores]; the result does not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// Also solve the full-information filter at checkpoints of every run (as `vio run
        /// --batch-reference`) and compare its NEES with the window's there (slow: a batch over
        /// the whole run so far at each checkpoint).
        #[arg(long)]
        batch_reference: bool,
        /// The estimator, as for `vio run`: an outside one takes part when its adapter names a
        /// `covariance` file (its newest state's covariance; the relative pose is ours only).
        #[arg(long)]
        estimator: Option<String>,
        /// Set a scenario key before the runs, as for `vio run` (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        settings: Vec<String>,
    },
    /// Run the image front end and the estimator on a recorded EuRoC ASL folder (`mav0/`:
    /// `imu0`, `cam0`, `cam1` with `data.csv`, PNG images and `sensor.yaml`; ground truth
    /// optional) and write what `vio run` writes (evaluated when the folder has
    /// `state_groundtruth_estimate0`).
    Euroc(EurocArgs),
    /// Run the image front end and the estimator on a recorded ROS 2 bag (one `.mcap` file:
    /// IMU and image topics, the rig as Kalibr files given or attached, ground truth optional)
    /// and write what `vio run` writes.
    Bag(BagArgs),
    /// List the built-in scenarios.
    List,
    /// Print the scenario's effective estimator, front-end and renderer settings as the TOML
    /// tables `[estimator]`, `[estimator.solver]`, `[estimator.health]`,
    /// `[estimator.zero_velocity]`, `[camera.tracker]`, `[camera.render]` and
    /// `[camera.photometric]`, with the value this scenario runs with; `--keys` lists every
    /// other key a scenario file may set (rig, trajectory, faults, expectations …) with its
    /// type, unit, default and meaning, generated from the schema the parser uses.
    Settings {
        /// A catalog scenario name or a path to a scenario .toml file; default: the default
        /// scenario.
        scenario: Option<String>,
        /// List every key of the scenario file format instead (no scenario is read).
        #[arg(long, conflicts_with = "scenario")]
        keys: bool,
    },
    /// Write a scenario's simulated measurements and ground truth: in the EuRoC ASL layout
    /// (`OUT/mav0/…`, the feature tracks as `OUT/features.csv`, the rig as Kalibr files
    /// `OUT/camchain-imucam.yaml` and `OUT/imu.yaml`), or as a ROS 2 bag (`--format mcap`).
    Export {
        /// A catalog scenario name or a path to a scenario .toml file; default: the default
        /// scenario.
        scenario: Option<String>,
        /// Output folder (`asl`) or file (`mcap`, e.g. `run.mcap`).
        #[arg(long)]
        out: PathBuf,
        /// `asl` (EuRoC folder) or `mcap` (a ROS 2 bag: IMU, images, camera infos, feature
        /// tracks, ground truth, /tf, the Kalibr rig attached; the topics are listed in the book).
        #[arg(long, default_value = "asl")]
        format: String,
        /// Seed instead of the scenario's `world.seed`.
        #[arg(long)]
        seed: Option<u64>,
        /// Simulated duration (s) instead of the scenario's `trajectory.duration_s`.
        #[arg(long)]
        duration: Option<f64>,
        /// Set a scenario key before the export: `--set rig.imu.rate_hz=400` (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        settings: Vec<String>,
    },
    /// Render one capture of a scenario: every camera's image and depth at time `--at`,
    /// written as `OUT/cam<i>.png`, `OUT/cam<i>_depth.png` (16-bit, millimetres) and
    /// `OUT/stereo.png` (side by side); with `--tracks` also `OUT/tracks.png`.
    Render {
        /// A catalog scenario name or a path to a scenario .toml file; default: the default
        /// scenario. Feature-level scenarios render with the default settings.
        scenario: Option<String>,
        /// Time into the run (s).
        #[arg(long, default_value_t = 0.0)]
        at: f64,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Seed instead of the scenario's `world.seed`.
        #[arg(long)]
        seed: Option<u64>,
        /// Also track the captures of the 2 s before `--at` with the image front end and
        /// write `OUT/tracks.png`: the left and right images with each track's trail (colour by
        /// age: red new, through yellow and green, to blue old) and its stereo match.
        #[arg(long)]
        tracks: bool,
    },
    /// Run a regression catalog (every `*.toml` of a folder, seeds from the files) and compare
    /// each accuracy metric with a stored baseline under per-metric tolerances: a table, JUnit
    /// XML with `--junit`, exit 1 when a metric regressed (the table and the XML name it).
    Regress {
        /// Folder of scenario files.
        #[arg(long, default_value = "scenarios/regress")]
        catalog: PathBuf,
        /// Baseline file [default: CATALOG/baseline.json].
        #[arg(long)]
        baseline: Option<PathBuf>,
        /// Write JUnit XML here (one testcase per scenario × metric).
        #[arg(long)]
        junit: Option<PathBuf>,
        /// Write the baseline from this run instead of comparing (keeps tolerances already in
        /// the file).
        #[arg(long)]
        update_baseline: bool,
        /// Run every scenario with this estimator (`ours`, a built-in adapter or an adapter
        /// .toml file); its baseline is then CATALOG/baseline.NAME.json by default (NAME the
        /// value's file stem) and its JUnit cases are named `ADAPTER.SCENARIO`.
        #[arg(long)]
        estimator: Option<String>,
    },
    /// Run a sweep (a base scenario over a grid of parameter values × seeds; see
    /// `scenarios/sweeps/`): `OUT/results.csv`, `OUT/sweep.json` and, without `--shard`, a plot
    /// per metric and axis. `--shard i/n` (0 ≤ i < n) runs every n-th run from the i-th, for one
    /// machine of many; `vio sweep-merge` joins the shards. Ctrl-C stops it keeping the runs
    /// done (exit 130); `--resume` finishes it.
    Sweep {
        /// The sweep file.
        file: PathBuf,
        /// Output folder (not needed with `--plan`).
        #[arg(long, required_unless_present = "plan")]
        out: Option<PathBuf>,
        /// Print the runs (this shard's) without running them: every point's scenario is
        /// built and checked, and two short probe runs (the first and last point) estimate the
        /// wall time. Writes nothing.
        #[arg(long, conflicts_with_all = ["resume", "force", "keep_runs"])]
        plan: bool,
        /// Keep each run's folder, `OUT/runs/run-<index>/`: the files `vio run --out` writes
        /// and the point's `scenario.toml`, so any point can be opened or run again.
        #[arg(long)]
        keep_runs: bool,
        /// Run only this slice of the runs: `i/n`.
        #[arg(long)]
        shard: Option<String>,
        /// Worker threads [default: the machine's cores]; the result does not depend on it.
        #[arg(long)]
        jobs: Option<usize>,
        /// Finish an interrupted sweep in `--out`: run only the runs it has not kept
        /// (`OUT/partial/`); the result is what an uninterrupted sweep writes.
        #[arg(long, conflicts_with = "force")]
        resume: bool,
        /// Replace a previous sweep's results in `--out` (without it they are refused, never
        /// mixed).
        #[arg(long)]
        force: bool,
    },
    /// Join sweep shard folders into `--out` (exactly what one process would have written) and
    /// draw the plots.
    SweepMerge {
        /// The shards' output folders.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Benchmark: fixed scenarios per suite and camera mode (`scenarios::studies::bench::SCENARIOS`),
    /// each in its own process; per-stage timing (median / p99 / max per frame), frames per
    /// second, peak memory; a table and `OUT/bench.json` with date and machine.
    Bench {
        /// Short runs (8 s feature-level, 3 s rendered) instead of 20–30 s / 10 s.
        #[arg(long)]
        quick: bool,
        /// Output folder [default: ./vio-out/bench].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Run one benchmark scenario in this process and print its row as JSON (what each
        /// child process does).
        #[arg(long, hide = true)]
        one: Option<String>,
    },
    /// Preintegrate a synthetic IMU interval and check every factor's Jacobians.
    Selfcheck,
    /// Compare an estimated trajectory with ground truth (TUM files): ATE and RPE with evo's
    /// definitions (`evo_ape tum GT EST -a` prints the same ATE).
    Eval(EvalArgs),
    /// Characterize a recorded IMU (EuRoC `imu0/data.csv`): Allan deviation of each axis with a
    /// fit of the Kalibr noise densities and random walks, spectra and vibration lines; with
    /// `--gt` also the residual against the IMU the ground truth implies, the clock lag and the
    /// frame check, and the IMU error model fitted to that residual (`OUT/error_model.toml`, for
    /// `[rig.imu] error_model`). Writes `OUT/imu_model.json`, `OUT/allan.png`, `OUT/spectrum.png`.
    ImuModel(ImuModelArgs),
    /// Measure static frames (a camera at rest) of EuRoC ASL folders side by side: temporal
    /// noise against intensity with the renderer's fitted `read_noise` and
    /// `electrons_per_level`, flat-area spatial residual, radial brightness, gradient and
    /// Shi–Tomasi response distributions, corner density, and the KLT front end's drift from
    /// each track's first position. Compare a real recording with `vio export` of a rendered
    /// scenario held at rest (`trajectory.static_start`).
    ImageStats(ImageStatsArgs),
}

/// Writes to stdout; a closed pipe (`vio list | head`) ends the output quietly instead of
/// panicking like `print!` does.
fn say(text: &str) {
    use std::io::Write;
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        // A reader that closed the pipe (`vio list | head`) wanted no more; anything else (a
        // full disk, a closed descriptor) lost output the user asked for.
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            let _ = STDOUT_FAILED.set(e.to_string());
        }
    }
}

/// The first error writing to stdout other than a closed pipe: the command then exits
/// [`STDOUT_FAILED_EXIT`] saying so, whatever it would have exited with.
static STDOUT_FAILED: std::sync::OnceLock<String> = std::sync::OnceLock::new();

/// Exit code when the output could not be written (`EX_IOERR` of sysexits.h).
const STDOUT_FAILED_EXIT: u8 = 74;

/// Exit code for bad input.
const BAD_INPUT: u8 = 2;

fn main() -> ExitCode {
    let code = dispatch(Cli::parse());
    match STDOUT_FAILED.get() {
        Some(e) => {
            eprintln!("vio: error: writing to stdout failed: {e}");
            ExitCode::from(STDOUT_FAILED_EXIT)
        }
        None => code,
    }
}

/// Runs the command line's command; its exit code.
fn dispatch(cli: Cli) -> ExitCode {
    match cli.command {
        Command::Run {
            scenario,
            out,
            seed,
            duration,
            batch_reference,
            mcap,
            estimator,
            mut settings,
        } => run_command(
            scenario,
            {
                if let Some(e) = estimator {
                    settings.push(estimator_setting(&e));
                }
                settings
            },
            out,
            RunOptions {
                seed,
                duration_s: duration,
                batch_reference,
                covariance: mcap,
                scene: mcap,
            },
        ),
        Command::Export {
            scenario,
            out,
            format,
            seed,
            duration,
            settings,
        } => {
            let bag = match format.as_str() {
                "asl" => false,
                "mcap" => true,
                other => {
                    eprintln!("error: --format {other}: expected asl or mcap");
                    return ExitCode::from(BAD_INPUT);
                }
            };
            let scenario = match load_scenario_with(scenario.as_deref(), &settings) {
                Ok(s) => s,
                Err(code) => return code,
            };
            if let Err(code) = check_duration(duration) {
                return code;
            }
            let options = RunOptions {
                seed,
                duration_s: duration,
                ..Default::default()
            };
            let written = if bag {
                scenarios::export::export_bag(&scenario, &options, &out)
            } else {
                scenarios::export::export(&scenario, &options, &out)
            };
            match written {
                Ok(s) => {
                    say(&format!(
                        "exported {}: {} IMU samples, {} frames ({} feature observations), {} ground-truth rows → {}\n",
                        scenario.name,
                        s.imu_samples,
                        s.frames,
                        s.observations,
                        s.groundtruth,
                        out.display()
                    ));
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("error: {e}");
                    ExitCode::from(BAD_INPUT)
                }
            }
        }
        Command::Render {
            scenario,
            at,
            out,
            seed,
            tracks,
        } => render_command(scenario, at, &out, seed, tracks),
        Command::Nees {
            scenario,
            seeds,
            duration,
            out,
            threads,
            batch_reference,
            estimator,
            mut settings,
        } => {
            if let Some(e) = estimator {
                settings.push(estimator_setting(&e));
            }
            nees_command(
                scenario,
                &settings,
                seeds,
                duration,
                out,
                threads,
                batch_reference,
            )
        }
        Command::Settings { keys: true, .. } => {
            use scenarios::spec::key_listing::{listing_text, scenario_keys};
            say(&listing_text(&scenario_keys()));
            ExitCode::SUCCESS
        }
        Command::Settings { scenario, .. } => {
            match load_scenario(scenario.as_deref()).map(|s| s.settings_toml()) {
                Ok(Ok(text)) => {
                    say(&text);
                    ExitCode::SUCCESS
                }
                Ok(Err(e)) => {
                    eprintln!("error: {e}");
                    ExitCode::from(BAD_INPUT)
                }
                Err(code) => code,
            }
        }
        Command::Euroc(args) => euroc_command(args),
        Command::Bag(args) => bag_command(args),
        Command::List => {
            for e in catalog::entries() {
                match Scenario::load(e.name) {
                    Ok(s) => {
                        let tag = if e.name == catalog::DEFAULT {
                            " [default]"
                        } else {
                            ""
                        };
                        say(&format!("{:<34} {}{tag}\n", e.name, s.spec.description));
                    }
                    Err(err) => say(&format!("{:<34} (broken: {err})\n", e.name)),
                }
            }
            ExitCode::SUCCESS
        }
        Command::Regress {
            catalog,
            baseline,
            junit,
            update_baseline,
            estimator,
        } => regress_command(&catalog, baseline, junit, update_baseline, estimator),
        Command::Sweep {
            file,
            out,
            plan,
            keep_runs,
            shard,
            jobs,
            resume,
            force,
        } => match out {
            Some(out) if !plan => sweep_command(
                &file,
                &out,
                shard.as_deref(),
                jobs,
                SweepFlags {
                    resume,
                    force,
                    keep_runs,
                },
            ),
            _ => sweep_plan_command(&file, shard.as_deref(), jobs),
        },
        Command::SweepMerge { dirs, out } => {
            match scenarios::studies::sweep::merge::merge(&dirs, &out) {
                Ok(files) => {
                    say(&format!(
                        "merged {} shards into {}\n",
                        dirs.len(),
                        out.display()
                    ));
                    for f in files {
                        say(&format!("  {}\n", f.display()));
                    }
                    ExitCode::SUCCESS
                }
                Err(e) => {
                    eprintln!("vio sweep-merge: error: {e}");
                    ExitCode::from(BAD_INPUT)
                }
            }
        }
        Command::Bench { quick, out, one } => bench_command(quick, out, one),
        Command::Selfcheck => {
            let result = scenarios::selfcheck::run();
            say(&result.report);
            if result.ok {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            }
        }
        Command::ImuModel(args) => imu_model_command(args),
        Command::ImageStats(args) => image_stats_command(args),
        Command::Eval(args) => match eval(&args) {
            Ok((report, passed)) => {
                say(&report);
                if passed {
                    ExitCode::SUCCESS
                } else {
                    ExitCode::from(1)
                }
            }
            Err(e) => {
                eprintln!("vio eval: error: {e}");
                ExitCode::from(2)
            }
        },
    }
}

/// `--estimator VALUE` as the `--set` of `estimator_adapter`: a file named on the command line
/// is relative to the working folder.
fn estimator_setting(value: &str) -> String {
    let value = match std::path::absolute(value) {
        Ok(abs) if value.ends_with(".toml") || value.contains('/') => abs.display().to_string(),
        _ => value.to_string(),
    };
    format!("estimator_adapter={}", toml::Value::String(value))
}

/// [`load_scenario`] with `--set KEY=VALUE` settings laid on it.
fn load_scenario_with(name: Option<&str>, settings: &[String]) -> Result<Scenario, ExitCode> {
    let fail = |m: String| {
        eprintln!("error: {m}");
        ExitCode::from(BAD_INPUT)
    };
    let settings = settings
        .iter()
        .map(|s| scenarios::spec::parse_setting(s))
        .collect::<Result<Vec<_>, _>>()
        .map_err(fail)?;
    Scenario::load_with_settings(name.unwrap_or(catalog::DEFAULT), &settings)
        .map_err(|e| fail(e.to_string()))
}

fn load_scenario(name: Option<&str>) -> Result<Scenario, ExitCode> {
    Scenario::load(name.unwrap_or(catalog::DEFAULT)).map_err(|e| {
        eprintln!("error: {e}");
        ExitCode::from(BAD_INPUT)
    })
}

fn render_command(
    scenario: Option<String>,
    at: f64,
    out: &std::path::Path,
    seed: Option<u64>,
    tracks: bool,
) -> ExitCode {
    let scenario = match load_scenario(scenario.as_deref()) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let r = match scenarios::images::render_at(&scenario, at, seed) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    if let Err(e) = std::fs::create_dir_all(out) {
        eprintln!("error: {}: {e}", out.display());
        return ExitCode::from(BAD_INPUT);
    }
    let mut written = Vec::new();
    for c in &r.frame.cameras {
        let path = out.join(format!("cam{}.png", c.cam_id));
        let mut result = scenarios::images::write_gray_png(&path, &c.image);
        written.push(path);
        if let (Ok(()), Some(d)) = (&result, &c.depth) {
            let path = out.join(format!("cam{}_depth.png", c.cam_id));
            result = scenarios::images::write_depth_png(&path, d);
            written.push(path);
        }
        if let Err(e) = result {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    }
    let pair = out.join("stereo.png");
    if let Err(e) =
        scenarios::images::write_gray_png(&pair, &scenarios::images::side_by_side(&r.frame))
    {
        eprintln!("error: {e}");
        return ExitCode::from(BAD_INPUT);
    }
    written.push(pair);
    say(&format!(
        "rendered {} at t = {at} s on {} in {:.1} ms (with depth):\n",
        scenario.name,
        r.adapter,
        r.render_s * 1e3
    ));
    for p in written {
        say(&format!("  {}\n", p.display()));
    }
    if tracks {
        return tracks_command(&scenario, at, out, seed);
    }
    ExitCode::SUCCESS
}

/// `vio render --tracks`: tracks the captures before `at` and writes `OUT/tracks.png`.
fn tracks_command(
    scenario: &Scenario,
    at: f64,
    out: &std::path::Path,
    seed: Option<u64>,
) -> ExitCode {
    let t = match scenarios::tracks_image::render_tracks(scenario, at, seed) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(BAD_INPUT);
        }
    };
    let path = out.join("tracks.png");
    if let Err(e) = t.image.save_with_format(&path, image::ImageFormat::Png) {
        eprintln!("error: {}: cannot write the image: {e}", path.display());
        return ExitCode::from(BAD_INPUT);
    }
    say(&format!(
        "tracked {} captures from t = {:.2} s to {:.2} s (render {:.1} s, tracker {:.1} ms per capture): \
         {} tracks, {} with a stereo match:\n  {}\n",
        t.frames,
        t.first_ns as f64 * 1e-9,
        t.last_ns as f64 * 1e-9,
        t.render_s,
        t.track_s * 1e3 / t.frames.max(1) as f64,
        t.tracks,
        t.stereo_matches,
        path.display()
    ));
    ExitCode::SUCCESS
}

/// `--duration`: finite, > 0 and within the simulator's one-day bound.
fn check_duration(duration: Option<f64>) -> Result<(), ExitCode> {
    let max = sim::limits::MAX_DURATION_S;
    match duration {
        Some(d) if !(d.is_finite() && d > 0.0 && d <= max) => {
            eprintln!("error: --duration must be a number of seconds in (0, {max}], got {d}");
            Err(ExitCode::from(BAD_INPUT))
        }
        _ => Ok(()),
    }
}

/// Creates `--out` and checks that a file can be written there, before any work is done.
fn check_out_dir(dir: &std::path::Path) -> Result<(), ExitCode> {
    let probe = dir.join(".vio-write-check");
    let result = std::fs::create_dir_all(dir)
        .and_then(|()| std::fs::write(&probe, b""))
        .and_then(|()| std::fs::remove_file(&probe));
    result.map_err(|e| {
        eprintln!("error: --out {}: cannot write there: {e}", dir.display());
        ExitCode::from(BAD_INPUT)
    })
}

fn run_command(
    scenario: Option<String>,
    settings: Vec<String>,
    out: Option<PathBuf>,
    options: RunOptions,
) -> ExitCode {
    let scenario = match load_scenario_with(scenario.as_deref(), &settings) {
        Ok(s) => s,
        Err(code) => return code,
    };
    if let Err(code) = check_duration(options.duration_s) {
        return code;
    }
    let out_dir = out.unwrap_or_else(|| PathBuf::from("vio-out").join(&scenario.name));
    let created = !out_dir.exists();
    if let Err(code) = check_out_dir(&out_dir) {
        return code;
    }
    // A run that fails on its input leaves no empty folder it made behind.
    let cleanup = || {
        if created {
            let _ = std::fs::remove_dir(&out_dir);
        }
    };
    let run = match run_attended(
        &scenario.name,
        RunInput::Scenario(&scenario),
        &options,
        &out_dir,
    ) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            cleanup();
            return ExitCode::from(BAD_INPUT);
        }
    };
    finish_attended(&out_dir, &run, "")
}
