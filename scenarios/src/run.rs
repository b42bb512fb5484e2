//! The runner: a scenario's simulated measurement stream → the estimator, collecting per-frame
//! estimates, ground truth at the estimate times, timings and events.
//!
//! Determinism: everything but the timing fields is a function of the scenario and the seed; the
//! wall clock is read only to fill [`FrameTiming`].

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use estimator::estimator::{
    Estimate, Estimator, EstimatorError, EventKind as EstimatorEventKind, Status,
};
use estimator::frontend::TrackSummary;
use estimator::geometry::Pose;
use estimator::problem::{SolverOptions, SolverSummary};
use sim::World;
use sim::stream::{GroundTruth, Measurement, Stream};

use crate::frontend::{FrontendStats, ImageFrontend};
use crate::spec::{Scenario, SpecError};

/// Overrides for one run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// Seed instead of the scenario's `world.seed`.
    pub seed: Option<u64>,
    /// Duration (s) instead of the scenario's `trajectory.duration_s`.
    pub duration_s: Option<f64>,
    /// Also solve the full batch over the window's keyframes at the end
    /// ([`RunOutput::batch_reference`]).
    pub batch_reference: bool,
    /// Compute the newest state's covariance with every estimate (`vio nees`).
    pub covariance: bool,
}

/// The window against the full batch on the same measurements
/// ([`RunOptions::batch_reference`]).
#[derive(Clone, Debug)]
pub struct BatchReference {
    /// Every frame's pose as it left the window, `(t_ns, T_w_b)`, in order.
    pub finalized: Vec<(i64, Pose)>,
    /// The batch solution over the keyframes (marginalized ones, then the final window),
    /// `(t_ns, T_w_b)` (`Estimator::batch_solve_keyframes`).
    pub batch: Vec<(i64, Pose)>,
    /// The batch solve's statistics.
    pub summary: Option<SolverSummary>,
}

/// Wall time spent on one frame (s). Measured for reports only.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameTiming {
    /// Front end: turning the sensor input into the estimator's feature frame: the image
    /// tracker's time in rendered scenarios, ~0 for feature-level input (handed over as is).
    pub frontend_s: f64,
    /// Back end: the estimator's own measurement (`Estimate::backend_s`).
    pub backend_s: f64,
    /// Front end plus the whole estimator call that produced the estimate.
    pub total_s: f64,
    /// Rendering the capture's images (rendered scenarios; 0 otherwise). Not part of `total`.
    pub render_s: f64,
}

/// One processed frame.
#[derive(Clone, Debug)]
pub struct FrameRecord {
    /// The estimate (its `t_ns` is in the IMU clock = true time).
    pub estimate: Estimate,
    /// Ground truth at the estimate's time.
    pub truth: GroundTruth,
    /// Timing.
    pub timing: FrameTiming,
}

/// What happened during a run.
#[derive(Clone, Debug, PartialEq)]
pub enum EventKind {
    /// The estimator's status changed.
    StatusChange {
        /// Before.
        from: Status,
        /// After.
        to: Status,
    },
    /// The estimator rejected an input (the run goes on without it).
    InputRejected(String),
    /// The sensors the estimator uses changed (`LiveSuite` names).
    SuiteSwitch {
        /// Before.
        from: String,
        /// After.
        to: String,
        /// Which sensor stopped or came back.
        reason: String,
    },
    /// Marginalization failed and the estimator went on without its prior.
    PriorDropped,
    /// The estimator aligned its world frame with the GNSS receiver's; fixes are used from
    /// now on.
    GnssAligned,
    /// GNSS fixes kept disagreeing with the odometry: the alignment was dropped and starts
    /// again.
    GnssAlignmentDropped,
    /// A calibration quantity the estimator held at its configured value is estimated from
    /// now on (which, and its σ then).
    CalibrationReleased(String),
    /// The estimator found its window failed and restarted from its last good state.
    Reset {
        /// What failed.
        reason: String,
    },
}

/// A timestamped event.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    /// Time (ns).
    pub t_ns: i64,
    /// What happened.
    pub kind: EventKind,
}

