//! The scenario file schema (TOML) and its mapping onto [`sim::WorldConfig`] and
//! [`estimator::estimator::EstimatorConfig`].
//!
//! A scenario file describes one run: the world (scene preset, seed), the trajectory (a generator
//! or a replayed ground-truth file), the sensor rig (cameras and IMU), the sensor suite the
//! estimator fuses, optional estimator settings, a fault timeline and the expectations `vio run`
//! checks. Every table rejects unknown keys, so a typo is an error rather than a silently ignored
//! setting. The built-in scenarios in `scenarios/catalog/` are the reference examples; a minimal
//! file looks like this:
//!
//! ```toml
//! description = "Stereo+IMU, a 20 s figure-eight in the room"
//! suite = "stereo_imu"            # or "stereo", "mono_imu" (the first camera and the IMU)
//!
//! [world]
//! scene = "room"
//! seed = 1
//!
//! [trajectory]
//! duration_s = 20.0
//! figure_eight = { center = [-0.5, 0.5, 1.5], half_width_m = 2.0, half_height_m = 1.0, period_s = 20.0 }
//!
//! [rig]
//! rate_hz = 20.0
//!
//! [[rig.cameras]]
//! model = "pinhole_radtan"
//! resolution = [752, 480]
//! intrinsics = [458.654, 457.296, 367.215, 248.375]
//! distortion = [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
//! T_b_c = { translation_m = [0.0, 0.055, 0.0], rotation = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]] }
//! pixel_sigma_px = 1.0
//!
//! [[rig.cameras]]
//! model = "pinhole_radtan"
//! resolution = [752, 480]
//! intrinsics = [458.654, 457.296, 367.215, 248.375]
//! distortion = [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
//! T_b_c = { translation_m = [0.0, -0.055, 0.0], rotation = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]] }
//! pixel_sigma_px = 1.0
//!
//! [rig.imu]
//! rate_hz = 200.0
//! gyroscope_noise_density = 1.6968e-4
//! accelerometer_noise_density = 2.0e-3
//! gyroscope_random_walk = 1.9393e-5
//! accelerometer_random_walk = 3.0e-3
//!
//! [expectations]
//! ate_rmse_m = { max = 0.1 }
//! ```
//!
//! Errors ([`SpecError`]) name the file, the key path (`rig.cameras[1].intrinsics`), the line
//! when it is known, and what was expected.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use estimator::camera::{
    Camera, CameraError, CameraModel, DoubleSphere, KannalaBrandt, Mei, PinholeRadtan,
};
use estimator::estimator::{CameraConfig as EstCamera, EstimatorConfig, Suite};
use estimator::geometry::Pose;
use estimator::imu::ImuNoise;
use estimator::problem::Method;
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};
use serde::Deserialize;
use sim::camera::{CameraConfig as SimCamera, RigConfig, TrackIds};
use sim::faults::Fault;
use sim::imu::{ImuConfig, ImuWindow};
use sim::motion::{Lissajous, RandomWaypoints, Replay};
use sim::render::{GainStep, MotionBlur, Photometric, RenderBackend, RenderConfig, RenderError};
use sim::scene::{SceneConfig, ScenePreset};
use sim::{StaticStartConfig, TrajectoryConfig, WorldConfig};

use crate::catalog;
pub use crate::tracker_spec::{FrontendSpec, TrackerSpec};
use estimator::frontend::TrackerConfig;

/// A scenario file as written (see the module documentation).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioSpec {
    /// One line saying what the scenario exercises (shown by `vio list`).
    pub description: String,
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
    /// Estimator settings (every key optional; defaults from `EstimatorConfig::new`).
    #[serde(default)]
    pub estimator: EstimatorSpec,
    /// Fault timeline.
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// Bounds on the run's metrics that `vio run` checks.
    #[serde(default)]
    pub expectations: ExpectationsSpec,
}

/// The sensor suite.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
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
/// [camera.tracker]             # every key optional (see `TrackerSpec`)
/// [camera.render]              # every key optional
/// backend = "gl"               # "gl" (Mesa llvmpipe without a GPU) or "vulkan"
/// msaa = false                 # 4× multisampling of geometric edges
/// motion_blur = { exposure_s = 0.005, samples = 4 }
/// [camera.photometric]         # every key optional
/// vignetting = 0.2
/// read_noise = 1.0
/// ```
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraModeSpec {
    /// `features` (projected landmarks with pixel noise) or `rendered` (images as well).
    #[serde(default)]
    pub mode: CameraMode,
    /// Renderer settings (defaults: `sim::render::RenderConfig::default()`).
    #[serde(default)]
    pub render: RenderSpec,
    /// Exposure, vignetting and noise (defaults: none).
    #[serde(default)]
    pub photometric: PhotometricSpec,
    /// Rendered mode: `klt` (default: the image front end tracks the rendered images) or
    /// `truth` (the simulator's ideal tracks of the same captures).
    #[serde(default)]
    pub frontend: FrontendSpec,
    /// The image front end's settings.
    #[serde(default)]
    pub tracker: TrackerSpec,
}

/// Camera measurement mode.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CameraMode {
    /// Feature-level measurements only.
    #[default]
    Features,
    /// Rendered images too; the estimator gets what the image front end tracks in them (or,
    /// with `frontend = "truth"`, the ideal tracks of the same captures).
    Rendered,
}

/// Renderer backend.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum BackendSpec {
    /// OpenGL through EGL.
    Gl,
    /// Vulkan.
    Vulkan,
}

/// `[camera.render]` (see `sim::render::RenderConfig` for each key's meaning).
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderSpec {
    /// Backend (default `gl`).
    pub backend: Option<BackendSpec>,
    /// Adapter name substring.
    pub adapter: Option<String>,
    /// 4× MSAA.
    pub msaa: Option<bool>,
    /// Trilinear texture filtering.
    pub trilinear: Option<bool>,
    /// Anisotropic filtering clamp.
    pub anisotropy: Option<u16>,
    /// Virtual pinhole focal scale.
    pub pinhole_scale: Option<f64>,
    /// Texture tile size (texels).
    pub texture_size: Option<u32>,
    /// Texel size (m).
    pub texel_m: Option<f64>,
    /// Largest rendered off-axis angle (deg).
    pub max_half_angle_deg: Option<f64>,
    /// Render depth images too.
    pub depth: Option<bool>,
    /// Motion blur.
    pub motion_blur: Option<MotionBlurSpec>,
}

/// `motion_blur = { exposure_s, samples }`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionBlurSpec {
    /// Exposure (s).
    pub exposure_s: f64,
    /// Sub-frame renders (2..=32).
    pub samples: u32,
}

/// `[camera.photometric]` (see `sim::render::Photometric`).
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhotometricSpec {
    /// Mean gain.
    pub gain: Option<f64>,
    /// Relative gain oscillation amplitude.
    pub gain_variation: Option<f64>,
    /// Gain oscillation period (s).
    pub gain_period_s: Option<f64>,
    /// Corner darkening (0..=1).
    pub vignetting: Option<f64>,
    /// Read noise σ (grey levels).
    pub read_noise: Option<f64>,
    /// Electrons per grey level (shot noise; 0 = none).
    pub electrons_per_level: Option<f64>,
    /// A gain step: `{ at_s, factor }`.
    pub gain_step: Option<GainStepSpec>,
}

