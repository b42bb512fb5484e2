//! `vio euroc`: the image front end and the estimator on a recorded EuRoC ASL folder.

use std::path::PathBuf;
use std::process::ExitCode;

use scenarios::run::{EurocOptions, RunInput, RunOptions};
use scenarios::spec::SuiteSpec;

use super::{BAD_INPUT, check_duration, check_out_dir, finish_attended, run_attended};

/// `vio euroc` arguments.
#[derive(clap::Args)]
pub struct EurocArgs {
    /// The dataset's `mav0` folder (or the folder holding it).
    pub mav0: PathBuf,
    /// Sensor suite: `stereo_imu` (cam0 + cam1 + imu0), `stereo` or `mono_imu` (cam0 + imu0).
    #[arg(long, default_value = "stereo_imu")]
    pub suite: String,
    /// Feed this `features.csv` (`vio export`'s feature tracks) instead of tracking the images.
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// A TOML file whose `[estimator]` and `[camera.tracker]` tables override the defaults (a
    /// scenario file works; `vio settings` prints every key).
    #[arg(long)]
    pub settings: Option<PathBuf>,
    /// Pixel noise σ (px) the estimator assumes for every camera.
    #[arg(long, default_value_t = 1.0)]
    pub pixel_sigma: f64,
    /// Seed of the front end's RANSAC.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Only the first seconds of the dataset.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Also write `run.mcap` for viewers (Foxglove, Rerun; see `vio run --mcap`).
    #[arg(long)]
    pub mcap: bool,
    /// Output folder [default: ./vio-out/euroc-NAME, NAME the dataset folder's name].
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `vio euroc`: exit 0 (ran; with ground truth every default expectation holds), 1 (an
/// expectation failed), 2 (bad input).
pub fn euroc_command(args: EurocArgs) -> ExitCode {
    let Some(suite) = parse_suite(&args.suite) else {
        return ExitCode::from(BAD_INPUT);
    };
    if !(args.pixel_sigma.is_finite() && args.pixel_sigma > 0.0 && args.pixel_sigma <= 100.0) {
        eprintln!(
            "error: --pixel-sigma {}: expected a number in (0, 100] px",
            args.pixel_sigma
        );
        return ExitCode::from(BAD_INPUT);
    }
    if let Err(code) = check_duration(args.duration) {
        return code;
    }
    // Either the `mav0` folder or its parent.
    let mav0 = if args.mav0.join("mav0").is_dir() {
        args.mav0.join("mav0")
    } else {
        args.mav0.clone()
    };
    let name = mav0
        .canonicalize()
        .ok()
        .and_then(|p| p.parent().and_then(|d| d.file_name()).map(|n| n.to_owned()))
        .map_or("dataset".into(), |n| n.to_string_lossy().into_owned());
    let out_dir = args
        .out
        .unwrap_or_else(|| PathBuf::from("vio-out").join(format!("euroc-{name}")));
    let created = !out_dir.exists();
    if let Err(code) = check_out_dir(&out_dir) {
        return code;
    }
    let options = EurocOptions {
        suite,
        features: args.features,
        settings: args.settings,
        pixel_sigma_px: args.pixel_sigma,
    };
    let run_options = RunOptions {
        seed: Some(args.seed),
        duration_s: args.duration,
        covariance: args.mcap,
        scene: args.mcap,
        ..Default::default()
    };
    let input = RunInput::Euroc {
        mav0: &mav0,
        options: &options,
    };
    let run = match run_attended(&format!("euroc-{name}"), input, &run_options) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            if created {
                let _ = std::fs::remove_dir_all(&out_dir);
            }
            return ExitCode::from(BAD_INPUT);
        }
    };
    let source = if options.features.is_some() {
        "feature tracks"
    } else {
        "images"
    };
    let preface = format!(
        "euroc {}: {} IMU samples, {} frames from {source}{}\n",
        mav0.display(),
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
    finish_attended(&out_dir, &run, &preface)
}

/// A recording's `--suite`: `stereo_imu`, `stereo` or `mono_imu`; `None` (said on stderr) for
/// anything else.
pub fn parse_suite(s: &str) -> Option<SuiteSpec> {
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
