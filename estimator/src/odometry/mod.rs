//! The sliding-window estimator (VINS-Fusion style).
//!
//! Each processed frame: predict its state with the IMU, add its feature observations, decide
//! whether the second-newest frame is a keyframe (parallax and track statistics), triangulate new
//! tracks, solve the window (IMU + reprojection + prior factors, landmarks Schur-eliminated),
//! drop outlier tracks, then either marginalize the oldest frame into the prior (keyframe) or drop
//! the second-newest frame and merge its IMU interval into the newest (non-keyframe).
//!
//! Stereo+IMU start-up: the first pose is gravity-aligned from the accelerometer; the window is
//! first solved visually (stereo gives metric scale); once `init_frames` frames are in, the
//! gyroscope bias is estimated from visual rotations and velocities and gravity from a linear
//! visual-inertial alignment, the world is rotated so gravity is −z, and IMU factors are used
//! from then on.

mod aiding_fusion;
mod batch_reference;
mod bias_mean;
mod calibration_gates;
mod chi2;
pub mod config;
pub mod events;
mod features;
mod frame;
mod frozen;
pub mod health;
mod imu_buffer;
mod init;
mod marginalization_policy;
mod persistent_point;
mod point_selection;
mod process;
mod relinearization;
mod sliding;
mod stationary;
mod time_offset;
mod triangulation;
mod window;
mod window_information;
mod window_problem;

use std::collections::VecDeque;
use std::sync::Arc;

use nalgebra::{DMatrix, Vector3};

pub use aiding_fusion::GnssAlignment;
pub use batch_reference::FilterEstimate;
use batch_reference::History;
pub use chi2::chi2_quantile;
pub use config::{
    CameraConfig, ConfigError, EstimatorConfig, GnssConfig, HealthLimits, ImuNoiseModel,
    MAX_PERSISTENT_POINTS, MAX_WINDOW_SIZE, PointCoordinates, Suite, WheelConfig,
    ZeroVelocityConfig,
};
pub use events::{Event, EventKind, LiveSuite};
use frame::WindowFrame;
pub use health::FailureReason;
use imu_buffer::ImuBuffer;
use window::Window;
pub use window_information::{RelativePose, WindowSystem};
use window_problem::ProblemSettings;

use crate::aiding_samples::{AidingError, GnssSample, WheelSample};
use crate::frontend::FeatureFrame;
use crate::geometry::Pose;
use crate::imu::{ImuError, ImuSample};
use crate::problem::{HuberLoss, LossFunction, SolverSummary, SolverWorkspace};

/// Where the estimator is in its life cycle, and what carries the newest estimate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Collecting frames for initialization (the estimate is visual-only or a prediction).
    Initializing,
    /// Full sliding-window estimation with visual constraints on the newest frame (at least
    /// `EstimatorConfig::min_tracking_observations` landmark observations in its solve).
    Tracking,
    /// Initialized, but the newest frame has too few landmark observations in the solve (no
    /// features, a dead camera, nothing triangulated): its state is carried by the IMU and the
    /// window's older frames, not by what it sees.
    Degraded,
}

impl Status {
    /// Past initialization (tracking or degraded): the estimate is in the estimator's world
    /// frame and is evaluated against ground truth.
    pub fn initialized(self) -> bool {
        !matches!(self, Status::Initializing)
    }
}

