//! What a run produced: per-frame estimates with their ground truth and timing, the events,
//! the counters, and the optional batch reference. Written by the runner ([`crate::run`]),
//! read by the report.

use estimator::frontend::TrackSummary;
use estimator::geometry::Pose;
use estimator::odometry::FilterEstimate;
use estimator::problem::SolverSummary;
use estimator::{Estimate, Status};
use nalgebra::{Vector2, Vector3};
use sim::stream::GroundTruth;

use crate::frontend::FrontendStats;

/// The window against the full batch on the same measurements
/// ([`RunOptions::batch_reference`](crate::run::RunOptions::batch_reference)).
#[derive(Clone, Debug)]
pub struct BatchReference {
    /// Every frame's pose as it left the window, `(t_ns, T_w_b)`, in order.
    pub finalized: Vec<(i64, Pose)>,
    /// The batch solution over the keyframes (marginalized ones, then the final window),
    /// `(t_ns, T_w_b)` (`Estimator::batch_solve_keyframes`).
    pub batch: Vec<(i64, Pose)>,
    /// The batch solve's statistics.
    pub summary: Option<SolverSummary>,
    /// The window against the full-information filter at checkpoints during the run.
    pub checkpoints: Vec<FilterCheckpoint>,
}

/// The window's and the full-information filter's estimates of the newest frame at one
/// checkpoint (`Estimator::filter_reference`).
#[derive(Clone, Debug)]
pub struct FilterCheckpoint {
    /// The newest frame's time (ns).
    pub t_ns: i64,
    /// The window's estimate of it.
    pub window: Pose,
    /// The filter's: pose, velocity, biases, with `compute_covariance` their covariance; the
    /// batch's size and its solve's statistics.
    pub filter: FilterEstimate,
    /// Ground truth there.
    pub truth: Pose,
    /// Wall time of its solve (s; for the report only).
    pub time_s: f64,
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
    /// The window as the estimate left it, when the run recorded it
    /// ([`RunOptions::scene`](crate::run::RunOptions::scene)).
    pub scene: Option<WindowScene>,
}

/// The estimator's window after an estimate: what a viewer draws.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowScene {
    /// The window's frame poses (world), oldest first.
    pub poses: Vec<Pose>,
    /// Its persistent points (world).
    pub points: Vec<Vector3<f64>>,
    /// The estimate's frame as the estimator received it: `(camera, feature id, pixel)`.
    pub features: Vec<(usize, u64, Vector2<f64>)>,
    /// The first camera's image of that frame as JPEG (input that is images).
    pub image_jpeg: Option<Vec<u8>>,
    /// Each camera's image size `[width, height]` (px).
    pub image_sizes: Vec<[u32; 2]>,
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
    /// An event the estimator reported (suite switches, resets, GNSS alignment, calibration
    /// releases, a dropped prior). Its IMU-sample events are not kept one by one: the output
    /// counts them ([`RunOutput::imu_samples_excluded`], [`RunOutput::imu_samples_saturated`]).
    Estimator(estimator::EventKind),
}

/// A timestamped event.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    /// Time (ns).
    pub t_ns: i64,
    /// What happened.
    pub kind: EventKind,
}

/// An outside estimator's run (`estimator_adapter`): which program, how it ended, and why it
/// failed when it did ([`crate::external`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct OutsideRun {
    /// The adapter's name.
    pub name: String,
    /// Where the adapter was read from (`preset:NAME` or its file).
    pub adapter: String,
    /// The command as run (placeholders replaced).
    pub command: Vec<String>,
    /// How the program ended, in words (`exited with status 0`).
    pub exit: String,
    /// Its wall time (s; for the report only).
    pub wall_s: f64,
    /// Its log (stdout and stderr), when it was kept.
    pub log: Option<std::path::PathBuf>,
    /// Why the run fails (a crash, a time-out, no or a malformed trajectory, another frame);
    /// `None` when its trajectory was scored.
    pub failure: Option<String>,
    /// The log's last lines, when the run failed.
    pub log_tail: Option<String>,
    /// Poses it wrote.
    pub poses: usize,
    /// Poses outside the ground truth's span (not scored).
    pub without_truth: usize,
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
    /// The outside estimator that produced the estimates (`None`: ours).
    pub outside: Option<OutsideRun>,
    /// Simulated time (s) at which the run was stopped early ([`RunControl::stop`](crate::run::RunControl::stop)); `None`
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
            outside: None,
            interrupted_at_s: None,
        }
    }
}