/// `gain_step = { at_s, factor }`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainStepSpec {
    /// When (s).
    pub at_s: f64,
    /// Gain factor from then on.
    pub factor: f64,
}

/// `[world]`: scene and seed.
#[derive(Clone, Debug, Deserialize)]
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
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
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
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySpec {
    /// Run length (s); a replayed file may end earlier.
    pub duration_s: f64,
    /// Rest before the motion starts.
    pub static_start: Option<StaticStartSpec>,
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
}

/// `trajectory.static_start`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StaticStartSpec {
    /// Rest duration (s).
    pub hold_s: f64,
    /// Smooth ramp into the motion (s).
    pub ramp_s: f64,
}

/// `trajectory.figure_eight`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FigureEightSpec {
    /// Centre (m).
    pub center: [f64; 3],
    /// Half-width along x (m).
    pub half_width_m: f64,
    /// Half-height along y (m).
    pub half_height_m: f64,
    /// One loop (s).
    pub period_s: f64,
}

/// `trajectory.circle`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircleSpec {
    /// Centre (m).
    pub center: [f64; 3],
    /// Radius (m).
    pub radius_m: f64,
    /// One turn (s).
    pub period_s: f64,
}

/// `trajectory.lissajous`: `p = center + amplitude ⊙ sin(2π·freq·t + phase)` with yaw, pitch and
/// roll oscillations (see [`sim::motion::Lissajous`]).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LissajousSpec {
    /// Centre (m).
    pub center: [f64; 3],
    /// Per-axis amplitude (m).
    pub amplitude_m: [f64; 3],
    /// Per-axis frequency (Hz).
    pub freq_hz: [f64; 3],
    /// Per-axis phase (rad).
    #[serde(default)]
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
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WaypointsSpec {
    /// Lower corner of the box the waypoints are drawn in (m).
    pub min: [f64; 3],
    /// Upper corner (m).
    pub max: [f64; 3],
    /// Time between waypoints (s).
    pub spacing_s: f64,
    /// Largest yaw change between waypoints (rad).
    pub max_yaw_step_rad: f64,
    /// Largest roll/pitch (rad).
    pub max_tilt_rad: f64,
}

/// `trajectory.replay`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReplaySpec {
    /// TUM or EuRoC ASL ground-truth file, relative to the scenario file.
    pub file: String,
    /// Spline knot spacing (s); default 0.04.
    pub knot_spacing_s: Option<f64>,
}

/// `[rig]`: synchronized cameras and the IMU.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigSpec {
    /// Frame rate (Hz).
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
    /// The cameras; index = `cam_id` (0 = left).
    pub cameras: Vec<CameraSpec>,
    /// The IMU.
    pub imu: ImuSpec,
}

/// `rig.track_ids`: how the feature-level cameras assign feature ids.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum TrackIdsSpec {
    /// A new id for every track (what a tracker outputs).
    #[default]
    Realistic,
    /// The landmark id, stable over time (ideal association).
    Landmark,
}

/// Camera projection models.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum ModelSpec {
    /// Pinhole with radial-tangential distortion: `distortion = [k1, k2, p1, p2]`.
    PinholeRadtan,
    /// Kannala-Brandt equidistant fisheye: `distortion = [k1, k2, k3, k4]`.
    KannalaBrandt,
    /// Mei unified model: `xi` and `distortion = [k1, k2, p1, p2]`.
    Mei,
    /// Double sphere: `xi` and `alpha`, no distortion.
    DoubleSphere,
}

/// One `[[rig.cameras]]` entry.
#[allow(non_snake_case)]
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Sensor name (selects its random streams); default `cam<index>`.
    pub name: Option<String>,
    /// Projection model.
    pub model: ModelSpec,
    /// `[width, height]` (px).
    pub resolution: [u32; 2],
    /// `[fx, fy, cx, cy]` (px).
    pub intrinsics: [f64; 4],
    /// Distortion coefficients (see [`ModelSpec`]).
    #[serde(default)]
    pub distortion: Vec<f64>,
    /// Mei and double-sphere ξ.
    pub xi: Option<f64>,
    /// Double-sphere α.
    pub alpha: Option<f64>,
    /// Extrinsic camera-to-body transform.
    pub T_b_c: ExtrinsicSpec,
    /// Feature noise standard deviation (px).
    pub pixel_sigma_px: f64,
    /// Most features per frame (default 150).
    pub max_features: Option<usize>,
    /// Nearest visible depth (m, default 0.1).
    pub min_depth_m: Option<f64>,
    /// Farthest visible depth (m, default 40).
    pub max_depth_m: Option<f64>,
    /// Longest track (frames; the landmark then rests as many frames in this camera); default
    /// unlimited, as the image front end's tracks (lost only when the feature is).
    pub max_track_length: Option<u32>,
}

/// A rigid transform: translation plus exactly one of a rotation matrix (rows) or a Hamilton
/// quaternion `[qx, qy, qz, qw]`.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExtrinsicSpec {
    /// Translation (m).
    pub translation_m: [f64; 3],
    /// Rotation matrix, rows.
    pub rotation: Option<[[f64; 3]; 3]>,
    /// Rotation quaternion `[qx, qy, qz, qw]`.
    pub quaternion_xyzw: Option<[f64; 4]>,
}

/// `[rig.imu]`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuSpec {
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Gyroscope white noise density (rad/s/√Hz).
    pub gyroscope_noise_density: f64,
    /// Accelerometer white noise density (m/s²/√Hz).
    pub accelerometer_noise_density: f64,
    /// Gyroscope bias random walk (rad/s²/√Hz).
    pub gyroscope_random_walk: f64,
    /// Accelerometer bias random walk (m/s³/√Hz).
    pub accelerometer_random_walk: f64,
    /// Simulate a noise-free IMU with constant biases (the estimator still uses the densities).
    #[serde(default)]
    pub noise_free: bool,
    /// Gyroscope bias at `t = 0` (rad/s).
    #[serde(default)]
    pub initial_gyro_bias_rad_s: [f64; 3],
    /// Accelerometer bias at `t = 0` (m/s²).
    #[serde(default)]
    pub initial_accel_bias_m_s2: [f64; 3],
    /// Per-axis gyroscope range (rad/s); none: no saturation.
    pub gyro_range_rad_s: Option<f64>,
    /// Per-axis accelerometer range (m/s²); none: no saturation.
    pub accel_range_m_s2: Option<f64>,
}