/// The state estimate for one processed frame.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct Estimate {
    /// Frame time in the IMU clock (camera stamp + td), ns.
    pub t_ns: i64,
    /// The frame's camera stamp (`FeatureFrame::t_ns`), ns: the same in every run of one
    /// sequence, whatever `td` each estimates.
    pub stamp_ns: i64,
    /// Body pose in the world frame.
    pub T_w_b: Pose,
    /// Velocity in the world frame (m/s).
    pub v_w: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub ba: Vector3<f64>,
    /// Gyroscope bias (rad/s).
    pub bg: Vector3<f64>,
    /// Camera-IMU time offset estimate (s).
    pub td_s: f64,
    /// Camera extrinsics `T_b_c` as estimated (the configured ones unless
    /// `estimate_extrinsics`), camera by camera.
    pub T_b_c: Vec<Pose>,
    /// Life-cycle status.
    pub status: Status,
    /// The sensors in use at this frame.
    pub live: LiveSuite,
    /// Whether the previous frame was kept as a keyframe.
    pub keyframe: bool,
    /// Landmarks used in the solve.
    pub landmarks: usize,
    /// Observations of those landmarks in the newest frame (what vision contributes to it).
    pub newest_observations: usize,
    /// Solver statistics, when a solve ran.
    pub solver: Option<SolverSummary>,
    /// Back-end wall time for this frame (measured for reports only), seconds.
    pub backend_s: f64,
    /// Part of `backend_s` spent in the window solve (s).
    pub solve_s: f64,
    /// Part of `backend_s` spent marginalizing and sliding (s).
    pub marginalization_s: f64,
    /// Marginal covariance of the newest state in its tangent coordinates, when
    /// `EstimatorConfig::compute_covariance` is set and the window system is positive
    /// definite: 15×15 over `[δp (world), δθ (body, right perturbation), δv, δba, δbg]` for
    /// IMU suites, 6×6 over `[δp, δθ]` for stereo-only.
    pub covariance: Option<DMatrix<f64>>,
    /// With `EstimatorConfig::compute_covariance`, when the time offset is a variable: its
    /// marginal σ (s), from the same factorization as `covariance`; while it is held (see
    /// `calibration_gates`), the σ it would have if free (`None` before the warm-up ends).
    pub td_sigma_s: Option<f64>,
    /// Whether the frame was detected at rest (its velocity constrained to zero; see
    /// `EstimatorConfig::zero_velocity`).
    pub at_rest: bool,
    /// With `EstimatorConfig::compute_covariance`: the newest pose relative to the window frame
    /// closest to `relative_pose_interval_s` before it, with its marginal covariance.
    pub relative_pose: Option<RelativePose>,
    /// `T_g_w`, the odometry's world frame in the GNSS receiver's frame, once aligned.
    pub gnss_alignment: Option<GnssAlignment>,
}

