//! The scenario file's serde types, as written (see the [`super`] module documentation).

use serde::Deserialize;

pub use super::camera_schema::{
    CalibrationErrorSpec, CameraSpec, ExtrinsicSpec, IntrinsicsErrorSpec, ModelSpec,
    RollingShutterSpec,
};
use super::{exact, units};

use estimator::Suite;

/// A scenario file as written (see the module documentation).
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// One line saying what the scenario exercises (shown by `vio list`).
    pub description: String,
    /// A sensor preset laid under the file (`catalog/presets/<name>.toml`): every key the
    /// preset sets that the file does not (`preset.rs`).
    pub preset: Option<String>,
    /// The sensors the estimator fuses.
    pub suite: SuiteSpec,
    /// Scene and seed.
    #[serde(default)]
    pub world: WorldSpec,
    /// The body's motion.
    pub trajectory: TrajectorySpec,
    /// Cameras and IMU.
    pub rig: RigSpec,
    /// How cameras measure: feature-level (default) or rendered images, and the rendering
    /// settings.
    #[serde(default)]
    pub camera: CameraModeSpec,
    /// Estimator settings: any [`estimator::EstimatorConfig`] setting by its name,
    /// nested ones as tables (`[estimator.solver]`, `[estimator.health]`); unset keys keep
    /// the defaults. Read through [`super::Scenario::estimator_config`].
    #[serde(default)]
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub estimator: toml::Table,
    /// Fault timeline.
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// Bounds on the run's metrics that `vio run` checks.
    #[serde(default)]
    pub expectations: ExpectationsSpec,
    /// The estimator that runs: `ours` (this project's, the default) or an outside program
    /// through an adapter: a built-in adapter's name (`openvins-tracks`, `openvins-images`) or
    /// an adapter `.toml` file relative to the scenario (`vio run --estimator`; the book's
    /// "Bring your own estimator"). The `[estimator]` table configures ours only.
    pub estimator_adapter: Option<String>,
}

/// The sensor suite.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SuiteSpec {
    /// Stereo camera and IMU.
    StereoImu,
    /// Stereo camera only.
    Stereo,
    /// The rig's first camera and the IMU (a second camera of the rig is simulated but not
    /// used).
    MonoImu,
}

impl SuiteSpec {
    /// The estimator's suite.
    pub fn suite(self) -> Suite {
        match self {
            SuiteSpec::StereoImu => Suite::StereoImu,
            SuiteSpec::Stereo => Suite::Stereo,
            SuiteSpec::MonoImu => Suite::MonoImu,
        }
    }

    /// The name used in files and reports (`stereo_imu`, `stereo`, `mono_imu`).
    pub fn as_str(self) -> &'static str {
        match self {
            SuiteSpec::StereoImu => "stereo_imu",
            SuiteSpec::Stereo => "stereo",
            SuiteSpec::MonoImu => "mono_imu",
        }
    }
}

/// `[camera]`: the camera measurement mode and, for rendered images, the renderer.
///
/// ```toml
/// [camera]
/// mode = "rendered"            # or "features" (default)
/// frontend = "klt"             # rendered: "klt" (default) or "truth" (ideal tracks)
/// [camera.tracker]             # any `estimator::frontend::TrackerConfig` field
/// [camera.render]              # every key optional
/// backend = "gl"               # "gl" (Mesa llvmpipe without a GPU) or "vulkan"
/// msaa = false                 # 4× multisampling of geometric edges
/// motion_blur = { exposure_s = 0.005, samples = 4 }
/// [camera.photometric]         # every key optional
/// vignetting = 0.2
/// read_noise = 1.0
/// ```
#[derive(Clone, Debug, Default, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraModeSpec {
    /// `features` (projected landmarks with pixel noise) or `rendered` (images as well).
    #[serde(default)]
    pub mode: CameraMode,
    /// Renderer settings: any [`sim::render::RenderConfig`] field by its name (unset keys keep
    /// its defaults; read through [`super::Scenario::render_config`]).
    #[serde(default)]
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub render: toml::Table,
    /// Exposure, vignetting and noise: any [`sim::render::Photometric`] field (defaults: none
    /// of the effects); laid over `render.photometric`.
    #[serde(default)]
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub photometric: toml::Table,
    /// Rendered mode: `klt` (default: the image front end tracks the rendered images) or
    /// `truth` (the simulator's ideal tracks of the same captures).
    #[serde(default)]
    pub frontend: FrontendSpec,
    /// The image front end's settings: any [`estimator::frontend::TrackerConfig`] field by
    /// its name (unset keys keep its defaults; read through [`super::Scenario::tracker_config`]).
    #[serde(default)]
    #[schemars(with = "serde_json::Map<String, serde_json::Value>")]
    pub tracker: toml::Table,
}

