//! The world: scene, trajectory, IMU, camera rig, aiding sensors and faults under one seed, and
//! the measurement stream and ground truth it answers with.

use crate::aiding_sensors::{GnssSim, WheelSim};
use crate::camera::RigSim;
use crate::faults::{Fault, FaultTimeline};
use crate::imu::ImuSim;
use crate::imu_source::ImuSource;
use crate::motion::{MotionSim, Reference, Replay, StaticStart, Stops, TruthBuffer};
use crate::render::{RenderConfig, Renderer};
use crate::scene::Scene;
use crate::stream::Stream;
use crate::world_config::{SimError, TrajectoryConfig, WorldConfig};
use std::sync::Arc;

/// The reference motion `config` flies: its trajectory (a replayed file read and fitted) under
/// its static start and stops. Its [`Reference::duration`] is the longest run the world
/// simulates; a longer `duration_s` is cut to it.
pub fn reference_motion(config: &WorldConfig) -> Result<Arc<dyn Reference>, SimError> {
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
    Ok(reference)
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
        let reference = reference_motion(&config)?;
        let mut duration = config.duration_s;
        if let Some(d) = reference.duration() {
            duration = duration.min(d);
        }
        let end_ns = (duration * 1e9).round() as i64;
        if let Some(log) = &config.recorded_imu {
            log.covers(end_ns).map_err(SimError::Config)?;
        }
        let scene = Arc::new(Scene::build(&config.scene, config.seed));
        crate::validate::check_free_space(
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
        let aiding = crate::stream::AidingSims {
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
    /// ([`stream::Measurement::Images`](crate::stream::Measurement::Images)); otherwise identical to [`World::stream`].
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
    fn state(&self, t: f64) -> crate::motion::RefState {
        self.0.state(t)
    }
    fn duration(&self) -> Option<f64> {
        self.0.duration()
    }
}