/// Errors from the estimator's inputs.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EstimatorError {
    /// An IMU sample was rejected.
    #[error(transparent)]
    Imu(#[from] ImuError),
    /// Frame timestamps must increase.
    #[error("frame at t_ns={t_ns} does not follow the previous frame at {prev_t_ns}")]
    NonIncreasingFrame {
        /// Rejected frame time.
        t_ns: i64,
        /// Previous frame time.
        prev_t_ns: i64,
    },
    /// The configuration is unusable.
    #[error("invalid estimator configuration: {0}")]
    Config(String),
    /// A GNSS fix or wheel reading was rejected.
    #[error(transparent)]
    Aiding(#[from] AidingError),
}

/// The sliding-window visual(-inertial) odometry estimator.
#[derive(Clone)]
pub struct Estimator {
    config: EstimatorConfig,
    /// Effective focal length of each camera (px).
    focal: Vec<f64>,
    /// The states being estimated.
    window: Window,
    imu: ImuBuffer,
    pending: VecDeque<FeatureFrame>,
    next_seq: u64,
    status: Status,
    last_frame_t: Option<i64>,
    history: Option<History>,
    huber: Arc<dyn LossFunction>,
    finalized: Vec<(i64, Pose)>,
    known_start: Option<KnownStart>,
    pending_bias_prior: bool,
    /// The newest state that passed the health checks (where a reset restarts).
    last_good: Option<WindowFrame>,
    /// When the last reset restarted from `last_good` (IMU time, ns): a failure soon after
    /// makes the next reset initialize again (`HealthLimits::restart_trial_s`).
    restarted_at: Option<i64>,
    /// Sensor monitors: the last time (ns, IMU clock) each camera delivered features, and the
    /// last IMU sample.
    last_features_t: [Option<i64>; 2],
    last_imu_t: Option<i64>,
    /// Time of the first measurement (a sensor that has not delivered yet is silent only
    /// `sensor_timeout_s` after it).
    first_t: Option<i64>,
    /// The latest time the sensor monitor has judged at: its clock never runs backwards (a
    /// frame's IMU time `t + td` can fall before the newest IMU sample when `td < 0`).
    monitor_t: Option<i64>,
    /// Which sensors deliver now (cameras 0 and 1, IMU); the live suite is made of them.
    live_cameras: [bool; 2],
    live_imu: bool,
    /// Cameras repeating their last image.
    frozen: frozen::FrozenMonitor,
    rest_monitor: stationary::RestMonitor,
    /// Time of the first solve of the current tracking period (IMU time, ns).
    tracking_since: Option<i64>,
    /// Consecutive solves whose IMU factors failed the χ² test.
    imu_chi2_failures: usize,
    /// The reprojection test's rejections over the last solves (cleared at a reset and when
    /// the IMU alignment succeeds).
    rejections: health::RejectionMonitor,
    /// Events not yet taken.
    events: Vec<Event>,
    /// Persistent points given a new first estimate so far (`relinearization.rs`).
    points_relinearized: usize,
    /// The window solve's scratch, reused from frame to frame (no state).
    workspace: SolverWorkspace,
}

/// A known state for the first frame (see [`Estimator::start_from`]).
#[derive(Clone, Copy, Debug)]
struct KnownStart {
    pose: Pose,
    v: Vector3<f64>,
    ba: Vector3<f64>,
    bg: Vector3<f64>,
}

impl Estimator {
    /// Creates an estimator; fails on an unusable configuration.
    pub fn new(mut config: EstimatorConfig) -> Result<Self, EstimatorError> {
        config
            .validate()
            .map_err(|e| EstimatorError::Config(e.to_string()))?;
        if let Some(sigma) = config.pixel_sigma_px {
            for c in &mut config.cameras {
                c.pixel_sigma = sigma;
            }
        }
        config.imu_noise = config.assumed_imu_noise();
        let mut focal = Vec::new();
        for (i, c) in config.cameras.iter().enumerate() {
            // Effective focal length: the projection's derivative on the optical axis.
            let (_, j) = c
                .model
                .project_with_jacobian(&Vector3::new(0.0, 0.0, 1.0))
                .ok_or_else(|| EstimatorError::Config(format!("cameras[{i}]: bad model")))?;
            focal.push(0.5 * (j[(0, 0)] + j[(1, 1)]));
        }
        let extrinsics = config.cameras.iter().map(|c| c.T_b_c).collect();
        let spike_threshold = config.imu_spike_threshold;
        let max_gap_s = config.imu_max_gap_s;
        let imu_range = config.imu_range;
        let live_imu = config.suite.uses_imu();
        let n_cameras = config.cameras.len();
        let history = config.record_history.then(History::default);
        let huber: Arc<dyn LossFunction> = Arc::new(HuberLoss {
            delta: config.huber_sigma,
        });
        Ok(Self {
            window: Window::new(extrinsics, config.td_s),
            config,
            focal,
            imu: ImuBuffer::new(spike_threshold, max_gap_s, imu_range),
            pending: VecDeque::new(),
            next_seq: 0,
            status: Status::Initializing,
            last_frame_t: None,
            history,
            huber,
            finalized: Vec::new(),
            known_start: None,
            pending_bias_prior: false,
            last_good: None,
            restarted_at: None,
            last_features_t: [None; 2],
            last_imu_t: None,
            first_t: None,
            monitor_t: None,
            live_cameras: [true, n_cameras > 1],
            live_imu,
            frozen: frozen::FrozenMonitor::default(),
            rest_monitor: stationary::RestMonitor::default(),
            tracking_since: None,
            points_relinearized: 0,
            imu_chi2_failures: 0,
            rejections: health::RejectionMonitor::default(),
            events: Vec::new(),
            workspace: SolverWorkspace::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &EstimatorConfig {
        &self.config
    }

    /// Starts from a known state at the first frame instead of initializing from the data
    /// (e.g. a vehicle starting at a surveyed pose, or simulation studies that isolate the
    /// sliding window from initialization). Must be called before the first frame; the
    /// estimator is then tracking from the first frame on, with the bias prior around `ba`, `bg`.
    #[allow(non_snake_case)]
    pub fn start_from(
        &mut self,
        T_w_b: Pose,
        v_w: Vector3<f64>,
        ba: Vector3<f64>,
        bg: Vector3<f64>,
    ) {
        self.known_start = Some(KnownStart {
            pose: T_w_b,
            v: v_w,
            ba,
            bg,
        });
        if self.config.suite.uses_imu() {
            self.status = Status::Tracking;
            self.pending_bias_prior = true;
        }
    }

    /// Current life-cycle status.
    pub fn status(&self) -> Status {
        self.status
    }

    /// How many times a persistent point got a new first estimate
    /// ([`EstimatorConfig::point_relinearize_fraction`]).
    pub fn points_relinearized(&self) -> usize {
        self.points_relinearized
    }

    /// The poses of the frames in the window, oldest first (world frame), as the last solve left
    /// them: what a viewer draws as the window.
    pub fn window_poses(&self) -> Vec<Pose> {
        self.window.frames.iter().map(|f| f.pose).collect()
    }

    /// The window's persistent points (world frame), in id order.
    pub fn window_points(&self) -> Vec<Vector3<f64>> {
        self.window.points.values().map(|p| p.world()).collect()
    }

    /// The sensors in use.
    pub fn live_suite(&self) -> LiveSuite {
        LiveSuite::from_live(self.live_cameras, self.live_imu)
    }

    /// Events since the last call, in order.
    pub fn take_events(&mut self) -> Vec<Event> {
        std::mem::take(&mut self.events)
    }

    /// Adds an IMU sample; returns estimates of frames that became processable.
    pub fn push_imu(&mut self, sample: ImuSample) -> Result<Vec<Estimate>, EstimatorError> {
        ImuSample::new(sample.t_ns, sample.gyro, sample.accel)?;
        self.imu.check_next(&sample)?;
        if !self.config.suite.uses_imu() {
            return Ok(Vec::new());
        }
        self.imu.push(sample)?;
        self.last_imu_t = Some(sample.t_ns);
        self.report_excluded();
        self.monitor_sensors(sample.t_ns);
        self.drain_pending()
    }

    /// Adds a GNSS position fix (used by IMU suites; see [`GnssConfig`]). Fixes are buffered:
    /// no estimate comes out of this call.
    pub fn push_gnss(&mut self, fix: GnssSample) -> Result<Vec<Estimate>, EstimatorError> {
        self.window.aiding.push_gnss(fix)?;
        Ok(Vec::new())
    }

    /// Adds a wheel-odometry reading (used by IMU suites; see [`WheelConfig`]). Buffered: no
    /// estimate comes out of this call.
    pub fn push_wheel(&mut self, reading: WheelSample) -> Result<Vec<Estimate>, EstimatorError> {
        self.window.aiding.push_wheel(reading)?;
        Ok(Vec::new())
    }

    /// Ends the data: the last IMU samples are judged (see
    /// `EstimatorConfig::imu_spike_threshold`) and the frames they cover are processed.
    pub fn finish(&mut self) -> Result<Vec<Estimate>, EstimatorError> {
        self.imu.flush();
        self.report_excluded();
        self.drain_pending()
    }

    /// Adds a camera frame; returns estimates of frames that became processable (with an IMU,
    /// a frame waits until IMU samples cover its time).
    pub fn push_frame(&mut self, mut frame: FeatureFrame) -> Result<Vec<Estimate>, EstimatorError> {
        let prev = self
            .pending
            .back()
            .map(|f| f.t_ns)
            .or(self.last_frame_t.map(|t| t - self.td_ns()));
        if let Some(prev) = prev
            && frame.t_ns <= prev
        {
            return Err(EstimatorError::NonIncreasingFrame {
                t_ns: frame.t_ns,
                prev_t_ns: prev,
            });
        }
        let t_imu = frame.t_ns + self.td_ns();
        self.drop_frozen(&mut frame, t_imu);
        for cf in frame.cameras.iter().filter(|c| !c.features.is_empty()) {
            if let Some(t) = self.last_features_t.get_mut(cf.cam_id) {
                *t = Some(t_imu);
            }
        }
        self.monitor_sensors(t_imu);
        self.pending.push_back(frame);
        self.drain_pending()
    }

    /// The current time offset in whole nanoseconds (camera stamp + this = IMU time).
    fn td_ns(&self) -> i64 {
        (self.window.td * 1e9).round() as i64
    }

    fn drain_pending(&mut self) -> Result<Vec<Estimate>, EstimatorError> {
        let mut out = Vec::new();
        while let Some(f) = self.pending.front() {
            // A frame's IMU time follows the previous frame's even when the offset estimate
            // fell by more than a frame period since (a reset returns it to `td_s`).
            let after_previous = self.last_frame_t.map_or(i64::MIN, |t| t + 1);
            let t = (f.t_ns + self.td_ns()).max(after_previous);
            if self.config.suite.uses_imu() {
                // A frame waits for the IMU samples that cover it, unless the IMU has been
                // silent for longer than the sensor timeout (newer frames prove time went on):
                // it is then processed without an IMU interval.
                let newest_frame_t = self.pending.back().map_or(t, |b| b.t_ns + self.td_ns());
                let silent_after = (self.config.sensor_timeout_s * 1e9) as i64;
                let imu_silent = newest_frame_t - t > silent_after;
                let covered = self.imu.newest_t_ns().is_some_and(|s| s >= t);
                if !covered && !imu_silent {
                    break;
                }
                if covered && self.imu.oldest_t_ns().is_some_and(|s| s > t) {
                    // No IMU before this frame: it cannot be integrated from anywhere.
                    self.pending.pop_front();
                    continue;
                }
            }
            let f = self.pending.pop_front().expect("front exists");
            out.push(self.process(f, t));
        }
        Ok(out)
    }

    /// What the window's problem needs besides the states.
    fn problem_settings(&self) -> ProblemSettings<'_> {
        ProblemSettings {
            config: &self.config,
            huber: &self.huber,
        }
    }

    /// Poses of frames that have left the window since the last call, as last estimated inside
    /// it (fixed-lag smoothed: keyframes after `window_size` keyframes, or
    /// `startup_window_size` early on, non-keyframes after one frame), in the order they left.
    pub fn take_finalized(&mut self) -> Vec<(i64, Pose)> {
        std::mem::take(&mut self.finalized)
    }
}