/// Which features the estimator gets in a rendered scenario.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FrontendSpec {
    /// The image front end (`estimator::frontend::FeatureTracker`) on the rendered images
    /// (the default when images are rendered).
    #[default]
    Klt,
    /// The simulator's ideal feature tracks of the same captures (for comparison).
    Truth,
}

/// Camera measurement mode.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum CameraMode {
    /// Feature-level measurements only.
    #[default]
    Features,
    /// Rendered images too; the estimator gets what the image front end tracks in them (or,
    /// with `frontend = "truth"`, the ideal tracks of the same captures).
    Rendered,
}

/// `[world]`: scene and seed.
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WorldSpec {
    /// Scene preset.
    #[serde(default)]
    pub scene: SceneSpec,
    /// Scenario seed (all random streams derive from it); `vio run --seed` overrides it.
    #[serde(default)]
    pub seed: u64,
    /// Landmarks per square metre of surface (default 8).
    pub landmark_density: Option<f64>,
}

impl Default for WorldSpec {
    fn default() -> Self {
        Self {
            scene: SceneSpec::Room,
            seed: 0,
            landmark_density: None,
        }
    }
}

/// Scene presets.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum SceneSpec {
    /// An 8 × 8 × 4 m Vicon room like EuRoC's V1/V2.
    #[default]
    Room,
    /// A machine hall like EuRoC's MH sequences.
    MachineHall,
    /// A ground plane with box buildings.
    Outdoor,
}

/// `[trajectory]`: duration, optional static start, and exactly one motion table.
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySpec {
    /// Run length (s); a replayed file may end earlier.
    pub duration_s: f64,
    /// Rest before the motion starts.
    pub static_start: Option<StaticStartSpec>,
    /// Stops inserted into the motion: `[{ at_s, duration_s, ramp_s }]`, sorted, not
    /// overlapping.
    #[serde(default)]
    pub stops: Vec<StopSpec>,
    /// Figure-eight generator.
    pub figure_eight: Option<FigureEightSpec>,
    /// Horizontal circle generator.
    pub circle: Option<CircleSpec>,
    /// General Lissajous generator.
    pub lissajous: Option<LissajousSpec>,
    /// Random smooth waypoints (drawn from the seed).
    pub waypoints: Option<WaypointsSpec>,
    /// Replay of a TUM or EuRoC ASL ground-truth file.
    pub replay: Option<ReplaySpec>,
    /// A ground vehicle's horizontal figure-eight, heading along its velocity.
    pub ground_vehicle: Option<GroundVehicleSpec>,
}

/// `trajectory.ground_vehicle`: `x = cx + a·sin(ωt)`, `y = cy + b·sin(2ωt)` at height `cz`,
/// level, the body's x axis along the velocity (see [`sim::motion::GroundVehicle`]).
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GroundVehicleSpec {
    /// Centre (m); `z` is the body's height.
    #[serde(deserialize_with = "exact::array")]
    pub center: [f64; 3],
    /// Half extent along x (m).
    pub half_width_m: f64,
    /// Half extent along y (m).
    pub half_height_m: f64,
    /// One loop (s).
    pub period_s: f64,
}

