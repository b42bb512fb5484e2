//! What a world is built from ([`WorldConfig`], plain data with defaults) and the error of
//! building one.

use crate::aiding_sensors::{GnssConfig, WheelConfig};
use crate::camera::RigConfig;
use crate::faults::Fault;
use crate::imu::ImuConfig;
use crate::imu_source::RecordedImu;
use crate::motion::{
    BodyParams, ControllerGains, Lissajous, RandomWaypoints, Reference, Stop, TrajectoryError,
};
use crate::render::RenderError;
use crate::scene::SceneConfig;
use nalgebra::Vector3;
use std::path::PathBuf;
use std::sync::Arc;

/// Which reference motion drives the body.
#[derive(Clone, Debug)]
pub enum TrajectoryConfig {
    /// A Lissajous / figure-eight / circle generator.
    Lissajous(Lissajous),
    /// Random smooth waypoints (drawn from the seed).
    Waypoints(RandomWaypoints),
    /// Replay of a TUM or EuRoC ASL ground-truth file through a least-squares spline.
    Replay {
        /// The file.
        path: PathBuf,
        /// Knot spacing of the fitted spline (s).
        knot_spacing_s: f64,
    },
    /// Any prebuilt reference.
    Reference(Arc<dyn Reference>),
}

/// Rest before the motion (see [`StaticStart`](crate::motion::StaticStart)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StaticStartConfig {
    /// Rest duration (s).
    pub hold_s: f64,
    /// Ramp into the motion (s).
    pub ramp_s: f64,
}

/// Everything a world is built from. Plain data with defaults: a 60 s figure-eight in the room,
/// EuRoC-like IMU and stereo rig ([`RigConfig::euroc_like`]), no faults.
#[derive(Clone, Debug)]
pub struct WorldConfig {
    /// Scenario seed.
    pub seed: u64,
    /// Duration (s); clipped to the trajectory's length when it has one.
    pub duration_s: f64,
    /// The reference motion.
    pub trajectory: TrajectoryConfig,
    /// Optional rest before the motion.
    pub static_start: Option<StaticStartConfig>,
    /// Stops inserted into the motion (run time, sorted, not overlapping; see [`Stops`](crate::motion::Stops)).
    pub stops: Vec<Stop>,
    /// Body mass properties.
    pub body: BodyParams,
    /// Controller gains.
    pub gains: ControllerGains,
    /// Physics steps per IMU period (physics rate = IMU rate × this; ≥ 1 kHz recommended).
    pub physics_steps_per_imu: u32,
    /// The IMU.
    pub imu: ImuConfig,
    /// The scene.
    pub scene: SceneConfig,
    /// The camera rig, if any.
    pub rig: Option<RigConfig>,
    /// A GNSS-like position receiver, if any.
    pub gnss: Option<GnssConfig>,
    /// Wheel odometry, if any.
    pub wheel: Option<WheelConfig>,
    /// Faults applied to the stream.
    pub faults: Vec<Fault>,
    /// How long ground truth stays queryable behind the last emitted event (s).
    pub truth_retention_s: f64,
    /// A recorded IMU log (run clock) the stream emits instead of the simulated IMU's samples;
    /// the physics still moves the cameras and gives the ground truth, and the faults apply
    /// to the log's samples. `imu.rate_hz` still sets the physics rate.
    pub recorded_imu: Option<Arc<RecordedImu>>,
}

impl Default for WorldConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            duration_s: 60.0,
            trajectory: TrajectoryConfig::Lissajous(Lissajous::figure_eight(
                Vector3::new(-0.5, 0.5, 1.5),
                2.0,
                1.0,
                20.0,
            )),
            static_start: None,
            stops: Vec::new(),
            body: BodyParams::default(),
            gains: ControllerGains::default(),
            physics_steps_per_imu: 5,
            imu: ImuConfig::default(),
            scene: SceneConfig::default(),
            rig: Some(RigConfig::euroc_like()),
            gnss: None,
            wheel: None,
            faults: Vec::new(),
            truth_retention_s: 5.0,
            recorded_imu: None,
        }
    }
}

/// Errors building a world.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The trajectory file could not be used.
    #[error(transparent)]
    Trajectory(#[from] TrajectoryError),
    /// A configuration value is out of range.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// The renderer could not be set up.
    #[error(transparent)]
    Render(#[from] RenderError),
}
