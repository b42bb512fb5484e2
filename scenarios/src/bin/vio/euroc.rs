//! `vio euroc`: the image front end and the estimator on a recorded EuRoC ASL folder.

use std::path::PathBuf;
use std::process::ExitCode;

use scenarios::run::EurocOptions;

use scenarios::pipeline::RunInput;

use super::recording::{check_recording_args, recording_options, run_recording};

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
    let suite = match check_recording_args(&args.suite, args.pixel_sigma, args.duration) {
        Ok(s) => s,
        Err(code) => return code,
    };
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
    let features = args.features.is_some();
    let options = EurocOptions {
        suite,
        features: args.features,
        settings: args.settings,
        pixel_sigma_px: args.pixel_sigma,
    };
    let input = RunInput::Euroc {
        mav0: &mav0,
        options: &options,
    };
    run_recording(
        &format!("euroc-{name}"),
        &out_dir,
        input,
        &recording_options(args.seed, args.duration, args.mcap),
        &format!("euroc {}", mav0.display()),
        features,
    )
}