impl TrajectorySpec {
    /// The motion tables given (`figure_eight`, `circle`, `lissajous`, `waypoints`, `replay`);
    /// a valid file has exactly one.
    pub fn motions_given(&self) -> Vec<&'static str> {
        [
            ("figure_eight", self.figure_eight.is_some()),
            ("circle", self.circle.is_some()),
            ("lissajous", self.lissajous.is_some()),
            ("waypoints", self.waypoints.is_some()),
            ("replay", self.replay.is_some()),
            ("ground_vehicle", self.ground_vehicle.is_some()),
        ]
        .into_iter()
        .filter_map(|(n, g)| g.then_some(n))
        .collect()
    }
}

/// `trajectory.static_start`.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StaticStartSpec {
    /// Rest duration (s).
    pub hold_s: f64,
    /// Smooth ramp into the motion (s).
    pub ramp_s: f64,
}

/// One entry of `trajectory.stops`: the motion slows to rest from `at_s` (run time) over
/// `ramp_s`, rests for `duration_s`, speeds up over `ramp_s` and continues where it stopped.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StopSpec {
    /// Run time (s) at which the slow-down starts.
    pub at_s: f64,
    /// Time at rest (s).
    pub duration_s: f64,
    /// Slow-down and speed-up time (s); default 1.
    #[serde(default = "StopSpec::default_ramp_s")]
    pub ramp_s: f64,
}

impl StopSpec {
    fn default_ramp_s() -> f64 {
        1.0
    }
}

/// `trajectory.figure_eight`.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FigureEightSpec {
    /// Centre (m).
    #[serde(deserialize_with = "exact::array")]
    pub center: [f64; 3],
    /// Half-width along x (m).
    pub half_width_m: f64,
    /// Half-height along y (m).
    pub half_height_m: f64,
    /// One loop (s).
    pub period_s: f64,
}

/// `trajectory.circle`.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CircleSpec {
    /// Centre (m).
    #[serde(deserialize_with = "exact::array")]
    pub center: [f64; 3],
    /// Radius (m).
    pub radius_m: f64,
    /// One turn (s).
    pub period_s: f64,
}

/// `trajectory.lissajous`: `p = center + amplitude ⊙ sin(2π·freq·t + phase)` with yaw, pitch and
/// roll oscillations (see [`sim::motion::Lissajous`]).
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LissajousSpec {
    /// Centre (m).
    #[serde(deserialize_with = "exact::array")]
    pub center: [f64; 3],
    /// Per-axis amplitude (m).
    #[serde(deserialize_with = "exact::array")]
    pub amplitude_m: [f64; 3],
    /// Per-axis frequency (Hz).
    #[serde(deserialize_with = "exact::array")]
    pub freq_hz: [f64; 3],
    /// Per-axis phase (rad).
    #[serde(default)]
    #[serde(deserialize_with = "exact::array")]
    pub phase_rad: [f64; 3],
    /// Initial yaw (rad).
    #[serde(default)]
    pub yaw0_rad: f64,
    /// Constant yaw rate (rad/s).
    #[serde(default)]
    pub yaw_rate_rad_s: f64,
    /// Yaw oscillation amplitude (rad).
    #[serde(default)]
    pub yaw_amplitude_rad: f64,
    /// Yaw oscillation frequency (Hz).
    #[serde(default)]
    pub yaw_freq_hz: f64,
    /// Roll/pitch oscillation amplitude (rad).
    #[serde(default)]
    pub tilt_amplitude_rad: f64,
    /// Roll/pitch oscillation frequency (Hz).
    #[serde(default)]
    pub tilt_freq_hz: f64,
}

/// `trajectory.waypoints`.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WaypointsSpec {
    /// Lower corner of the box the waypoints are drawn in (m).
    #[serde(deserialize_with = "exact::array")]
    pub min: [f64; 3],
    /// Upper corner (m).
    #[serde(deserialize_with = "exact::array")]
    pub max: [f64; 3],
    /// Time between waypoints (s).
    pub spacing_s: f64,
    /// Largest yaw change between waypoints (rad).
    pub max_yaw_step_rad: f64,
    /// Largest roll/pitch (rad).
    pub max_tilt_rad: f64,
}

