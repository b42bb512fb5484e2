//! `sim`: the deterministic sensor-level simulator.
//!
//! A [`World`] (scene + trajectory + IMU + camera rig + faults, one seed) produces a lazily
//! generated, time-ordered [`stream::Stream`] of [`stream::Measurement`] events, with ground truth
//! queryable at any timestamp.
//!
//! ```
//! use sim::{World, WorldConfig};
//! let world = World::new(WorldConfig { duration_s: 1.0, ..WorldConfig::default() }).unwrap();
//! let mut stream = world.stream();
//! let n_imu = stream
//!     .by_ref()
//!     .filter(|m| matches!(m, sim::stream::Measurement::Imu(_)))
//!     .count();
//! assert_eq!(n_imu, 201); // 200 Hz over [0, 1] s, both ends included
//! ```
//!
//! Conventions: timestamps are `i64` nanoseconds from the start of the run; world frame z up,
//! `g = (0, 0, −9.81)`; body frame = IMU frame; poses `T_w_b`. Determinism: every random draw
//! comes from a ChaCha8 stream derived from (seed, sensor name) ([`rng::sensor_rng`]).

pub mod aiding;
pub mod bias_instability;
pub mod camera;
pub mod faults;
pub mod imu;
pub mod imu_source;
pub mod limits;
pub mod motion;
pub mod render;
mod render_worker;
pub mod rng;
pub mod scene;
pub mod shaped_noise;
pub mod stream;
pub mod validate;
pub mod vibration;

use crate::aiding::{GnssConfig, GnssSim, WheelConfig, WheelSim};
use crate::camera::{RigConfig, RigSim};
use crate::faults::{Fault, FaultTimeline};
use crate::imu::{ImuConfig, ImuSim};
use crate::imu_source::{ImuSource, RecordedImu};
use crate::motion::{
    BodyParams, ControllerGains, Lissajous, MotionSim, RandomWaypoints, Reference, Replay,
    StaticStart, Stop, Stops, TrajectoryError, TruthBuffer,
};
use crate::render::{RenderConfig, RenderError, Renderer};
use crate::scene::{Scene, SceneConfig};
use crate::stream::Stream;
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

/// Rest before the motion (see [`StaticStart`]).
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
    /// Stops inserted into the motion (run time, sorted, not overlapping; see [`Stops`]).
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

/// A built world: scene, reference motion and sensor configuration. Streams are generated from
/// it on demand; every stream of the same world is identical.
#[derive(Clone, Debug)]
pub struct World {
    config: WorldConfig,
    scene: Arc<Scene>,
    reference: Arc<dyn Reference>,
    end_ns: i64,
}

