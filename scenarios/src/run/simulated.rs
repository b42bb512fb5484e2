//! A scenario's simulated measurement stream as a run's source: the world's IMU, GNSS and
//! wheel measurements, and its frames (feature-level, or rendered images through the image
//! front end), with ground truth from the simulator.
//!
//! The image front end runs as a pipeline stage on its own thread (`vio-track`), one capture
//! ahead of the estimator: while the estimator takes frame k, the front end tracks frame k + 1
//! (VINS-Fusion's split of the feature tracker from the estimator). It needs nothing from the
//! estimator (its rotation prediction is the raw gyroscope's), so it sees the same calls in the
//! same order either way.
//!
//! Determinism: everything but the timing fields is a function of the scenario and the seed; the
//! wall clock is read only to fill [`FrameTiming`](super::FrameTiming).

use estimator::frontend::{FeatureFrame, ImageView, TrackerConfig, TrackerError};
use estimator::imu::ImuSample;
use estimator::{Estimate, Estimator, EstimatorConfig};
use sim::World;
use sim::render::ImageFrame;
use sim::stream::{GroundTruth, Measurement, Stream};

use super::driver::{Input, Source, drive};
use super::lookahead::{Lookahead, Slot};
use super::stage::Stage;
use super::{Recorder, RunControl, RunError, RunOptions, RunOutput};
use crate::frontend::{CapturePoses, ImageFrontend};
use crate::spec::Scenario;

/// The scenario's measurement stream: with rendered images when `camera.mode = "rendered"`
/// (then also the adapter's description), else feature-level.
pub fn measurement_stream(
    scenario: &Scenario,
    world: &World,
) -> Result<(Stream, Option<String>), RunError> {
    Ok(match scenario.render_config()? {
        None => (world.stream(), None),
        Some(cfg) => {
            let r = world
                .renderer(&cfg)
                .map_err(|e| RunError::sim(scenario, e))?;
            let adapter = r.adapter().to_string();
            (world.rendered_stream(r), Some(adapter))
        }
    })
}

/// The rendering error that ended `stream` early, if any, as a run error.
pub fn stream_result(scenario: &Scenario, stream: &Stream) -> Result<(), RunError> {
    match stream.error() {
        Some(e) => Err(RunError::sim(scenario, e)),
        None => Ok(()),
    }
}

/// Runs `scenario` to its output (the estimator's, without evaluation; see
/// [`run_to_report`](super::run_to_report)).
pub(crate) fn simulate(
    scenario: &Scenario,
    options: &RunOptions,
    control: &mut RunControl,
) -> Result<RunOutput, RunError> {
    let world_cfg = scenario.world_config(options.seed, options.duration_s)?;
    let mut est_cfg = scenario.estimator_config_at(world_cfg.seed)?;
    est_cfg.record_history |= options.batch_reference;
    est_cfg.compute_covariance |= options.covariance;
    let seed = world_cfg.seed;
    let tracker_cfg = scenario.tracker_config(seed)?;
    let uses_imu = est_cfg.suite.uses_imu();
    let world = World::new(world_cfg).map_err(|e| RunError::sim(scenario, e))?;
    let frontend = match tracker_cfg {
        None => None,
        Some(cfg) => Some(image_frontend(scenario, &world, &est_cfg, cfg)?),
    };
    let estimator = Estimator::new(est_cfg).map_err(|e| RunError::Estimator {
        file: scenario.file_label(),
        message: e.to_string(),
    })?;
    let end_ns = world.end_ns();
    let readout_s = world.config().rig.as_ref().map_or(0.0, |r| {
        r.cameras
            .iter()
            .map(|c| c.rolling_shutter.readout_s)
            .fold(0.0, f64::max)
    });
    let (stream, renderer) = measurement_stream(scenario, &world)?;
    let out = RunOutput::new(scenario.name.clone(), seed, end_ns as f64 * 1e-9, renderer);
    let recorder = Recorder::new(out, estimator.status());
    std::thread::scope(|scope| {
        let source = Simulated {
            scenario,
            stream,
            end_ns,
            tracking: frontend.map(|fe| Stage::spawn(scope, "vio-track", fe, track)),
            uses_imu,
            readout_s,
            ahead: Lookahead::default(),
            render_s: 0.0,
            latest: None,
        };
        drive(source, estimator, recorder, options, control).map(|(out, _)| out)
    })
}

/// A job of the front end's stage: a gyroscope sample for its rotation prediction, or a capture
/// to track with the true poses over its readout.
enum TrackJob {
    Imu(ImuSample),
    Images(ImageFrame, Option<CapturePoses>),
}

/// The stage's answer to a capture: the frame and the tracker's time (s), and the images back.
type Tracked = (Result<(FeatureFrame, f64), TrackerError>, ImageFrame);

/// The front end's stage: runs each job in order.
fn track(fe: &mut ImageFrontend, job: TrackJob) -> Option<Tracked> {
    match job {
        TrackJob::Imu(s) => {
            fe.push_imu(&s);
            None
        }
        TrackJob::Images(images, truth) => Some((fe.process(&images, truth.as_ref()), images)),
    }
}

/// The world's stream as a run's source.
struct Simulated<'a, 's> {
    scenario: &'a Scenario,
    stream: Stream,
    end_ns: i64,
    /// The image front end's stage (rendered scenarios): it tracks the images, and the ideal
    /// frames that follow them are skipped.
    tracking: Option<Stage<'s, ImageFrontend, TrackJob, Tracked>>,
    /// Whether the front end predicts rotations from the gyroscope.
    uses_imu: bool,
    /// The rig's longest rolling-shutter readout (s): the span of the true poses the front
    /// end's statistics need per capture.
    readout_s: f64,
    /// Inputs read from the stream and not yet given to the estimator; a capture with the
    /// front end keeps its render time (s).
    ahead: Lookahead<f64>,
    /// The latest images' render time (s).
    render_s: f64,
    /// The latest images tracked.
    latest: Option<ImageFrame>,
}