/// `trajectory.replay`.
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ReplaySpec {
    /// TUM or EuRoC ASL ground-truth file, relative to the scenario file.
    pub file: String,
    /// Spline knot spacing (s); default 0.04.
    pub knot_spacing_s: Option<f64>,
    /// Unit of the file's stamps: `"s"`, `"ms"`, `"us"` or `"ns"`; default: the format's (TUM
    /// seconds, ASL nanoseconds) when the stamp spacing fits it, else detected.
    pub time_unit: Option<TimeUnitSpec>,
    /// Drop glitch samples and bridge gaps (up to 2 s) instead of refusing the file; the
    /// summary and `report.json` say what was done.
    #[serde(default)]
    pub repair: bool,
    /// Largest departure of the fitted spline from a recorded sample (m); default 0.01.
    pub fit_tolerance_m: Option<f64>,
    /// Largest attitude departure of the fitted spline from a recorded sample (deg); default 1.
    pub fit_tolerance_deg: Option<f64>,
    /// Places the recording in the scene: rotation about the world z axis (deg), then
    /// translation (m), applied to every sample.
    pub placement: Option<PlacementSpec>,
}

/// `trajectory.replay.placement`: where a recording sits in the scene.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PlacementSpec {
    /// Translation (m) added after the rotation.
    #[serde(default, deserialize_with = "exact::array")]
    pub translation_m: [f64; 3],
    /// Rotation about the world z axis (deg).
    #[serde(default)]
    pub yaw_deg: f64,
}

/// `trajectory.replay.time_unit`.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
pub enum TimeUnitSpec {
    /// Seconds.
    #[serde(rename = "s")]
    Seconds,
    /// Milliseconds.
    #[serde(rename = "ms")]
    Milliseconds,
    /// Microseconds.
    #[serde(rename = "us")]
    Microseconds,
    /// Nanoseconds.
    #[serde(rename = "ns")]
    Nanoseconds,
}

/// `[rig]`: synchronized cameras and the IMU.
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RigSpec {
    /// Frame rate (Hz), up to the IMU's: frame `i` is captured at `i / rate_hz` rounded to the
    /// nanosecond, so rates such as 30 Hz, whose period is not a whole number of nanoseconds,
    /// keep their average rate.
    pub rate_hz: f64,
    /// Camera-IMU time offset (s): a frame taken at IMU time `t` is stamped `t − time_offset_s`.
    #[serde(default)]
    pub time_offset_s: f64,
    /// Seed new landmarks on the scene's surfaces where a camera's view runs short of
    /// `max_features` (default false).
    #[serde(default)]
    pub reseed: bool,
    /// Feature ids of the feature-level cameras: `"realistic"` (default: a new id for every
    /// track, as a tracker outputs; a re-acquired landmark is a new track; noisy pixels outside
    /// the image are dropped) or `"landmark"` (the landmark's id, stable over time: ideal
    /// re-association, and observations are kept whatever their noise).
    #[serde(default)]
    pub track_ids: TrackIdsSpec,
    /// The cameras; index = `cam_id` (0 = left). Written by `kalibr.camchain` when that is
    /// given.
    #[serde(default)]
    pub cameras: Vec<CameraSpec>,
    /// The IMU (written by `kalibr.imu` when that is given).
    pub imu: ImuSpec,
    /// Kalibr calibration files instead of `[[rig.cameras]]` / `[rig.imu]`.
    pub kalibr: Option<KalibrSpec>,
    /// A GNSS-like position receiver (its frame is the simulator's world frame).
    pub gnss: Option<GnssSpec>,
    /// Wheel odometry (forward speed of the body origin).
    pub wheel: Option<WheelSpec>,
    /// Calibration error drawn per seed: the estimator is given the rig's extrinsics off by
    /// Gaussian errors of these per-axis standard deviations (`calibration_draw.rs`).
    pub calibration_draw: Option<CalibrationDrawSpec>,
}

/// `[rig.calibration_draw]`: per-axis standard deviations of the calibration error drawn per
/// seed.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CalibrationDrawSpec {
    /// The stereo pair's rotation against the IMU (deg, body frame).
    #[serde(default)]
    pub camera_imu_rotation_deg: f64,
    /// The stereo pair's translation against the IMU (m, body frame).
    #[serde(default)]
    pub camera_imu_translation_m: f64,
    /// The second camera's rotation against the first (deg, body frame).
    #[serde(default)]
    pub stereo_rotation_deg: f64,
    /// The second camera's translation against the first (m, body frame).
    #[serde(default)]
    pub stereo_translation_m: f64,
}