/// `[estimator]`: every key optional.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EstimatorSpec {
    /// Keyframes in the window.
    pub window_size: Option<usize>,
    /// Solver iterations per frame.
    pub solver_iterations: Option<usize>,
    /// `levenberg_marquardt` or `dogleg`.
    pub solver_method: Option<MethodSpec>,
    /// The solve stops once an accepted step lowers the cost by less than this fraction.
    pub solver_function_tolerance: Option<f64>,
    /// Keyframe parallax threshold (px).
    pub keyframe_parallax_px: Option<f64>,
    /// Keyframe when fewer features are tracked.
    pub keyframe_min_tracked: Option<usize>,
    /// Huber threshold (σ units).
    pub huber_sigma: Option<f64>,
    /// Outlier track threshold (px).
    pub outlier_reprojection_px: Option<f64>,
    /// Frames collected before visual-inertial initialization.
    pub init_frames: Option<usize>,
    /// Pixel noise σ the estimator assumes (default: each camera's `pixel_sigma_px`, at
    /// least 0.5).
    pub pixel_sigma_px: Option<f64>,
    /// Initial camera-IMU time offset (s).
    pub td_s: Option<f64>,
    /// Estimate the time offset online.
    pub estimate_td: Option<bool>,
    /// Estimate the camera extrinsics online.
    pub estimate_extrinsics: Option<bool>,
    /// Keep using the tracks of a marginalized keyframe (VINS-Fusion; counts their
    /// observations twice) instead of ending them.
    pub reuse_marginalized_tracks: Option<bool>,
    /// Frames a track must span before it enters the optimization.
    pub min_track_frames: Option<usize>,
    /// Persistent world points kept through marginalization (0: none).
    pub max_persistent_points: Option<usize>,
    /// Evaluate every factor's Jacobians of states in the marginalization prior at the
    /// prior's linearization point (first-estimate Jacobians).
    pub first_estimate_jacobians: Option<bool>,
    /// Also first-estimate Jacobians for the persistent world points.
    pub first_estimate_points: Option<bool>,
}

/// Solver methods.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum MethodSpec {
    /// Levenberg–Marquardt.
    LevenbergMarquardt,
    /// Powell's dogleg.
    Dogleg,
}

/// Fault kinds.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// No frames (or empty frames with `black_frames = true`) on `[start_s, end_s)`.
    CameraBlackout,
    /// Camera `cam_id` dies at `at_s`.
    CameraDeath,
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
}

/// One `[[faults]]` entry: a kind and the keys that kind takes.
#[derive(Clone, Debug, Deserialize)]
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
    /// Camera index (`camera_death`).
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
}

/// A bound on a metric: `min ≤ value ≤ max`, either side optional.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq)]
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
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpectationsSpec {
    /// Position ATE RMSE after alignment (m).
    pub ate_rmse_m: Option<Bound>,
    /// Rotation ATE RMSE after alignment (deg).
    pub ate_rot_rmse_deg: Option<Bound>,
    /// RPE translation RMSE over 1 m of ground-truth path (m; see [`crate::report`]).
    pub rpe_trans_rmse_m: Option<Bound>,
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
}

impl ExpectationsSpec {
    /// `(metric name, bound)` for every bound that is set, in a fixed order.
    pub fn bounds(&self) -> Vec<(&'static str, Bound)> {
        [
            ("ate_rmse_m", self.ate_rmse_m),
            ("ate_rot_rmse_deg", self.ate_rot_rmse_deg),
            ("rpe_trans_rmse_m", self.rpe_trans_rmse_m),
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
        ]
        .into_iter()
        .filter_map(|(n, b)| b.map(|b| (n, b)))
        .collect()
    }
}

/// A scenario error: names the file, the key path, the line when known, and what was wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecError {
    /// The scenario file (or `catalog:<name>`).
    pub file: String,
    /// Dotted key path, e.g. `rig.cameras[1].intrinsics` (empty for the whole file).
    pub key: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// What was wrong / expected.
    pub message: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        if !self.key.is_empty() {
            write!(f, ": key `{}`", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for SpecError {}

/// Where a scenario came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Origin {
    /// A built-in catalog scenario (its data files are embedded too).
    Catalog,
    /// A file on disk; relative data paths resolve against its directory.
    File(PathBuf),
}

/// A parsed, validated scenario.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Name: the catalog name or the file stem.
    pub name: String,
    /// Where it came from.
    pub origin: Origin,
    /// The parsed file.
    pub spec: ScenarioSpec,
    /// The file's text (kept for line lookups in later errors).
    text: String,
    /// The camera models, built once: the simulator and the estimator share these.
    models: Vec<Arc<dyn CameraModel>>,
}

impl Scenario {
    /// Loads a catalog scenario by name, or else a `.toml` file by path.
    pub fn load(name_or_path: &str) -> Result<Self, SpecError> {
        if let Some(entry) = catalog::get(name_or_path) {
            return Self::parse(entry.name, Origin::Catalog, entry.text);
        }
        let path = Path::new(name_or_path);
        if path.extension().is_some_and(|e| e == "toml") || path.exists() {
            return Self::from_file(path);
        }
        Err(SpecError {
            file: name_or_path.into(),
            key: String::new(),
            line: None,
            message: format!(
                "no catalog scenario of that name and no such file (catalog: {})",
                catalog::names().join(", ")
            ),
        })
    }

    /// Reads and parses a scenario file.
    pub fn from_file(path: &Path) -> Result<Self, SpecError> {
        let text = std::fs::read_to_string(path).map_err(|e| SpecError {
            file: path.display().to_string(),
            key: String::new(),
            line: None,
            message: format!("cannot read the scenario file: {e}"),
        })?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        Self::parse(&name, Origin::File(path.to_path_buf()), &text)
    }

    /// Parses scenario text; `origin` resolves relative data paths and names the file in errors.
    pub fn parse(name: &str, origin: Origin, text: &str) -> Result<Self, SpecError> {
        let file = match &origin {
            Origin::Catalog => format!("catalog:{name}"),
            Origin::File(p) => p.display().to_string(),
        };
        let de = toml::Deserializer::parse(text).map_err(|e| SpecError {
            file: file.clone(),
            key: String::new(),
            line: e.span().map(|s| line_of_offset(text, s.start)),
            message: e.message().trim().to_string(),
        })?;
        let spec: ScenarioSpec = serde_path_to_error::deserialize(de).map_err(|e| {
            let key = path_string(e.path());
            let inner = e.into_inner();
            let line = inner
                .span()
                .map(|s| line_of_offset(text, s.start))
                .or_else(|| line_of_key(text, &key));
            SpecError {
                file: file.clone(),
                key,
                line,
                message: inner.message().trim().to_string(),
            }
        })?;
        let s = Self {
            name: name.into(),
            origin,
            spec,
            text: text.into(),
            models: Vec::new(),
        };
        s.validate()?;
        let models = (0..s.spec.rig.cameras.len())
            .map(|i| s.camera_model(i))
            .collect::<Result<_, _>>()?;
        Ok(Self { models, ..s })
    }

    /// The renderer configuration of a rendered scenario (`None` for feature-level ones).
    pub fn render_config(&self) -> Result<Option<RenderConfig>, SpecError> {
        let cfg = self.render_settings()?;
        Ok((self.spec.camera.mode == CameraMode::Rendered).then_some(cfg))
    }