impl Simulated<'_, '_> {
    /// Reads the stream as far as [`Lookahead`] wants.
    fn read_ahead(&mut self) {
        while self.ahead.wants_more(self.tracking.is_some()) {
            match self.stream.next() {
                Some(m) => {
                    if let Some(slot) = self.take(m) {
                        self.ahead.push(slot);
                    }
                }
                None => self.ahead.end(),
            }
        }
    }

    /// One measurement of the stream as an input (images go to the front end); `None` for
    /// what the estimator does not take.
    fn take(&mut self, m: Measurement) -> Option<Slot<f64>> {
        let input = match m {
            Measurement::Images(images) => {
                let render_s = self.stream.last_render_s();
                let Some(stage) = &self.tracking else {
                    self.render_s = render_s;
                    return None;
                };
                let truth = capture_poses(&mut self.stream, images.t_capture_ns, self.readout_s);
                stage.submit(TrackJob::Images(images, truth));
                return Some(Slot::Tracking(render_s));
            }
            Measurement::Imu(s) => {
                if let Some(stage) = self.tracking.as_ref().filter(|_| self.uses_imu) {
                    stage.submit(TrackJob::Imu(s));
                }
                Input::Imu(s)
            }
            Measurement::Gnss(fix) => Input::Gnss(fix),
            Measurement::Wheel(reading) => Input::Wheel(reading),
            Measurement::Frame(_) if self.tracking.is_some() => return None,
            // Feature-level input: the frame is already the estimator's input.
            Measurement::Frame(frame) => Input::Frame {
                frame,
                frontend_s: 0.0,
            },
        };
        Some(Slot::Ready(input))
    }
}

impl Source for Simulated<'_, '_> {
    fn end_ns(&self) -> i64 {
        self.end_ns
    }

    fn next_input(&mut self) -> Result<Option<Input>, RunError> {
        self.read_ahead();
        Ok(Some(match self.ahead.pop() {
            None => return Ok(None),
            Some(Slot::Ready(input)) => input,
            Some(Slot::Tracking(render_s)) => {
                let stage = self
                    .tracking
                    .as_mut()
                    .expect("captures go to the front end");
                let (result, images) = stage.next_result();
                self.render_s = render_s;
                self.latest = Some(images);
                let (frame, frontend_s) = result.map_err(|e| RunError::Frontend {
                    file: self.scenario.file_label(),
                    message: e.to_string(),
                })?;
                Input::Frame { frame, frontend_s }
            }
        }))
    }

    fn render_s(&self) -> f64 {
        self.render_s
    }

    fn latest_image(&self) -> Option<ImageView<'_>> {
        let camera = self
            .latest
            .as_ref()?
            .cameras
            .iter()
            .find(|c| c.cam_id == 0)?;
        ImageView::packed(camera.image.width, camera.image.height, &camera.image.data).ok()
    }

    fn truth(&mut self, estimate: &Estimate) -> Option<GroundTruth> {
        self.stream.truth(estimate.t_ns)
    }

    fn finish(self, out: &mut RunOutput, interrupted: bool) -> Result<(), RunError> {
        // A stopped run's front end may have tracked the capture after the last one the
        // estimator took; its statistics then count that capture too.
        let frontend = self.tracking.map(Stage::finish);
        out.frontend_tracks = frontend.as_ref().map(|f| f.track_summary());
        out.frontend = frontend.map(|f| f.stats());
        if interrupted {
            return Ok(());
        }
        stream_result(self.scenario, &self.stream)
    }
}

/// The image front end for a rendered scenario: the estimator's cameras, the scene and the
/// simulator's true extrinsics for the ground-truth statistics.
pub fn image_frontend(
    scenario: &Scenario,
    world: &World,
    est_cfg: &EstimatorConfig,
    cfg: TrackerConfig,
) -> Result<ImageFrontend, RunError> {
    let cameras = crate::frontend::tracker_cameras(est_cfg);
    let true_cameras = world
        .config()
        .rig
        .as_ref()
        .map(|r| r.cameras.as_slice())
        .unwrap_or_default();
    ImageFrontend::new(cfg, cameras, world.scene().clone(), true_cameras).map_err(|e| {
        RunError::Frontend {
            file: scenario.file_label(),
            message: e.to_string(),
        }
    })
}

/// Poses the ground-truth track statistics sample over a rolling-shutter readout.
const READOUT_POSES: usize = 33;

/// The true body poses over the readout `readout_s` of the capture at `t_capture_ns` (one pose
/// for a global shutter); `None` outside the ground truth.
fn capture_poses(stream: &mut Stream, t_capture_ns: i64, readout_s: f64) -> Option<CapturePoses> {
    if readout_s <= 0.0 {
        return Some(CapturePoses::new(
            0.0,
            vec![stream.truth(t_capture_ns)?.pose],
        ));
    }
    let step_s = readout_s / (READOUT_POSES - 1) as f64;
    let poses = (0..READOUT_POSES)
        .map(|k| {
            let dt_ns = (k as f64 * step_s * 1e9).round() as i64;
            stream.truth(t_capture_ns + dt_ns).map(|g| g.pose)
        })
        .collect::<Option<Vec<_>>>()?;
    Some(CapturePoses::new(step_s, poses))
}