/// `[rig.gnss]`.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GnssSpec {
    /// Fix rate (Hz).
    pub rate_hz: f64,
    /// White noise σ east / north / up (m), also the reported accuracy.
    #[serde(deserialize_with = "exact::array")]
    pub sigma_m: [f64; 3],
    /// Antenna position in the body frame (m).
    #[serde(default)]
    #[serde(deserialize_with = "exact::array")]
    pub lever_arm_m: [f64; 3],
}

/// `[rig.wheel]`.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct WheelSpec {
    /// Reading rate (Hz).
    pub rate_hz: f64,
    /// White noise σ of the speed (m/s).
    pub sigma_m_s: f64,
}

/// `rig.kalibr`: a Kalibr calibration as the rig (see [`crate::dataset::kalibr`]).
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct KalibrSpec {
    /// `camchain-imucam.yaml`, relative to the scenario file: the cameras.
    pub camchain: String,
    /// `imu.yaml`, relative to the scenario file: the IMU's rate and densities (else
    /// `[rig.imu]` is written out).
    pub imu: Option<String>,
    /// Feature noise of every camera (px); default 1.
    pub pixel_sigma_px: Option<f64>,
}

/// `rig.track_ids`: how the feature-level cameras assign feature ids.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum TrackIdsSpec {
    /// A new id for every track (what a tracker outputs).
    #[default]
    Realistic,
    /// The landmark id, stable over time (ideal association).
    Landmark,
}

/// `[rig.imu]`.
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImuSpec {
    /// A built-in IMU model (`"adis16448"`, `"bmi160"`: `catalog/sensors/imu/`, each with its
    /// sources) or a `.toml` file relative to the scenario, laid under this table: its keys
    /// fill what the table leaves unset (`sensor_preset.rs`).
    pub preset: Option<String>,
    /// Sample rate (Hz).
    #[serde(deserialize_with = "units::frequency")]
    pub rate_hz: f64,
    /// Gyroscope white noise density (rad/s/√Hz; or a string in datasheet units,
    /// `"0.18 deg/sqrt(h)"`: [`units`]).
    #[serde(deserialize_with = "units::gyro_density")]
    pub gyroscope_noise_density: f64,
    /// Accelerometer white noise density (m/s²/√Hz; or e.g. `"175 ug/sqrt(Hz)"`).
    #[serde(deserialize_with = "units::accel_density")]
    pub accelerometer_noise_density: f64,
    /// Gyroscope bias random walk (rad/s²/√Hz; or e.g. `"2 deg/h/sqrt(h)"`).
    #[serde(deserialize_with = "units::gyro_random_walk")]
    pub gyroscope_random_walk: f64,
    /// Accelerometer bias random walk (m/s³/√Hz; or e.g. `"0.03 mg/sqrt(s)"`).
    #[serde(deserialize_with = "units::accel_random_walk")]
    pub accelerometer_random_walk: f64,
    /// Simulate a noise-free IMU with constant biases (the estimator still uses the densities).
    #[serde(default)]
    pub noise_free: bool,
    /// Gyroscope bias at `t = 0` (rad/s).
    #[serde(default)]
    #[serde(deserialize_with = "exact::array")]
    pub initial_gyro_bias_rad_s: [f64; 3],
    /// Accelerometer bias at `t = 0` (m/s²).
    #[serde(default)]
    #[serde(deserialize_with = "exact::array")]
    pub initial_accel_bias_m_s2: [f64; 3],
    /// Per-axis gyroscope range (rad/s; or e.g. `"2000 deg/s"`); none: no saturation.
    #[serde(default, deserialize_with = "units::angular_rate_opt")]
    pub gyro_range_rad_s: Option<f64>,
    /// Per-axis accelerometer range (m/s²; or e.g. `"16 g"`); none: no saturation.
    #[serde(default, deserialize_with = "units::acceleration_opt")]
    pub accel_range_m_s2: Option<f64>,
    /// A recorded IMU log (EuRoC ASL `imu0/data.csv`, the replayed recording's clock, relative
    /// to the scenario file) the run uses instead of the simulated IMU; replay trajectories only.
    pub recorded: Option<String>,
    /// What the simulated IMU adds to the densities above: a built-in preset (`"euroc_mav"`,
    /// the EuRoC MAV's ADIS16448 fitted to its V1_01 log) or an error-model TOML file relative
    /// to the scenario (`vio imu-model --gt` writes one): bias instability and vibration.
    pub error_model: Option<String>,
}