    /// The scenario's rendering settings whatever its mode (`vio render` uses them for
    /// feature-level scenarios too); validated, errors name the key.
    pub fn render_settings(&self) -> Result<RenderConfig, SpecError> {
        let c = &self.spec.camera;
        let (r, p) = (&c.render, &c.photometric);
        let d = RenderConfig::default();
        let dp = d.photometric;
        let cfg = RenderConfig {
            backend: match r.backend {
                Some(BackendSpec::Vulkan) => RenderBackend::Vulkan,
                _ => RenderBackend::Gl,
            },
            adapter: r.adapter.clone(),
            msaa: r.msaa.unwrap_or(d.msaa),
            trilinear: r.trilinear.unwrap_or(d.trilinear),
            anisotropy: r.anisotropy.unwrap_or(d.anisotropy),
            pinhole_scale: r.pinhole_scale.unwrap_or(d.pinhole_scale),
            texture_size: r.texture_size.unwrap_or(d.texture_size),
            texel_m: r.texel_m.unwrap_or(d.texel_m),
            max_half_angle_deg: r.max_half_angle_deg.unwrap_or(d.max_half_angle_deg),
            max_pinhole_size: d.max_pinhole_size,
            depth: r.depth.unwrap_or(d.depth),
            motion_blur: r.motion_blur.map(|b| MotionBlur {
                exposure_s: b.exposure_s,
                samples: b.samples,
            }),
            photometric: Photometric {
                gain: p.gain.unwrap_or(dp.gain),
                gain_variation: p.gain_variation.unwrap_or(dp.gain_variation),
                gain_period_s: p.gain_period_s.unwrap_or(dp.gain_period_s),
                vignetting: p.vignetting.unwrap_or(dp.vignetting),
                read_noise: p.read_noise.unwrap_or(dp.read_noise),
                electrons_per_level: p.electrons_per_level.unwrap_or(dp.electrons_per_level),
                gain_step: p.gain_step.map(|g| GainStep {
                    at_s: g.at_s,
                    factor: g.factor,
                }),
            },
        };
        cfg.validate().map_err(|e| {
            let key = match &e {
                RenderError::Field { field, .. } if field.starts_with("photometric.") => {
                    format!("camera.{field}")
                }
                RenderError::Field { field, .. } => format!("camera.render.{field}"),
                _ => "camera".into(),
            };
            self.error(&key, e.to_string())
        })?;
        Ok(cfg)
    }

    /// The image front end's configuration when the estimator should track the rendered images
    /// (`mode = "rendered"` and `frontend = "klt"`); `None` otherwise.
    pub fn tracker_config(&self, seed: u64) -> Result<Option<TrackerConfig>, SpecError> {
        let c = &self.spec.camera;
        let cfg = c
            .tracker
            .config(seed)
            .map_err(|(field, why)| self.error(&format!("camera.tracker.{field}"), why))?;
        Ok((c.mode == CameraMode::Rendered && c.frontend == FrontendSpec::Klt).then_some(cfg))
    }

    /// The name errors use for the file.
    pub fn file_label(&self) -> String {
        match &self.origin {
            Origin::Catalog => format!("catalog:{}", self.name),
            Origin::File(p) => p.display().to_string(),
        }
    }

    /// An error at `key`, with the key's line.
    pub fn error(&self, key: &str, message: impl Into<String>) -> SpecError {
        SpecError {
            file: self.file_label(),
            key: key.into(),
            line: line_of_key(&self.text, key),
            message: message.into(),
        }
    }

