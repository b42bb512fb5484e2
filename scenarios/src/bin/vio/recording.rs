//! What `vio euroc` and `vio bag` share: a recording's common arguments checked, its run
//! attended, and its output folder written (or removed again when the run fails before it
//! wrote anything).

use std::path::Path;
use std::process::ExitCode;

use scenarios::run::RunOptions;

use scenarios::pipeline::RunInput;
use scenarios::spec::SuiteSpec;

use super::{BAD_INPUT, check_duration, check_out_dir, finish_attended, run_attended};

/// A recording's `--suite`: `stereo_imu`, `stereo` or `mono_imu`; `None` (said on stderr) for
/// anything else.
fn parse_suite(s: &str) -> Option<SuiteSpec> {
    match s {
        "stereo_imu" => Some(SuiteSpec::StereoImu),
        "stereo" => Some(SuiteSpec::Stereo),
        "mono_imu" => Some(SuiteSpec::MonoImu),
        other => {
            eprintln!("error: --suite {other}: expected stereo_imu, stereo or mono_imu");
            None
        }
    }
}

/// The suite of `--suite`, after checking `--pixel-sigma` and `--duration`; the exit code (2,
/// said on stderr) otherwise.
pub fn check_recording_args(
    suite: &str,
    pixel_sigma: f64,
    duration: Option<f64>,
) -> Result<SuiteSpec, ExitCode> {
    let suite = parse_suite(suite).ok_or(ExitCode::from(BAD_INPUT))?;
    if !(pixel_sigma.is_finite() && pixel_sigma > 0.0 && pixel_sigma <= 100.0) {
        eprintln!("error: --pixel-sigma {pixel_sigma}: expected a number in (0, 100] px");
        return Err(ExitCode::from(BAD_INPUT));
    }
    check_duration(duration)?;
    Ok(suite)
}

/// A recorded run's options: the front end's seed, the duration, `--mcap` (the window and the
/// covariance recorded for `run.mcap`).
pub fn recording_options(seed: u64, duration: Option<f64>, mcap: bool) -> RunOptions {
    RunOptions {
        seed: Some(seed),
        duration_s: duration,
        covariance: mcap,
        scene: mcap,
        ..Default::default()
    }
}

/// Runs `input` (`tag` labels its progress) into `out_dir`; `what` opens the first line
/// (`euroc PATH`, `bag PATH`), `features` says the frames came as feature tracks.
pub fn run_recording(
    tag: &str,
    out_dir: &Path,
    input: RunInput,
    options: &RunOptions,
    what: &str,
    features: bool,
) -> ExitCode {
    let created = !out_dir.exists();
    if let Err(code) = check_out_dir(out_dir) {
        return code;
    }
    let run = match run_attended(tag, input, options, out_dir) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            if created {
                let _ = std::fs::remove_dir_all(out_dir);
            }
            return ExitCode::from(BAD_INPUT);
        }
    };
    let source = if features { "feature tracks" } else { "images" };
    let preface = format!(
        "{what}: {} IMU samples, {} frames from {source}{}\n",
        run.output.imu_samples,
        run.output.frames_in,
        if run.context.ground_truth {
            format!(
                "; {} estimates outside the ground truth's span left out",
                run.without_truth
            )
        } else {
            "; no ground truth: not evaluated".into()
        }
    );
    finish_attended(out_dir, &run, &preface)
}