/// Fault kinds.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// No frames (or empty frames with `black_frames = true`) on `[start_s, end_s)`.
    CameraBlackout,
    /// Camera `cam_id` dies at `at_s`.
    CameraDeath,
    /// Camera `cam_id` (every camera without it) repeats its last image and features on
    /// `[start_s, end_s)`.
    CameraFreeze,
    /// Frames dropped with `probability` on `[start_s, end_s)`.
    FrameDrops,
    /// No IMU samples on `[start_s, end_s)`.
    ImuDropout,
    /// IMU spikes (`probability`, `gyro_rad_s`, `accel_m_s2`) on `[start_s, end_s)`.
    ImuSpikes,
    /// IMU readings clamped to `gyro_range_rad_s`, `accel_range_m_s2` on `[start_s, end_s)`.
    ImuSaturation,
    /// Timestamp jitter (`imu_sigma_s`, `camera_sigma_s`) on `[start_s, end_s)`.
    TimestampJitter,
    /// Frames stamped `td_s` earlier from `at_s` on.
    CameraTimeOffset,
    /// No GNSS fixes on `[start_s, end_s)` (an end past the run removes the receiver).
    GnssOutage,
    /// Every GNSS fix off by `offset_m` from `at_s` on.
    GnssBiasJump,
    /// The wheels report `1 + slip_ratio` times the speed on `[start_s, end_s)`.
    WheelSlip,
}

/// One `[[faults]]` entry: a kind and the keys that kind takes.
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct FaultSpec {
    /// What goes wrong.
    pub kind: FaultKind,
    /// Start (s).
    pub start_s: Option<f64>,
    /// End (s).
    pub end_s: Option<f64>,
    /// Instant (s) for permanent faults.
    pub at_s: Option<f64>,
    /// Camera index (`camera_death`, `camera_freeze`).
    pub cam_id: Option<usize>,
    /// Emit empty frames instead of none (`camera_blackout`).
    pub black_frames: Option<bool>,
    /// Per-event probability (`frame_drops`, `imu_spikes`).
    pub probability: Option<f64>,
    /// Gyroscope spike size (rad/s).
    pub gyro_rad_s: Option<f64>,
    /// Accelerometer spike size (m/s²).
    pub accel_m_s2: Option<f64>,
    /// Gyroscope range (rad/s, `imu_saturation`).
    pub gyro_range_rad_s: Option<f64>,
    /// Accelerometer range (m/s², `imu_saturation`).
    pub accel_range_m_s2: Option<f64>,
    /// IMU stamp jitter σ (s).
    pub imu_sigma_s: Option<f64>,
    /// Camera stamp jitter σ (s).
    pub camera_sigma_s: Option<f64>,
    /// Time offset (s, `camera_time_offset`).
    pub td_s: Option<f64>,
    /// Position offset (m, `gnss_bias_jump`).
    pub offset_m: Option<[f64; 3]>,
    /// Relative excess wheel speed (`wheel_slip`).
    pub slip_ratio: Option<f64>,
}

/// A bound on a metric: `min ≤ value ≤ max`, either side optional.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Bound {
    /// Lower bound.
    pub min: Option<f64>,
    /// Upper bound.
    pub max: Option<f64>,
}

impl Bound {
    /// True if `value` satisfies the bound (a missing value never does).
    pub fn check(&self, value: Option<f64>) -> bool {
        match value {
            Some(v) if v.is_finite() => {
                self.min.is_none_or(|m| v >= m) && self.max.is_none_or(|m| v <= m)
            }
            _ => false,
        }
    }
}

