//! `vio bag`: the image front end and the estimator on a recorded ROS 2 bag (MCAP).

use std::path::PathBuf;
use std::process::ExitCode;

use scenarios::run::BagOptions;

use scenarios::pipeline::RunInput;

use super::recording::{check_recording_args, recording_options, run_recording};

/// `vio bag` arguments.
#[derive(clap::Args)]
pub struct BagArgs {
    /// The bag: one `.mcap` file (rosbag2's MCAP storage).
    pub bag: PathBuf,
    /// Sensor suite: `stereo_imu` (left + right + IMU), `stereo` or `mono_imu` (left + IMU).
    #[arg(long, default_value = "stereo_imu")]
    pub suite: String,
    /// The `sensor_msgs/msg/Imu` topic.
    #[arg(long, default_value = "/imu0")]
    pub imu: String,
    /// The left camera's `sensor_msgs/msg/Image` topic (mono8).
    #[arg(long, default_value = "/cam0/image_raw")]
    pub left: String,
    /// The right camera's `sensor_msgs/msg/Image` topic (stereo suites).
    #[arg(long, default_value = "/cam1/image_raw")]
    pub right: String,
    /// Feed this `sensor_msgs/msg/PointCloud2` feature-track topic (as `vio export --format
    /// mcap` writes `/features`) instead of tracking the images.
    #[arg(long)]
    pub features: Option<String>,
    /// The ground-truth topic (`geometry_msgs/msg/PoseStamped` or `TransformStamped`)
    /// [default: `/groundtruth/pose` when the bag has it].
    #[arg(long)]
    pub groundtruth: Option<String>,
    /// Kalibr `camchain-imucam.yaml` of the rig [default: the bag's attachment of that name].
    #[arg(long)]
    pub camchain: Option<PathBuf>,
    /// The cameras from the bag's own `sensor_msgs/msg/CameraInfo` (beside each image topic)
    /// and `/tf_static` instead of a camchain (plumb_bob or equidistant).
    #[arg(long, conflicts_with = "camchain")]
    pub camera_info: bool,
    /// Kalibr `imu.yaml` (noise densities) [default: the bag's attachment of that name].
    #[arg(long)]
    pub imu_yaml: Option<PathBuf>,
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
    /// Only the first seconds of the bag.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Also write `run.mcap` for viewers (Foxglove, Rerun; see `vio run --mcap`).
    #[arg(long)]
    pub mcap: bool,
    /// Output folder [default: ./vio-out/bag-NAME, NAME the bag's file stem].
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// Runs `vio bag`: exit 0 (ran; with ground truth every default expectation holds), 1 (an
/// expectation failed), 2 (bad input).
pub fn bag_command(args: BagArgs) -> ExitCode {
    let suite = match check_recording_args(&args.suite, args.pixel_sigma, args.duration) {
        Ok(s) => s,
        Err(code) => return code,
    };
    let name = args
        .bag
        .file_stem()
        .map_or("bag".into(), |n| n.to_string_lossy().into_owned());
    let out_dir = args
        .out
        .unwrap_or_else(|| PathBuf::from("vio-out").join(format!("bag-{name}")));
    let features = args.features.is_some();
    let options = BagOptions {
        suite,
        imu_topic: args.imu,
        image_topics: vec![args.left, args.right],
        features_topic: args.features,
        groundtruth_topic: args.groundtruth,
        camchain: args.camchain,
        camera_info: args.camera_info,
        imu_yaml: args.imu_yaml,
        settings: args.settings,
        pixel_sigma_px: args.pixel_sigma,
    };
    let input = RunInput::Bag {
        path: &args.bag,
        options: &options,
    };
    run_recording(
        &format!("bag-{name}"),
        &out_dir,
        input,
        &recording_options(args.seed, args.duration, args.mcap),
        &format!("bag {}", args.bag.display()),
        features,
    )
}