/// Everything a run produced.
#[derive(Clone, Debug)]
pub struct RunOutput {
    /// Scenario name.
    pub scenario: String,
    /// The seed used.
    pub seed: u64,
    /// Simulated duration (s).
    pub duration_s: f64,
    /// IMU samples fed.
    pub imu_samples: usize,
    /// Frames fed.
    pub frames_in: usize,
    /// Per processed frame, in order.
    pub frames: Vec<FrameRecord>,
    /// Events in order.
    pub events: Vec<Event>,
    /// Estimator resets (`Reset` events).
    pub resets: usize,
    /// Sensor-suite switches the estimator reported.
    pub suite_switches: usize,
    /// IMU samples the estimator excluded as spikes.
    pub imu_samples_excluded: usize,
    /// IMU samples the estimator found on the sensor's range.
    pub imu_samples_saturated: usize,
    /// Persistent points the estimator gave a new first estimate.
    pub points_relinearized: usize,
    /// The graphics adapter of a rendered scenario (`None` for feature-level ones).
    pub renderer: Option<String>,
    /// The image front end's statistics against ground truth (rendered scenarios tracked by
    /// the KLT front end).
    pub frontend: Option<FrontendStats>,
    /// What the image front end did, without ground truth (runs on images, rendered or
    /// recorded).
    pub frontend_tracks: Option<TrackSummary>,
    /// The batch reference, when asked for.
    pub batch_reference: Option<BatchReference>,
    /// Simulated time (s) at which the run was stopped early ([`run_interruptible`]); `None`
    /// when it ran to the end.
    pub interrupted_at_s: Option<f64>,
}

impl RunOutput {
    /// An output with nothing recorded yet: run `name` with `seed` over `duration_s`, images
    /// from `renderer` (`None`: feature level or recorded).
    pub fn new(name: String, seed: u64, duration_s: f64, renderer: Option<String>) -> Self {
        Self {
            scenario: name,
            seed,
            duration_s,
            imu_samples: 0,
            frames_in: 0,
            frames: Vec::new(),
            events: Vec::new(),
            resets: 0,
            suite_switches: 0,
            imu_samples_excluded: 0,
            imu_samples_saturated: 0,
            points_relinearized: 0,
            renderer,
            frontend: None,
            frontend_tracks: None,
            batch_reference: None,
            interrupted_at_s: None,
        }
    }
}

/// Errors that stop a run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The scenario does not map onto a world or an estimator.
    #[error("{0}")]
    Spec(#[from] SpecError),
    /// The simulator rejected the world.
    #[error("{file}: the simulator rejected the scenario: {message}")]
    Sim {
        /// The scenario file.
        file: String,
        /// Why.
        message: String,
    },
    /// The estimator rejected its configuration.
    #[error("{file}: the estimator rejected the scenario's configuration: {message}")]
    Estimator {
        /// The scenario file.
        file: String,
        /// Why.
        message: String,
    },
    /// The image front end rejected its configuration or an image.
    #[error("{file}: image front end: {message}")]
    Frontend {
        /// The scenario file.
        file: String,
        /// Why.
        message: String,
    },
    /// Ground truth was not available at an estimate's time.
    #[error("no ground truth at t = {t_ns} ns")]
    NoTruth {
        /// The estimate's time.
        t_ns: i64,
    },
}

impl RunError {
    /// A failure of the simulator or the renderer while running `scenario`.
    pub fn sim(scenario: &Scenario, message: impl std::fmt::Display) -> Self {
        RunError::Sim {
            file: scenario.file_label(),
            message: message.to_string(),
        }
    }
}

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