/// `[expectations]`: bounds on the run's metrics.
#[derive(Clone, Debug, Default, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExpectationsSpec {
    /// Position ATE RMSE after alignment (m).
    pub ate_rmse_m: Option<Bound>,
    /// Rotation ATE RMSE after alignment (deg).
    pub ate_rot_rmse_deg: Option<Bound>,
    /// RPE translation RMSE over 1 m of ground-truth path (m; see [`crate::report`]).
    pub rpe_trans_rmse_m: Option<Bound>,
    /// A static run's largest position error from its first pose (m; `static_trajectory` in
    /// [`crate::report`]).
    pub position_drift_m: Option<Bound>,
    /// A static run's largest tilt error (deg).
    pub tilt_error_deg: Option<Bound>,
    /// Estimator resets.
    pub resets: Option<Bound>,
    /// Sensor-suite switches.
    pub suite_switches: Option<Bound>,
    /// IMU samples excluded as spikes.
    pub imu_samples_excluded: Option<Bound>,
    /// IMU samples on the sensor's range.
    pub imu_samples_saturated: Option<Bound>,
    /// The slowest return (s) of the full sensor suite after a fault's end.
    pub recovery_s: Option<Bound>,
    /// Fraction of processed frames in tracking state.
    pub tracking_fraction: Option<Bound>,
    /// Final gyroscope bias error (rad/s).
    pub gyro_bias_error_rad_s: Option<Bound>,
    /// Final accelerometer bias error (m/s²).
    pub accel_bias_error_m_s2: Option<Bound>,
    /// Fewest features the image front end tracked in a frame.
    pub frontend_features_min: Option<Bound>,
    /// Median track error of the image front end (px).
    pub frontend_track_error_median_px: Option<Bound>,
    /// 95th-percentile track error of the image front end (px).
    pub frontend_track_error_p95_px: Option<Bound>,
    /// Fraction of wrong tracks (> 2 px) the estimator gets.
    pub frontend_wrong_after_ransac: Option<Bound>,
    /// Median stereo match error (px).
    pub frontend_stereo_error_median_px: Option<Bound>,
    /// RMS of the position error in the GNSS frame through the estimated alignment, no
    /// trajectory alignment (m; frames after the GNSS alignment).
    pub gnss_global_rmse_m: Option<Bound>,
    /// Time (s) at which the GNSS alignment was initialized.
    pub gnss_aligned_at_s: Option<Bound>,
}

impl ExpectationsSpec {
    /// `(metric name, bound)` for every bound that is set, in a fixed order.
    pub fn bounds(&self) -> Vec<(&'static str, Bound)> {
        [
            ("ate_rmse_m", self.ate_rmse_m),
            ("ate_rot_rmse_deg", self.ate_rot_rmse_deg),
            ("rpe_trans_rmse_m", self.rpe_trans_rmse_m),
            ("position_drift_m", self.position_drift_m),
            ("tilt_error_deg", self.tilt_error_deg),
            ("resets", self.resets),
            ("suite_switches", self.suite_switches),
            ("imu_samples_excluded", self.imu_samples_excluded),
            ("imu_samples_saturated", self.imu_samples_saturated),
            ("recovery_s", self.recovery_s),
            ("tracking_fraction", self.tracking_fraction),
            ("gyro_bias_error_rad_s", self.gyro_bias_error_rad_s),
            ("accel_bias_error_m_s2", self.accel_bias_error_m_s2),
            ("frontend_features_min", self.frontend_features_min),
            (
                "frontend_track_error_median_px",
                self.frontend_track_error_median_px,
            ),
            (
                "frontend_track_error_p95_px",
                self.frontend_track_error_p95_px,
            ),
            (
                "frontend_wrong_after_ransac",
                self.frontend_wrong_after_ransac,
            ),
            (
                "frontend_stereo_error_median_px",
                self.frontend_stereo_error_median_px,
            ),
            ("gnss_global_rmse_m", self.gnss_global_rmse_m),
            ("gnss_aligned_at_s", self.gnss_aligned_at_s),
        ]
        .into_iter()
        .filter_map(|(n, b)| b.map(|b| (n, b)))
        .collect()
    }
}