impl World {
    /// Builds the world (reads and fits a replayed trajectory, places landmarks).
    pub fn new(config: WorldConfig) -> Result<Self, SimError> {
        config.validate()?;
        let bad = |m: &str| Err(SimError::Config(m.to_string()));
        let imu_period = config.imu.period_ns();
        if !positive(config.imu.rate_hz)
            || (1e9 / config.imu.rate_hz - imu_period as f64).abs() > 1e-6
        {
            return bad("IMU period must be a whole number of nanoseconds");
        }
        let n = i64::from(config.physics_steps_per_imu);
        if n < 1 || imu_period % n != 0 {
            return bad("physics_steps_per_imu must divide the IMU period in ns");
        }
        if let Some(rig) = &config.rig {
            if !positive(rig.rate_hz) || rig.period_ns() < 1 {
                return bad("frame rate must be positive and at most 1 GHz");
            }
            if rig.cameras.is_empty() {
                return bad("a rig needs at least one camera");
            }
        }
        if !positive(config.duration_s) {
            return bad("duration must be positive");
        }
        let mut reference: Arc<dyn Reference> = match &config.trajectory {
            TrajectoryConfig::Lissajous(l) => Arc::new(l.clone()),
            TrajectoryConfig::Waypoints(w) => Arc::new(w.build(config.seed)),
            TrajectoryConfig::Replay {
                path,
                knot_spacing_s,
            } => Arc::new(Replay::from_file(path, *knot_spacing_s)?),
            TrajectoryConfig::Reference(r) => r.clone(),
        };
        if let Some(s) = config.static_start {
            reference = Arc::new(StaticStart {
                inner: Box::new(SharedReference(reference)),
                hold_s: s.hold_s,
                ramp_s: s.ramp_s.max(1e-3),
            });
        }
        if !config.stops.is_empty() {
            reference = Arc::new(Stops {
                inner: Box::new(SharedReference(reference)),
                stops: config.stops.clone(),
            });
        }
        let mut duration = config.duration_s;
        if let Some(d) = reference.duration() {
            duration = duration.min(d);
        }
        let end_ns = (duration * 1e9).round() as i64;
        if let Some(log) = &config.recorded_imu {
            log.covers(end_ns).map_err(SimError::Config)?;
        }
        let scene = Arc::new(Scene::build(&config.scene, config.seed));
        validate::check_free_space(
            reference.as_ref(),
            &config.scene.preset.free_space(),
            &scene.boxes,
            duration,
        )?;
        Ok(Self {
            end_ns,
            config,
            scene,
            reference,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &WorldConfig {
        &self.config
    }

    /// The scene.
    pub fn scene(&self) -> &Arc<Scene> {
        &self.scene
    }

    /// The reference motion (including the static start).
    pub fn reference(&self) -> &Arc<dyn Reference> {
        &self.reference
    }

    /// End of the run (ns).
    pub fn end_ns(&self) -> i64 {
        self.end_ns
    }

    /// Physics step (ns).
    pub fn physics_step_ns(&self) -> i64 {
        self.config.imu.period_ns() / i64::from(self.config.physics_steps_per_imu)
    }

    /// A fresh physics simulation, started one IMU period before `t = 0` so the first IMU
    /// sample's window is covered.
    pub fn motion(&self) -> MotionSim {
        MotionSim::new(
            self.reference.clone(),
            self.config.body,
            self.config.gains,
            self.physics_step_ns(),
            -self.config.imu.period_ns(),
        )
    }

    /// A fresh measurement stream from `t = 0` to [`World::end_ns`].
    pub fn stream(&self) -> Stream {
        let c = &self.config;
        let truth = TruthBuffer::new(self.motion());
        let imu = match &c.recorded_imu {
            Some(log) => ImuSource::recorded(log.clone(), c.imu.period_ns()),
            None => ImuSource::Simulated(Box::new(ImuSim::new(c.imu.clone(), c.seed))),
        };
        let rig = c
            .rig
            .as_ref()
            .map(|r| RigSim::new(r.clone(), self.scene.clone(), c.seed));
        let faults = FaultTimeline::new(c.faults.clone(), c.seed);
        // Ground truth must outlive the longest stretch a consumer may lag behind the stream:
        // a sensor outage delays the frames that wait for it.
        let longest_outage_ns = c
            .faults
            .iter()
            .map(|f| match *f {
                Fault::ImuDropout { start_ns, end_ns }
                | Fault::CameraBlackout {
                    start_ns, end_ns, ..
                } => end_ns - start_ns,
                _ => 0,
            })
            .max()
            .unwrap_or(0);
        let retention_ns =
            ((c.truth_retention_s * 1e9) as i64).max(longest_outage_ns + 1_000_000_000);
        let aiding = stream::AidingSims {
            gnss: c.gnss.clone().map(|g| GnssSim::new(g, c.seed)),
            wheel: c.wheel.clone().map(|w| WheelSim::new(w, c.seed)),
        };
        Stream::new(truth, imu, rig, faults, self.end_ns, retention_ns).with_aiding(aiding)
    }
}

impl World {
    /// A renderer for this world's scene and rig (textures drawn from the seed).
    pub fn renderer(&self, config: &RenderConfig) -> Result<Renderer, SimError> {
        let rig = self
            .config
            .rig
            .as_ref()
            .ok_or_else(|| SimError::Config("rendering needs a camera rig".into()))?;
        Ok(Renderer::new(&self.scene, rig, config, self.config.seed)?)
    }

    /// A fresh measurement stream whose frames are preceded by their rendered images
    /// ([`stream::Measurement::Images`]); otherwise identical to [`World::stream`].
    pub fn rendered_stream(&self, renderer: Renderer) -> Stream {
        self.stream().with_renderer(renderer)
    }
}

/// True for finite values > 0.
fn positive(x: f64) -> bool {
    x.is_finite() && x > 0.0
}

/// Adapter: a shared reference as a boxed one.
#[derive(Debug)]
struct SharedReference(Arc<dyn Reference>);

impl Reference for SharedReference {
    fn state(&self, t: f64) -> motion::RefState {
        self.0.state(t)
    }
    fn duration(&self) -> Option<f64> {
        self.0.duration()
    }
}