    /// Checks everything the world and estimator configurations need, so that
    /// [`Scenario::world_config`] and [`Scenario::estimator_config`] only fail on data files.
    fn validate(&self) -> Result<(), SpecError> {
        self.render_config()?;
        self.tracker_config(0)?;
        let s = &self.spec;
        let pos = |key: &str, v: f64| -> Result<(), SpecError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(self.error(key, format!("expected a finite number > 0, got {v}")))
            }
        };
        let nonneg = |key: &str, v: f64| -> Result<(), SpecError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(self.error(key, format!("expected a finite number ≥ 0, got {v}")))
            }
        };
        if s.description.trim().is_empty() || s.description.contains('\n') {
            return Err(self.error("description", "expected one non-empty line"));
        }
        if let Some(d) = s.world.landmark_density {
            pos("world.landmark_density", d)?;
        }
        // Trajectory.
        let t = &s.trajectory;
        pos("trajectory.duration_s", t.duration_s)?;
        if let Some(ss) = t.static_start {
            nonneg("trajectory.static_start.hold_s", ss.hold_s)?;
            nonneg("trajectory.static_start.ramp_s", ss.ramp_s)?;
        }
        let given: Vec<&str> = [
            ("figure_eight", t.figure_eight.is_some()),
            ("circle", t.circle.is_some()),
            ("lissajous", t.lissajous.is_some()),
            ("waypoints", t.waypoints.is_some()),
            ("replay", t.replay.is_some()),
        ]
        .into_iter()
        .filter_map(|(n, g)| g.then_some(n))
        .collect();
        if given.len() != 1 {
            return Err(self.error(
                "trajectory",
                format!(
                    "expected exactly one of figure_eight, circle, lissajous, waypoints, replay; got {}",
                    if given.is_empty() {
                        "none".to_string()
                    } else {
                        given.join(", ")
                    }
                ),
            ));
        }
        if let Some(f) = t.figure_eight {
            pos("trajectory.figure_eight.period_s", f.period_s)?;
            nonneg("trajectory.figure_eight.half_width_m", f.half_width_m)?;
            nonneg("trajectory.figure_eight.half_height_m", f.half_height_m)?;
        }
        if let Some(c) = t.circle {
            pos("trajectory.circle.period_s", c.period_s)?;
            nonneg("trajectory.circle.radius_m", c.radius_m)?;
        }
        if let Some(w) = t.waypoints {
            pos("trajectory.waypoints.spacing_s", w.spacing_s)?;
            if (0..3).any(|i| w.max[i] <= w.min[i]) {
                return Err(self.error("trajectory.waypoints.max", "expected max > min per axis"));
            }
        }
        if let Some(r) = &t.replay
            && let Some(k) = r.knot_spacing_s
        {
            pos("trajectory.replay.knot_spacing_s", k)?;
        }
        // Rig.
        let rig = &s.rig;
        pos("rig.rate_hz", rig.rate_hz)?;
        if (1e9 / rig.rate_hz - (1e9 / rig.rate_hz).round()).abs() > 1e-6 {
            return Err(self.error(
                "rig.rate_hz",
                "expected a rate whose period is a whole number of nanoseconds",
            ));
        }
        if !rig.time_offset_s.is_finite() {
            return Err(self.error("rig.time_offset_s", "expected a finite number"));
        }
        let allowed = match s.suite {
            SuiteSpec::MonoImu => 1..=2,
            SuiteSpec::StereoImu | SuiteSpec::Stereo => 2..=2,
        };
        if !allowed.contains(&rig.cameras.len()) {
            let want = if allowed.start() == allowed.end() {
                allowed.start().to_string()
            } else {
                format!("{} or {}", allowed.start(), allowed.end())
            };
            return Err(self.error(
                "rig.cameras",
                format!(
                    "expected {want} cameras for the {} suite, got {}",
                    s.suite.as_str(),
                    rig.cameras.len()
                ),
            ));
        }
        for i in 0..rig.cameras.len() {
            self.camera_model(i)?;
            self.extrinsic(i)?;
            let c = &rig.cameras[i];
            nonneg(
                &format!("rig.cameras[{i}].pixel_sigma_px"),
                c.pixel_sigma_px,
            )?;
            if let Some(d) = c.min_depth_m {
                pos(&format!("rig.cameras[{i}].min_depth_m"), d)?;
            }
            if let Some(d) = c.max_depth_m {
                pos(&format!("rig.cameras[{i}].max_depth_m"), d)?;
            }
        }
        let imu = &rig.imu;
        pos("rig.imu.rate_hz", imu.rate_hz)?;
        if (1e9 / imu.rate_hz - (1e9 / imu.rate_hz).round()).abs() > 1e-6 {
            return Err(self.error(
                "rig.imu.rate_hz",
                "expected a rate whose period is a whole number of nanoseconds",
            ));
        }
        pos(
            "rig.imu.gyroscope_noise_density",
            imu.gyroscope_noise_density,
        )?;
        pos(
            "rig.imu.accelerometer_noise_density",
            imu.accelerometer_noise_density,
        )?;
        pos("rig.imu.gyroscope_random_walk", imu.gyroscope_random_walk)?;
        pos(
            "rig.imu.accelerometer_random_walk",
            imu.accelerometer_random_walk,
        )?;
        if let Some(r) = imu.gyro_range_rad_s {
            pos("rig.imu.gyro_range_rad_s", r)?;
        }
        if let Some(r) = imu.accel_range_m_s2 {
            pos("rig.imu.accel_range_m_s2", r)?;
        }
        // Estimator.
        let e = &s.estimator;
        if let Some(w) = e.window_size
            && w < 3
        {
            return Err(self.error("estimator.window_size", "expected ≥ 3"));
        }
        if let Some(n) = e.init_frames
            && n < 4
        {
            return Err(self.error("estimator.init_frames", "expected ≥ 4"));
        }
        if let Some(n) = e.solver_iterations
            && n < 1
        {
            return Err(self.error("estimator.solver_iterations", "expected ≥ 1"));
        }
        if let Some(p) = e.pixel_sigma_px {
            pos("estimator.pixel_sigma_px", p)?;
        }
        for (key, v) in [
            ("estimator.keyframe_parallax_px", e.keyframe_parallax_px),
            ("estimator.huber_sigma", e.huber_sigma),
            (
                "estimator.outlier_reprojection_px",
                e.outlier_reprojection_px,
            ),
        ] {
            if let Some(v) = v {
                pos(key, v)?;
            }
        }
        // Faults.
        for i in 0..s.faults.len() {
            self.fault(i)?;
        }
        // Expectations.
        for (name, b) in s.expectations.bounds() {
            if b.min.is_none() && b.max.is_none() {
                return Err(self.error(
                    &format!("expectations.{name}"),
                    "expected `min` and/or `max`",
                ));
            }
        }
        Ok(())
    }

    /// The projection model of camera `i`.
    fn camera_model(&self, i: usize) -> Result<Arc<dyn CameraModel>, SpecError> {
        let c = &self.spec.rig.cameras[i];
        let key = |k: &str| format!("rig.cameras[{i}].{k}");
        let [w, h] = c.resolution;
        let [fx, fy, cx, cy] = c.intrinsics;
        let d = &c.distortion;
        let need_d = |n: usize, what: &str| -> Result<(), SpecError> {
            if d.len() == n {
                Ok(())
            } else {
                Err(self.error(
                    &key("distortion"),
                    format!("expected {n} coefficients {what}, got {}", d.len()),
                ))
            }
        };
        let need = |v: Option<f64>, k: &str| {
            v.ok_or_else(|| {
                self.error(
                    &key(k),
                    format!("missing: the {} model needs `{k}`", serde_name(c.model)),
                )
            })
        };
        let forbid = |v: Option<f64>, k: &str| -> Result<(), SpecError> {
            match v {
                Some(_) => Err(self.error(
                    &key(k),
                    format!("not used by the {} model: remove it", serde_name(c.model)),
                )),
                None => Ok(()),
            }
        };
        let cam_err = |e: CameraError| self.error(&key("intrinsics"), e.to_string());
        let cam = match c.model {
            ModelSpec::PinholeRadtan => {
                need_d(4, "[k1, k2, p1, p2]")?;
                forbid(c.xi, "xi")?;
                forbid(c.alpha, "alpha")?;
                Camera::PinholeRadtan(
                    PinholeRadtan::new(w, h, fx, fy, cx, cy, d[0], d[1], d[2], d[3])
                        .map_err(cam_err)?,
                )
            }
            ModelSpec::KannalaBrandt => {
                need_d(4, "[k1, k2, k3, k4]")?;
                forbid(c.xi, "xi")?;
                forbid(c.alpha, "alpha")?;
                Camera::KannalaBrandt(
                    KannalaBrandt::new(w, h, fx, fy, cx, cy, d[0], d[1], d[2], d[3])
                        .map_err(cam_err)?,
                )
            }
            ModelSpec::Mei => {
                need_d(4, "[k1, k2, p1, p2]")?;
                forbid(c.alpha, "alpha")?;
                let xi = need(c.xi, "xi")?;
                Camera::Mei(
                    Mei::new(w, h, xi, fx, fy, cx, cy, d[0], d[1], d[2], d[3]).map_err(cam_err)?,
                )
            }
            ModelSpec::DoubleSphere => {
                need_d(0, "(none)")?;
                let xi = need(c.xi, "xi")?;
                let alpha = need(c.alpha, "alpha")?;
                Camera::DoubleSphere(
                    DoubleSphere::new(w, h, fx, fy, cx, cy, xi, alpha).map_err(cam_err)?,
                )
            }
        };
        Ok(Arc::new(cam))
    }

    /// `T_b_c` of camera `i`.
    fn extrinsic(&self, i: usize) -> Result<Pose, SpecError> {
        let e = &self.spec.rig.cameras[i].T_b_c;
        let key = format!("rig.cameras[{i}].T_b_c");
        let t = Vector3::from(e.translation_m);
        if !t.iter().all(|v| v.is_finite()) {
            return Err(self.error(&format!("{key}.translation_m"), "expected finite values"));
        }
        let q = match (e.rotation, e.quaternion_xyzw) {
            (Some(r), None) => {
                let m = Matrix3::from_fn(|a, b| r[a][b]);
                let ortho = (m.transpose() * m - Matrix3::identity()).amax();
                if !(ortho < 1e-3 && (m.determinant() - 1.0).abs() < 1e-3) {
                    return Err(self.error(
                        &format!("{key}.rotation"),
                        "expected a rotation matrix (orthonormal rows, determinant +1, to 1e-3)",
                    ));
                }
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&m))
            }
            (None, Some(q)) => {
                let quat = Quaternion::new(q[3], q[0], q[1], q[2]);
                let unit = (quat.norm() - 1.0).abs() < 1e-3; // false for NaN
                if !unit {
                    return Err(self.error(
                        &format!("{key}.quaternion_xyzw"),
                        "expected a unit quaternion [qx, qy, qz, qw] (norm 1 to 1e-3)",
                    ));
                }
                UnitQuaternion::new_normalize(quat)
            }
            _ => {
                return Err(self.error(
                    &key,
                    "expected exactly one of `rotation` (3×3 rows) or `quaternion_xyzw`",
                ));
            }
        };
        Ok(Pose::new(q, t))
    }

    /// Fault `i` in sim form.
    fn fault(&self, i: usize) -> Result<Fault, SpecError> {
        let f = &self.spec.faults[i];
        let key = |k: &str| format!("faults[{i}].{k}");
        let ns = |s: f64| (s * 1e9).round() as i64;
        // (present, name) of every optional key, to reject keys the kind does not take.
        let present: [(&str, bool); 13] = [
            ("start_s", f.start_s.is_some()),
            ("end_s", f.end_s.is_some()),
            ("at_s", f.at_s.is_some()),
            ("cam_id", f.cam_id.is_some()),
            ("black_frames", f.black_frames.is_some()),
            ("probability", f.probability.is_some()),
            ("gyro_rad_s", f.gyro_rad_s.is_some()),
            ("accel_m_s2", f.accel_m_s2.is_some()),
            ("gyro_range_rad_s", f.gyro_range_rad_s.is_some()),
            ("accel_range_m_s2", f.accel_range_m_s2.is_some()),
            ("imu_sigma_s", f.imu_sigma_s.is_some()),
            ("camera_sigma_s", f.camera_sigma_s.is_some()),
            ("td_s", f.td_s.is_some()),
        ];
        let (required, optional): (&[&str], &[&str]) = match f.kind {
            FaultKind::CameraBlackout => (&["start_s", "end_s"], &["black_frames"]),
            FaultKind::CameraDeath => (&["cam_id", "at_s"], &[]),
            FaultKind::FrameDrops => (&["start_s", "end_s", "probability"], &[]),
            FaultKind::ImuDropout => (&["start_s", "end_s"], &[]),
            FaultKind::ImuSpikes => (
                &[
                    "start_s",
                    "end_s",
                    "probability",
                    "gyro_rad_s",
                    "accel_m_s2",
                ],
                &[],
            ),
            FaultKind::ImuSaturation => (
                &["start_s", "end_s", "gyro_range_rad_s", "accel_range_m_s2"],
                &[],
            ),
            FaultKind::TimestampJitter => {
                (&["start_s", "end_s"], &["imu_sigma_s", "camera_sigma_s"])
            }
            FaultKind::CameraTimeOffset => (&["at_s", "td_s"], &[]),
        };
        for (name, p) in present {
            let req = required.contains(&name);
            if req && !p {
                return Err(self.error(
                    &key(name),
                    format!("missing: a {} fault needs `{name}`", serde_name(f.kind)),
                ));
            }
            if p && !req && !optional.contains(&name) {
                return Err(self.error(
                    &key(name),
                    format!(
                        "not used by a {} fault (it takes {})",
                        serde_name(f.kind),
                        required
                            .iter()
                            .chain(optional)
                            .copied()
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
        }
        let (start, end) = (f.start_s.unwrap_or(0.0), f.end_s.unwrap_or(0.0));
        if f.start_s.is_some() && !(start.is_finite() && end.is_finite() && end > start) {
            return Err(self.error(&key("end_s"), "expected finite start_s < end_s"));
        }
        if let Some(p) = f.probability
            && !(0.0..=1.0).contains(&p)
        {
            return Err(self.error(&key("probability"), "expected a probability in [0, 1]"));
        }
        if let Some(c) = f.cam_id
            && c >= self.spec.rig.cameras.len()
        {
            return Err(self.error(
                &key("cam_id"),
                format!("expected a camera index < {}", self.spec.rig.cameras.len()),
            ));
        }
        let (start_ns, end_ns) = (ns(start), ns(end));
        Ok(match f.kind {
            FaultKind::CameraBlackout => Fault::CameraBlackout {
                start_ns,
                end_ns,
                black_frames: f.black_frames.unwrap_or(false),
            },
            FaultKind::CameraDeath => Fault::CameraDeath {
                cam_id: f.cam_id.unwrap_or(0),
                at_ns: ns(f.at_s.unwrap_or(0.0)),
            },
            FaultKind::FrameDrops => Fault::FrameDrops {
                start_ns,
                end_ns,
                probability: f.probability.unwrap_or(0.0),
            },
            FaultKind::ImuDropout => Fault::ImuDropout { start_ns, end_ns },
            FaultKind::ImuSpikes => Fault::ImuSpikes {
                start_ns,
                end_ns,
                probability: f.probability.unwrap_or(0.0),
                gyro: f.gyro_rad_s.unwrap_or(0.0),
                accel: f.accel_m_s2.unwrap_or(0.0),
            },
            FaultKind::ImuSaturation => Fault::ImuSaturation {
                start_ns,
                end_ns,
                gyro_range: f.gyro_range_rad_s.unwrap_or(f64::INFINITY),
                accel_range: f.accel_range_m_s2.unwrap_or(f64::INFINITY),
            },
            FaultKind::TimestampJitter => Fault::TimestampJitter {
                start_ns,
                end_ns,
                imu_sigma_ns: f.imu_sigma_s.unwrap_or(0.0) * 1e9,
                camera_sigma_ns: f.camera_sigma_s.unwrap_or(0.0) * 1e9,
            },
            FaultKind::CameraTimeOffset => Fault::CameraTimeOffset {
                start_ns: ns(f.at_s.unwrap_or(0.0)),
                td_ns: ns(f.td_s.unwrap_or(0.0)),
            },
        })
    }

    /// Fault intervals `(kind, start s, end s)` for reports and plots (permanent faults end at
    /// infinity).
    pub fn fault_intervals(&self) -> Vec<(String, f64, f64)> {
        self.spec
            .faults
            .iter()
            .map(|f| {
                let name = serde_name(f.kind);
                match (f.start_s, f.end_s, f.at_s) {
                    (Some(a), Some(b), _) => (name, a, b),
                    (_, _, Some(a)) => (name, a, f64::INFINITY),
                    _ => (name, 0.0, 0.0),
                }
            })
            .collect()
    }

    /// The trajectory configuration (reads and fits a replayed file).
    fn trajectory(&self) -> Result<TrajectoryConfig, SpecError> {
        let t = &self.spec.trajectory;
        let v = Vector3::from;
        if let Some(f) = t.figure_eight {
            return Ok(TrajectoryConfig::Lissajous(Lissajous::figure_eight(
                v(f.center),
                f.half_width_m,
                f.half_height_m,
                f.period_s,
            )));
        }
        if let Some(c) = t.circle {
            return Ok(TrajectoryConfig::Lissajous(Lissajous::circle(
                v(c.center),
                c.radius_m,
                c.period_s,
            )));
        }
        if let Some(l) = t.lissajous {
            return Ok(TrajectoryConfig::Lissajous(Lissajous {
                center: v(l.center),
                amplitude: v(l.amplitude_m),
                freq_hz: v(l.freq_hz),
                phase: v(l.phase_rad),
                yaw0: l.yaw0_rad,
                yaw_rate: l.yaw_rate_rad_s,
                yaw_amplitude: l.yaw_amplitude_rad,
                yaw_freq_hz: l.yaw_freq_hz,
                tilt_amplitude: l.tilt_amplitude_rad,
                tilt_freq_hz: l.tilt_freq_hz,
                duration_s: None,
            }));
        }
        if let Some(w) = t.waypoints {
            return Ok(TrajectoryConfig::Waypoints(RandomWaypoints {
                min: v(w.min),
                max: v(w.max),
                spacing_s: w.spacing_s,
                max_yaw_step: w.max_yaw_step_rad,
                max_tilt: w.max_tilt_rad,
                duration_s: t.duration_s,
            }));
        }
        let r = t
            .replay
            .as_ref()
            .ok_or_else(|| self.error("trajectory", "no motion given"))?;
        let key = "trajectory.replay.file";
        let text = self.data_file(key, &r.file)?;
        let samples = sim::motion::spline::parse_trajectory(&text)
            .map_err(|e| self.error(key, format!("in {}: {e}", r.file)))?;
        let replay = Replay::from_samples(
            samples,
            r.knot_spacing_s.unwrap_or(Replay::DEFAULT_KNOT_SPACING_S),
        )
        .map_err(|e| self.error(key, format!("in {}: {e}", r.file)))?;
        Ok(TrajectoryConfig::Reference(Arc::new(replay)))
    }

    /// Reads a data file named in the scenario: relative to the scenario file, or embedded for
    /// catalog scenarios.
    fn data_file(&self, key: &str, rel: &str) -> Result<String, SpecError> {
        match &self.origin {
            Origin::Catalog => catalog::data(rel)
                .map(str::to_string)
                .ok_or_else(|| self.error(key, format!("no embedded catalog data file `{rel}`"))),
            Origin::File(p) => {
                let base = p.parent().unwrap_or(Path::new("."));
                let path = base.join(rel);
                std::fs::read_to_string(&path).map_err(|e| {
                    self.error(
                        key,
                        format!(
                            "cannot read {} (relative to the scenario file): {e}",
                            path.display()
                        ),
                    )
                })
            }
        }
    }

    /// The simulator configuration; `seed` overrides `world.seed`, `duration_s` the
    /// trajectory's duration.
    pub fn world_config(
        &self,
        seed: Option<u64>,
        duration_s: Option<f64>,
    ) -> Result<WorldConfig, SpecError> {
        let s = &self.spec;
        let imu = &s.rig.imu;
        let scene = SceneConfig {
            preset: match s.world.scene {
                SceneSpec::Room => ScenePreset::Room,
                SceneSpec::MachineHall => ScenePreset::MachineHall,
                SceneSpec::Outdoor => ScenePreset::Outdoor,
            },
            landmark_density: s
                .world
                .landmark_density
                .unwrap_or(SceneConfig::default().landmark_density),
        };
        let mut cameras = Vec::new();
        for (i, c) in s.rig.cameras.iter().enumerate() {
            let mut sc = SimCamera::new(
                c.name.as_deref().unwrap_or(&format!("cam{i}")),
                self.models[i].clone(),
                self.extrinsic(i)?,
            );
            sc.pixel_sigma = c.pixel_sigma_px;
            if let Some(v) = c.max_features {
                sc.max_features = v;
            }
            if let Some(v) = c.min_depth_m {
                sc.min_depth = v;
            }
            if let Some(v) = c.max_depth_m {
                sc.max_depth = v;
            }
            sc.max_track_length = c.max_track_length;
            cameras.push(sc);
        }
        let rig = RigConfig {
            cameras,
            rate_hz: s.rig.rate_hz,
            td_ns: (s.rig.time_offset_s * 1e9).round() as i64,
            reseed: s.rig.reseed,
            track_ids: match s.rig.track_ids {
                TrackIdsSpec::Realistic => TrackIds::Realistic,
                TrackIdsSpec::Landmark => TrackIds::Landmark,
            },
        };
        let imu_cfg = ImuConfig {
            name: "imu".into(),
            rate_hz: imu.rate_hz,
            window: ImuWindow::Centered,
            noise: (!imu.noise_free).then(|| self.imu_noise()),
            initial_gyro_bias: Vector3::from(imu.initial_gyro_bias_rad_s),
            initial_accel_bias: Vector3::from(imu.initial_accel_bias_m_s2),
            gyro_matrix: Matrix3::identity(),
            accel_matrix: Matrix3::identity(),
            gyro_range: imu.gyro_range_rad_s,
            accel_range: imu.accel_range_m_s2,
        };
        let faults = (0..s.faults.len())
            .map(|i| self.fault(i))
            .collect::<Result<Vec<_>, _>>()?;
        let duration = duration_s.unwrap_or(s.trajectory.duration_s);
        // Physics at ≥ 1 kHz with a step that divides the IMU period.
        let period = imu_cfg.period_ns();
        let steps = (1..=20u32)
            .find(|n| period % i64::from(*n) == 0 && period / i64::from(*n) <= 1_000_000)
            .unwrap_or(1);
        Ok(WorldConfig {
            seed: seed.unwrap_or(s.world.seed),
            duration_s: duration,
            trajectory: self.trajectory()?,
            static_start: s.trajectory.static_start.map(|ss| StaticStartConfig {
                hold_s: ss.hold_s,
                ramp_s: ss.ramp_s,
            }),
            physics_steps_per_imu: steps,
            imu: imu_cfg,
            scene,
            rig: Some(rig),
            faults,
            ..WorldConfig::default()
        })
    }

    /// The IMU noise densities of the file.
    fn imu_noise(&self) -> ImuNoise {
        let imu = &self.spec.rig.imu;
        ImuNoise {
            gyroscope_noise_density: imu.gyroscope_noise_density,
            accelerometer_noise_density: imu.accelerometer_noise_density,
            gyroscope_random_walk: imu.gyroscope_random_walk,
            accelerometer_random_walk: imu.accelerometer_random_walk,
        }
    }

    /// The estimator configuration: the same camera models and extrinsics the simulator uses.
    pub fn estimator_config(&self) -> Result<EstimatorConfig, SpecError> {
        let s = &self.spec;
        let e = &s.estimator;
        let mut cameras = Vec::new();
        let used = s.suite.suite().cameras();
        for (i, c) in s.rig.cameras.iter().enumerate().take(used) {
            cameras.push(EstCamera {
                model: self.models[i].clone(),
                T_b_c: self.extrinsic(i)?,
                pixel_sigma: e.pixel_sigma_px.unwrap_or(c.pixel_sigma_px.max(0.5)),
            });
        }
        let mut cfg = EstimatorConfig::new(s.suite.suite(), cameras, self.imu_noise());
        if let Some(v) = e.window_size {
            cfg.window_size = v;
        }
        if let Some(v) = e.solver_iterations {
            cfg.solver.max_iterations = v;
        }
        if let Some(v) = e.solver_function_tolerance {
            cfg.solver.function_tolerance = v;
        }
        if let Some(m) = e.solver_method {
            cfg.solver.method = match m {
                MethodSpec::LevenbergMarquardt => Method::LevenbergMarquardt,
                MethodSpec::Dogleg => Method::Dogleg,
            };
        }
        if let Some(v) = e.keyframe_parallax_px {
            cfg.keyframe_parallax_px = v;
        }
        if let Some(v) = e.keyframe_min_tracked {
            cfg.keyframe_min_tracked = v;
        }
        if let Some(v) = e.huber_sigma {
            cfg.huber_sigma = v;
        }
        if let Some(v) = e.outlier_reprojection_px {
            cfg.outlier_reprojection_px = v;
        }
        if let Some(v) = e.init_frames {
            cfg.init_frames = v;
        }
        if let Some(v) = e.td_s {
            cfg.td_s = v;
        }
        if let Some(v) = e.estimate_td {
            cfg.estimate_td = v;
        }
        if let Some(v) = e.estimate_extrinsics {
            cfg.estimate_extrinsics = v;
        }
        if let Some(v) = e.reuse_marginalized_tracks {
            cfg.reuse_marginalized_tracks = v;
        }
        if let Some(v) = e.min_track_frames {
            cfg.min_track_frames = v;
        }
        if let Some(v) = e.max_persistent_points {
            cfg.max_persistent_points = v;
        }
        if let Some(v) = e.first_estimate_jacobians {
            cfg.first_estimate_jacobians = v;
        }
        if let Some(v) = e.first_estimate_points {
            cfg.first_estimate_points = v;
        }
        // The IMU's datasheet ranges: the estimator treats readings on them as clipped.
        let imu = &s.rig.imu;
        if imu.gyro_range_rad_s.is_some() || imu.accel_range_m_s2.is_some() {
            cfg.imu_range = Some((
                imu.gyro_range_rad_s.unwrap_or(f64::INFINITY),
                imu.accel_range_m_s2.unwrap_or(f64::INFINITY),
            ));
        }
        Ok(cfg)
    }
}

/// The serde (snake_case) name of a fault kind.
fn serde_name(k: impl fmt::Debug) -> String {
    let dbg = format!("{k:?}");
    let mut out = String::new();
    for (i, ch) in dbg.chars().enumerate() {
        if ch.is_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.extend(ch.to_lowercase());
        } else {
            out.push(ch);
        }
    }
    out
}

/// 1-based line of a byte offset.
fn line_of_offset(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// A serde path as `a.b[2].c`.
fn path_string(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut s = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => s.push_str(&format!("[{index}]")),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(key);
            }
            Segment::Unknown => {}
        }
    }
    s
}