/// Runs `scenario`; `progress` is called with the fraction of simulated time done (0..=1).
pub fn run(
    scenario: &Scenario,
    options: &RunOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<RunOutput, RunError> {
    run_interruptible(scenario, options, progress, &AtomicBool::new(false))
}

/// [`run`], stopping early once `stop` is set (Ctrl-C): the simulation ends there, the
/// estimator processes what it holds, and the output covers the run so far
/// ([`RunOutput::interrupted_at_s`]).
pub fn run_interruptible(
    scenario: &Scenario,
    options: &RunOptions,
    progress: &mut dyn FnMut(f64),
    stop: &AtomicBool,
) -> Result<RunOutput, RunError> {
    let world_cfg = scenario.world_config(options.seed, options.duration_s)?;
    let mut est_cfg = scenario.estimator_config()?;
    est_cfg.record_history |= options.batch_reference;
    est_cfg.compute_covariance |= options.covariance;
    let seed = world_cfg.seed;
    let tracker_cfg = scenario.tracker_config(seed)?;
    let uses_imu = est_cfg.suite.uses_imu();
    let world = World::new(world_cfg).map_err(|e| RunError::sim(scenario, e))?;
    let mut frontend = match tracker_cfg {
        None => None,
        Some(cfg) => Some(image_frontend(scenario, &world, &est_cfg, cfg)?),
    };
    let mut estimator = Estimator::new(est_cfg).map_err(|e| RunError::Estimator {
        file: scenario.file_label(),
        message: e.to_string(),
    })?;
    let end_ns = world.end_ns();
    let (mut stream, renderer) = measurement_stream(scenario, &world)?;
    let out = RunOutput::new(scenario.name.clone(), seed, end_ns as f64 * 1e-9, renderer);
    let mut render_s = 0.0;
    let mut recorder = Recorder::new(out, estimator.status());
    let mut last_progress = -1.0;
    let mut finished = false;
    let mut now_ns: i64 = 0;
    while !finished {
        let m = if stop.load(Ordering::Relaxed) {
            recorder
                .out
                .interrupted_at_s
                .get_or_insert(now_ns as f64 * 1e-9);
            None
        } else {
            stream.next()
        };
        let t_ns = m.as_ref().map_or(end_ns, |m| m.t_ns());
        now_ns = now_ns.max(t_ns.min(end_ns));
        let (result, _frontend_s, call_start) = match m {
            None => {
                // End of the data: the estimator judges its last IMU samples and processes
                // the frames still waiting for them.
                finished = true;
                let start = Instant::now();
                (estimator.finish(), 0.0, start)
            }
            Some(Measurement::Images(images)) => {
                render_s = stream.last_render_s();
                let Some(fe) = frontend.as_mut() else {
                    continue;
                };
                // The front end tracks the images; the ideal frame that follows is skipped.
                let truth = stream.truth(images.t_capture_ns).map(|g| g.pose);
                let (frame, frontend_s) =
                    fe.process(&images, truth.as_ref())
                        .map_err(|e| RunError::Frontend {
                            file: scenario.file_label(),
                            message: e.to_string(),
                        })?;
                recorder.frame_pushed(frame.t_ns, frontend_s, render_s);
                let start = Instant::now();
                (estimator.push_frame(frame), frontend_s, start)
            }
            Some(Measurement::Imu(s)) => {
                recorder.out.imu_samples += 1;
                if let Some(fe) = frontend.as_mut().filter(|_| uses_imu) {
                    fe.push_imu(&s);
                }
                let start = Instant::now();
                (estimator.push_imu(s), 0.0, start)
            }
            Some(Measurement::Gnss(fix)) => {
                let start = Instant::now();
                (estimator.push_gnss(fix), 0.0, start)
            }
            Some(Measurement::Wheel(reading)) => {
                let start = Instant::now();
                (estimator.push_wheel(reading), 0.0, start)
            }
            Some(Measurement::Frame(_)) if frontend.is_some() => continue,
            Some(Measurement::Frame(f)) => {
                // Feature-level input: the frame is already the estimator's input.
                let start = Instant::now();
                let frame = f;
                let frontend_s = start.elapsed().as_secs_f64();
                recorder.frame_pushed(frame.t_ns, frontend_s, render_s);
                (estimator.push_frame(frame), frontend_s, start)
            }
        };
        let call_s = call_start.elapsed().as_secs_f64();
        recorder.absorb(&mut estimator, result, t_ns, call_s, render_s, |e| {
            stream.truth(e.t_ns)
        })?;
        let frac = (t_ns as f64 / end_ns.max(1) as f64).clamp(0.0, 1.0);
        if frac - last_progress >= 0.001 {
            progress(frac);
            last_progress = frac;
        }
    }
    let mut out = recorder.out;
    out.frontend_tracks = frontend.as_ref().map(|f| f.track_summary());
    out.frontend = frontend.map(|f| f.stats());
    match out.interrupted_at_s {
        Some(t) => out.duration_s = t,
        None => stream_result(scenario, &stream)?,
    }
    if options.batch_reference {
        out.batch_reference = Some(batch_reference(&mut estimator));
    }
    progress(1.0);
    Ok(out)
}

/// Collects a run's output from the estimator's calls: estimates with their ground truth and
/// timing, status changes and the estimator's events. Shared by simulated runs and recorded
/// datasets (`vio euroc`).
#[derive(Debug)]
pub(crate) struct Recorder {
    /// The output so far.
    pub out: RunOutput,
    /// Leave estimates without ground truth out of the frames (counted in `without_truth`)
    /// instead of failing with [`RunError::NoTruth`].
    pub skip_without_truth: bool,
    /// Estimates left out for want of ground truth.
    pub without_truth: usize,
    status: Status,
    /// (camera stamp, front-end s, render s) of frames pushed and not yet estimated.
    pending: VecDeque<(i64, f64, f64)>,
}

impl Recorder {
    /// A recorder filling `out`, the estimator starting in `status`.
    pub fn new(out: RunOutput, status: Status) -> Self {
        Self {
            out,
            skip_without_truth: false,
            without_truth: 0,
            status,
            pending: VecDeque::new(),
        }
    }

    /// A frame stamped `t_ns` (camera clock) went to the estimator after `frontend_s` of
    /// front-end and `render_s` of rendering time.
    pub fn frame_pushed(&mut self, t_ns: i64, frontend_s: f64, render_s: f64) {
        self.out.frames_in += 1;
        self.pending.push_back((t_ns, frontend_s, render_s));
    }

    /// Records one estimator call made at `t_ns` that took `call_s`: its events, and its
    /// estimates with their `truth` (an estimate without: see
    /// [`Recorder::skip_without_truth`]).
    pub fn absorb(
        &mut self,
        estimator: &mut Estimator,
        result: Result<Vec<Estimate>, EstimatorError>,
        t_ns: i64,
        call_s: f64,
        render_s: f64,
        mut truth: impl FnMut(&Estimate) -> Option<GroundTruth>,
    ) -> Result<(), RunError> {
        let out = &mut self.out;
        out.points_relinearized = estimator.points_relinearized();
        for e in estimator.take_events() {
            let kind = match e.kind {
                EstimatorEventKind::SuiteSwitch { from, to, reason } => {
                    out.suite_switches += 1;
                    EventKind::SuiteSwitch {
                        from: from.to_string(),
                        to: to.to_string(),
                        reason,
                    }
                }
                EstimatorEventKind::ImuSamplesExcluded { t_ns } => {
                    out.imu_samples_excluded += t_ns.len();
                    continue;
                }
                EstimatorEventKind::ImuSamplesSaturated { count } => {
                    out.imu_samples_saturated += count;
                    continue;
                }
                EstimatorEventKind::PriorDropped => EventKind::PriorDropped,
                EstimatorEventKind::GnssAligned => EventKind::GnssAligned,
                EstimatorEventKind::GnssAlignmentDropped => EventKind::GnssAlignmentDropped,
                EstimatorEventKind::CalibrationReleased { detail } => {
                    EventKind::CalibrationReleased(detail)
                }
                EstimatorEventKind::Reset { reason } => {
                    out.resets += 1;
                    EventKind::Reset { reason }
                }
            };
            out.events.push(Event { t_ns: e.t_ns, kind });
        }
        let estimates = match result {
            Ok(e) => e,
            Err(e) => {
                out.events.push(Event {
                    t_ns,
                    kind: EventKind::InputRejected(e.to_string()),
                });
                Vec::new()
            }
        };
        let n = estimates.len().max(1) as f64;
        for e in estimates {
            if e.status != self.status {
                out.events.push(Event {
                    t_ns: e.t_ns,
                    kind: EventKind::StatusChange {
                        from: self.status,
                        to: e.status,
                    },
                });
                self.status = e.status;
            }
            let Some(truth) = truth(&e) else {
                if self.skip_without_truth {
                    self.without_truth += 1;
                    continue;
                }
                return Err(RunError::NoTruth { t_ns: e.t_ns });
            };
            // An estimate often leaves the estimator in a later call than its frame entered
            // (the frame waits for the IMU that covers it): its front-end and render times are
            // those recorded when its frame was pushed.
            let camera_t = e.stamp_ns;
            let (mut frame_frontend_s, mut frame_render_s) = (0.0, render_s);
            while let Some(&(t, f, r)) = self.pending.front() {
                if t > camera_t {
                    break;
                }
                self.pending.pop_front();
                (frame_frontend_s, frame_render_s) = (f, r);
            }
            let timing = FrameTiming {
                frontend_s: frame_frontend_s,
                backend_s: e.backend_s,
                total_s: frame_frontend_s + call_s / n,
                render_s: frame_render_s,
            };
            out.frames.push(FrameRecord {
                estimate: e,
                truth,
                timing,
            });
        }
        Ok(())
    }
}

/// Iterations of the batch reference solve: it starts from the window's estimates, so a few
/// Gauss-Newton steps converge (the same cap as the estimator's batch tests).
const BATCH_ITERATIONS: usize = 20;

/// The frames as they left the window and the keyframe batch solved at the end of a run.
fn batch_reference(estimator: &mut Estimator) -> BatchReference {
    let options = SolverOptions {
        max_iterations: BATCH_ITERATIONS,
        ..Default::default()
    };
    let (batch, summary) = estimator
        .batch_solve_keyframes(&options)
        .map_or((Vec::new(), None), |(b, s)| (b, Some(s)));
    BatchReference {
        finalized: estimator.take_finalized(),
        batch,
        summary,
    }
}

/// The image front end for a rendered scenario: the estimator's cameras, the scene and the
/// simulator's true extrinsics for the ground-truth statistics.
pub fn image_frontend(
    scenario: &Scenario,
    world: &World,
    est_cfg: &estimator::estimator::EstimatorConfig,
    cfg: estimator::frontend::TrackerConfig,
) -> Result<ImageFrontend, RunError> {
    let cameras = crate::frontend::tracker_cameras(est_cfg);
    let true_t_b_c = world
        .config()
        .rig
        .as_ref()
        .map(|r| r.cameras.iter().map(|c| c.t_b_c).collect())
        .unwrap_or_default();
    ImageFrontend::new(cfg, cameras, world.scene().clone(), true_t_b_c).map_err(|e| {
        RunError::Frontend {
            file: scenario.file_label(),
            message: e.to_string(),
        }
    })
}