/// Line of the deepest part of `key` (`a.b[2].c`) present in the document.
fn line_of_key(text: &str, key: &str) -> Option<usize> {
    let root = toml::de::DeTable::parse(text).ok()?;
    let mut span: Option<std::ops::Range<usize>> = None;
    let mut cur = toml::de::DeValue::Table(root.into_inner());
    'outer: for part in key.split('.').filter(|p| !p.is_empty()) {
        let (name, indices) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        let Some(next) = cur.get(name).cloned() else {
            break;
        };
        span = Some(next.span());
        cur = next.into_inner();
        for idx in indices
            .split(['[', ']'])
            .filter_map(|s| s.parse::<usize>().ok())
        {
            let Some(n) = cur.get(idx).cloned() else {
                break 'outer;
            };
            span = Some(n.span());
            cur = n.into_inner();
        }
    }
    span.map(|s| line_of_offset(text, s.start))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn default_text() -> &'static str {
        catalog::get(catalog::DEFAULT).unwrap().text
    }

    #[test]
    fn key_lines_are_found_down_to_array_elements() {
        let text = default_text();
        let line = |needle: &str| text.lines().position(|l| l.contains(needle)).unwrap() + 1;
        assert_eq!(line_of_key(text, "world.seed"), Some(line("seed = 1")));
        assert_eq!(
            line_of_key(text, "rig.cameras[1].pixel_sigma_px"),
            Some(
                text.lines()
                    .collect::<Vec<_>>()
                    .iter()
                    .rposition(|l| l.contains("pixel_sigma_px"))
                    .unwrap()
                    + 1
            )
        );
        // A missing key gives the line of its deepest present parent.
        assert_eq!(
            line_of_key(text, "trajectory.nope.deeper"),
            line_of_key(text, "trajectory")
        );
        assert_eq!(line_of_key(text, "nope"), None);
    }

    #[test]
    fn bounds_check_both_sides_and_reject_missing_values() {
        let b = Bound {
            min: Some(1.0),
            max: Some(2.0),
        };
        assert!(b.check(Some(1.5)));
        assert!(!b.check(Some(0.5)) && !b.check(Some(2.5)));
        assert!(!b.check(None) && !b.check(Some(f64::NAN)));
    }

    #[test]
    fn other_camera_models_and_quaternion_extrinsics_map_onto_the_configs() {
        let text = default_text()
            .replacen(
                "model = \"pinhole_radtan\"",
                "model = \"double_sphere\"\nxi = -0.2\nalpha = 0.6",
                1,
            )
            .replacen(
                "distortion = [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n",
                "",
                1,
            )
            .replacen(
                "rotation = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]",
                "quaternion_xyzw = [0.5, -0.5, 0.5, -0.5]",
                1,
            );
        let s = Scenario::parse("t", Origin::Catalog, &text).unwrap_or_else(|e| panic!("{e}"));
        let w = s.world_config(Some(9), Some(1.0)).unwrap();
        let e = s.estimator_config().unwrap();
        let rig = w.rig.unwrap();
        assert_eq!(w.seed, 9);
        // The estimator gets the very models the simulator projects with.
        for i in 0..2 {
            assert!(Arc::ptr_eq(&rig.cameras[i].model, &e.cameras[i].model));
        }
        // Both quaternion and matrix extrinsics give the same forward-looking rotation.
        let d = rig.cameras[0].t_b_c.q.angle_to(&rig.cameras[1].t_b_c.q);
        assert!(d < 1e-9, "{d}");
        assert_eq!(e.cameras[0].T_b_c, rig.cameras[0].t_b_c);
        let p = nalgebra::Vector3::new(0.1, -0.2, 1.0);
        assert_eq!(
            e.cameras[0].model.project(&p),
            rig.cameras[0].model.project(&p)
        );
    }

    #[test]
    fn replay_paths_resolve_relative_to_the_scenario_file() {
        let dir = std::env::temp_dir().join(format!("vio-spec-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("data")).unwrap();
        std::fs::write(
            dir.join("data/traj.txt"),
            catalog::data("data/euroc_V2_02_medium_20s.txt").unwrap(),
        )
        .unwrap();
        let text = catalog::get("room_replay_v2_02_stereo_imu")
            .unwrap()
            .text
            .replace("data/euroc_V2_02_medium_20s.txt", "data/traj.txt");
        let file = dir.join("replay.toml");
        std::fs::write(&file, text).unwrap();
        let s = Scenario::load(file.to_str().unwrap()).unwrap();
        assert_eq!(s.name, "replay");
        assert!(s.world_config(None, None).is_ok());
        let _ = std::fs::remove_dir_all(dir);
    }
}
