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

pub mod config;
mod features;
mod init;

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, Matrix4, SymmetricEigen, UnitQuaternion, Vector2, Vector3, Vector4};

pub use config::{CameraConfig, EstimatorConfig, Suite};
use features::{FeatureManager, Observation};

use crate::factors::{
    FeatureMeasurement, ImuFactor, PriorFactor, ProjectionOneFrameTwoCam, ProjectionTwoFrameOneCam,
    ProjectionTwoFrameTwoCam,
};
use crate::frontend::FeatureFrame;
use crate::geometry::Pose;
use crate::imu::{ImuError, ImuSample, Preintegration};
use crate::problem::marginalization::{MarginalizationOptions, marginalize};
use crate::problem::solver::dense_normal_equations;
use crate::problem::{
    BlockId, BlockKind, Euclidean, Factor, HuberLoss, LossFunction, PoseManifold, Problem,
    ResidualId, SolverSummary, solve,
};

/// Where the estimator is in its life cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Collecting frames for initialization (the estimate is visual-only or a prediction).
    Initializing,
    /// Full sliding-window estimation.
    Tracking,
}

/// The state estimate for one processed frame.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct Estimate {
    /// Frame time in the IMU clock (camera stamp + td), ns.
    pub t_ns: i64,
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
    /// Life-cycle status.
    pub status: Status,
    /// Whether the previous frame was kept as a keyframe.
    pub keyframe: bool,
    /// Landmarks used in the solve.
    pub landmarks: usize,
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
}

/// A frame's state in the window.
#[derive(Clone, Debug)]
struct WindowFrame {
    seq: u64,
    t_ns: i64,
    pose: Pose,
    v: Vector3<f64>,
    ba: Vector3<f64>,
    bg: Vector3<f64>,
    /// IMU interval from the previous window frame to this one.
    preint: Option<Preintegration>,
}

/// A parameter block of the window, independent of any one `Problem`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BlockRef {
    Pose(u64),
    SpeedBias(u64),
    Extrinsic(usize),
    Td,
}

/// A window problem and the map from its blocks back to the estimator's states.
struct Built {
    problem: Problem,
    refs: Vec<(BlockRef, BlockId)>,
    landmarks: Vec<(u64, BlockId)>,
    /// (IMU factor, index of its later frame in the window).
    imu: Vec<(ResidualId, usize)>,
    /// (residual, track id).
    visual: Vec<(ResidualId, u64)>,
    prior: Option<ResidualId>,
}

impl Built {
    fn block(&self, r: BlockRef) -> Option<BlockId> {
        self.refs.iter().find(|(x, _)| *x == r).map(|(_, b)| *b)
    }
}

/// Marginal covariance of frame `seq`'s pose (and speed-bias) blocks: the matching block of the
/// inverse of the whole window's Gauss-Newton information. `None` if a block is constant or
/// absent, or the information is not positive definite.
fn newest_covariance(built: &Built, seq: u64) -> Option<DMatrix<f64>> {
    let (h, _, blocks) = dense_normal_equations(&built.problem)?;
    let mut offsets = Vec::with_capacity(blocks.len());
    let mut at = 0;
    for b in &blocks {
        offsets.push(at);
        at += built.problem.manifold(*b).tangent_size();
    }
    let mut cols = Vec::new();
    for r in [BlockRef::Pose(seq), BlockRef::SpeedBias(seq)] {
        let Some(id) = built.block(r) else { continue };
        let k = blocks.iter().position(|b| *b == id)?;
        cols.extend(offsets[k]..offsets[k] + built.problem.manifold(id).tangent_size());
    }
    if cols.is_empty() {
        return None;
    }
    let n = h.nrows();
    let chol = h.cholesky()?;
    let mut e = DMatrix::zeros(n, cols.len());
    for (j, &c) in cols.iter().enumerate() {
        e[(c, j)] = 1.0;
    }
    let x = chol.solve(&e);
    let m = cols.len();
    let mut cov = DMatrix::from_fn(m, m, |i, j| x[(cols[i], j)]);
    // Symmetric by construction up to rounding.
    cov = (&cov + cov.transpose()) * 0.5;
    Some(cov)
}

/// History kept for [`Estimator::batch_solve`].
#[derive(Clone, Debug, Default)]
struct History {
    frames: Vec<WindowFrame>,
    /// Per frame seq: the observations (feature id, observation).
    observations: Vec<(u64, Vec<(u64, Observation)>)>,
}

/// The sliding-window visual(-inertial) odometry estimator.
#[derive(Clone)]
pub struct Estimator {
    config: EstimatorConfig,
    focal: Vec<f64>,
    extrinsics: Vec<Pose>,
    td: f64,
    frames: VecDeque<WindowFrame>,
    features: FeatureManager,
    prior: Option<(Arc<PriorFactor>, Vec<BlockRef>)>,
    imu: VecDeque<ImuSample>,
    pending: VecDeque<FeatureFrame>,
    next_seq: u64,
    status: Status,
    last_frame_t: Option<i64>,
    history: Option<History>,
    huber: Arc<dyn LossFunction>,
    finalized: Vec<(i64, Pose)>,
    known_start: Option<KnownStart>,
    pending_bias_prior: bool,
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
    pub fn new(config: EstimatorConfig) -> Result<Self, EstimatorError> {
        if config.cameras.is_empty() || config.cameras.len() > 2 {
            return Err(EstimatorError::Config(format!(
                "cameras: need 1 or 2, got {}",
                config.cameras.len()
            )));
        }
        if config.cameras.len() != 2 {
            return Err(EstimatorError::Config(
                "the stereo suites need exactly two cameras".into(),
            ));
        }
        if config.window_size < 3 {
            return Err(EstimatorError::Config("window_size must be ≥ 3".into()));
        }
        if !(config.initial_ba_sigma > 0.0 && config.initial_bg_sigma > 0.0) {
            return Err(EstimatorError::Config(
                "initial bias sigmas must be > 0".into(),
            ));
        }
        if config.suite.uses_imu() && config.init_frames < 4 {
            return Err(EstimatorError::Config("init_frames must be ≥ 4".into()));
        }
        let mut focal = Vec::new();
        for (i, c) in config.cameras.iter().enumerate() {
            if !(c.pixel_sigma.is_finite() && c.pixel_sigma > 0.0) {
                return Err(EstimatorError::Config(format!(
                    "cameras[{i}].pixel_sigma must be > 0"
                )));
            }
            // Effective focal length: the projection's derivative on the optical axis.
            let (_, j) = c
                .model
                .project_with_jacobian(&Vector3::new(0.0, 0.0, 1.0))
                .ok_or_else(|| EstimatorError::Config(format!("cameras[{i}]: bad model")))?;
            focal.push(0.5 * (j[(0, 0)] + j[(1, 1)]));
        }
        let extrinsics = config.cameras.iter().map(|c| c.T_b_c).collect();
        let history = config.record_history.then(History::default);
        let huber: Arc<dyn LossFunction> = Arc::new(HuberLoss {
            delta: config.huber_sigma,
        });
        Ok(Self {
            td: config.td_s,
            config,
            focal,
            extrinsics,
            frames: VecDeque::new(),
            features: FeatureManager::default(),
            prior: None,
            imu: VecDeque::new(),
            pending: VecDeque::new(),
            next_seq: 0,
            status: Status::Initializing,
            last_frame_t: None,
            history,
            huber,
            finalized: Vec::new(),
            known_start: None,
            pending_bias_prior: false,
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

    /// Adds an IMU sample; returns estimates of frames that became processable.
    pub fn push_imu(&mut self, sample: ImuSample) -> Result<Vec<Estimate>, EstimatorError> {
        ImuSample::new(sample.t_ns, sample.gyro, sample.accel)?;
        if let Some(last) = self.imu.back()
            && sample.t_ns <= last.t_ns
        {
            return Err(ImuError::NonIncreasingTime {
                t_ns: sample.t_ns,
                prev_t_ns: last.t_ns,
            }
            .into());
        }
        if !self.config.suite.uses_imu() {
            return Ok(Vec::new());
        }
        self.imu.push_back(sample);
        self.drain_pending()
    }

    /// Adds a camera frame; returns estimates of frames that became processable (with an IMU,
    /// a frame waits until IMU samples cover its time).
    pub fn push_frame(&mut self, frame: FeatureFrame) -> Result<Vec<Estimate>, EstimatorError> {
        let prev = self.pending.back().map(|f| f.t_ns).or(self
            .last_frame_t
            .map(|t| t - (self.td * 1e9).round() as i64));
        if let Some(prev) = prev
            && frame.t_ns <= prev
        {
            return Err(EstimatorError::NonIncreasingFrame {
                t_ns: frame.t_ns,
                prev_t_ns: prev,
            });
        }
        self.pending.push_back(frame);
        self.drain_pending()
    }

    fn drain_pending(&mut self) -> Result<Vec<Estimate>, EstimatorError> {
        let mut out = Vec::new();
        while let Some(f) = self.pending.front() {
            let t = f.t_ns + (self.td * 1e9).round() as i64;
            if self.config.suite.uses_imu() {
                match self.imu.back() {
                    Some(s) if s.t_ns >= t => {}
                    _ => break,
                }
                if self.imu.front().is_some_and(|s| s.t_ns > t) {
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

    /// Cuts the IMU buffer into a preintegration over `[t0, t1]` linearized at the biases.
    fn take_interval(
        &mut self,
        t0: i64,
        t1: i64,
        ba: Vector3<f64>,
        bg: Vector3<f64>,
    ) -> Option<Preintegration> {
        let at = |buf: &VecDeque<ImuSample>, t: i64| -> Option<ImuSample> {
            let i = buf.iter().position(|s| s.t_ns >= t)?;
            if buf[i].t_ns == t || i == 0 {
                return Some(ImuSample { t_ns: t, ..buf[i] });
            }
            Some(ImuSample::interpolate(&buf[i - 1], &buf[i], t))
        };
        let first = at(&self.imu, t0)?;
        let last = at(&self.imu, t1)?;
        let mut p = Preintegration::new(first, ba, bg, self.config.imu_noise).ok()?;
        for s in self.imu.iter().filter(|s| s.t_ns > t0 && s.t_ns < t1) {
            p.push(*s).ok()?;
        }
        p.push(last).ok()?;
        // Keep the last sample at or before t1 for the next interval's interpolation.
        while self.imu.len() >= 2 && self.imu[1].t_ns <= t1 {
            self.imu.pop_front();
        }
        Some(p)
    }

    fn process(&mut self, frame: FeatureFrame, t_ns: i64) -> Estimate {
        let start = Instant::now();
        let seq = self.next_seq;
        self.next_seq += 1;
        let uses_imu = self.config.suite.uses_imu();

        // 1. State prediction.
        let mut wf = match self.frames.back() {
            None if self.known_start.is_some() => {
                let k = self.known_start.take().expect("checked");
                WindowFrame {
                    seq,
                    t_ns,
                    pose: k.pose,
                    v: k.v,
                    ba: k.ba,
                    bg: k.bg,
                    preint: None,
                }
            }
            None => {
                let q = if uses_imu {
                    let recent: Vec<ImuSample> = self
                        .imu
                        .iter()
                        .filter(|s| s.t_ns <= t_ns)
                        .rev()
                        .take(20)
                        .copied()
                        .collect();
                    init::gravity_aligned_rotation(&recent).unwrap_or_else(UnitQuaternion::identity)
                } else {
                    UnitQuaternion::identity()
                };
                WindowFrame {
                    seq,
                    t_ns,
                    pose: Pose::new(q, Vector3::zeros()),
                    v: Vector3::zeros(),
                    ba: Vector3::zeros(),
                    bg: Vector3::zeros(),
                    preint: None,
                }
            }
            Some(last) => {
                let last = last.clone();
                let preint = if uses_imu {
                    self.take_interval(last.t_ns, t_ns, last.ba, last.bg)
                } else {
                    None
                };
                let (pose, v) = match (&preint, self.status) {
                    (Some(p), Status::Tracking) => {
                        p.predict(&last.pose, &last.v, &last.ba, &last.bg)
                    }
                    _ => (self.constant_velocity_guess(&last, t_ns), last.v),
                };
                WindowFrame {
                    seq,
                    t_ns,
                    pose,
                    v,
                    ba: last.ba,
                    bg: last.bg,
                    preint,
                }
            }
        };
        if uses_imu && wf.preint.is_none() && !self.frames.is_empty() {
            // IMU gap: carry the state over (the window solve will use vision only here).
            wf.pose = self.frames.back().expect("non-empty").pose;
        }
        self.last_frame_t = Some(t_ns);

        // 2. Observations.
        let observations = self.observations(&frame, seq, t_ns);
        if let Some(h) = &mut self.history {
            h.observations.push((seq, observations.clone()));
        }
        let continued = self.features.add_frame(observations);
        self.frames.push_back(wf);

        // 3. Keyframe decision about the second-newest frame.
        let n = self.frames.len();
        let keyframe = if n < 3 || continued < self.config.keyframe_min_tracked {
            true
        } else {
            let a = self.frames[n - 3].seq;
            let b = self.frames[n - 2].seq;
            match self.features.parallax(a, b) {
                Some(p) => p * self.focal[0] >= self.config.keyframe_parallax_px,
                None => true,
            }
        };

        // 4. Triangulate, solve, reject outliers, marginalize, slide.
        if self.pending_bias_prior {
            self.pending_bias_prior = false;
            self.set_initial_prior();
        }
        self.triangulate_tracks();
        if uses_imu
            && self.status == Status::Initializing
            && self.frames.len() >= self.config.init_frames
        {
            self.try_initialize();
        }
        let imu_active = uses_imu && self.status == Status::Tracking;
        let mut built = self.build(imu_active);
        let summary = solve(&mut built.problem, &self.config.solver);
        self.write_back(&built);
        let covariance = if self.config.compute_covariance {
            let seq = self.frames.back().expect("just pushed").seq;
            newest_covariance(&built, seq)
        } else {
            None
        };
        let landmarks = built.landmarks.len();
        // The newest frame's state and (not yet merged) IMU interval, as solved.
        let newest = self.frames.back().expect("just pushed").clone();
        let window_full = self.frames.len() > self.config.window_size;
        let marg_start = Instant::now();
        if window_full {
            if keyframe {
                self.marginalize_oldest(&built, imu_active);
            } else {
                self.marginalize_second_newest(&built);
            }
        }
        let marginalization_s = marg_start.elapsed().as_secs_f64();
        self.reject_outliers();
        if !uses_imu {
            self.status = Status::Tracking;
        }
        if let Some(h) = &mut self.history
            && self.status == Status::Tracking
        {
            h.frames.push(newest.clone());
        }
        Estimate {
            t_ns: newest.t_ns,
            T_w_b: newest.pose,
            v_w: newest.v,
            ba: newest.ba,
            bg: newest.bg,
            td_s: self.td,
            status: self.status,
            keyframe,
            landmarks,
            solver: Some(summary),
            backend_s: start.elapsed().as_secs_f64(),
            solve_s: summary.time.as_secs_f64(),
            marginalization_s,
            covariance,
        }
    }

    fn constant_velocity_guess(&self, last: &WindowFrame, t_ns: i64) -> Pose {
        let n = self.frames.len();
        if n < 2 {
            return last.pose;
        }
        let prev = &self.frames[n - 2];
        let dt_prev = (last.t_ns - prev.t_ns) as f64;
        let dt = (t_ns - last.t_ns) as f64;
        if dt_prev <= 0.0 {
            return last.pose;
        }
        let rel = prev.pose.inverse().compose(&last.pose);
        let s = dt / dt_prev;
        let rel_scaled = Pose::new(
            UnitQuaternion::identity().slerp(&rel.q, s.min(2.0)),
            rel.p * s,
        );
        last.pose.compose(&rel_scaled)
    }

    /// Undistorts a frame's features and computes their image velocities.
    fn observations(&self, frame: &FeatureFrame, seq: u64, t_ns: i64) -> Vec<(u64, Observation)> {
        let mut by_id: std::collections::BTreeMap<u64, Observation> =
            std::collections::BTreeMap::new();
        for cf in &frame.cameras {
            if cf.cam_id > 1 {
                continue;
            }
            let model = &self.config.cameras[cf.cam_id].model;
            for f in &cf.features {
                if !f.uv.iter().all(|v| v.is_finite()) {
                    continue;
                }
                let Some(point) = model.unproject_normalized(&f.uv) else {
                    continue;
                };
                let o = by_id.entry(f.feature_id).or_insert(Observation {
                    seq,
                    meas: [None, None],
                    uv: [None, None],
                });
                let mut velocity = Vector2::zeros();
                if cf.cam_id == 0
                    && let Some((prev_seq, prev_pt)) = self.features.last_left(f.feature_id)
                    && let Some(pf) = self.frames.iter().find(|w| w.seq == prev_seq)
                {
                    let dt = (t_ns - pf.t_ns) as f64 * 1e-9;
                    if dt > 0.0 {
                        velocity = (point - prev_pt) / dt;
                    }
                }
                o.meas[cf.cam_id] = Some(FeatureMeasurement {
                    point,
                    velocity,
                    td: self.td,
                });
                o.uv[cf.cam_id] = Some(f.uv);
            }
        }
        by_id.into_iter().collect()
    }

    fn frame_index(&self, seq: u64) -> Option<usize> {
        self.frames.iter().position(|f| f.seq == seq)
    }

    /// `T_w_c` of camera `cam` at window frame `idx`.
    fn camera_pose(&self, idx: usize, cam: usize) -> Pose {
        self.frames[idx].pose.compose(&self.extrinsics[cam])
    }

    /// Triangulates tracks without depth: from the stereo pair at the anchor if it has one,
    /// else from every left-camera view in the window (DLT).
    fn triangulate_tracks(&mut self) {
        let ids: Vec<u64> = self
            .features
            .tracks
            .iter()
            .filter(|(_, t)| t.inv_depth.is_none())
            .map(|(id, _)| *id)
            .collect();
        for id in ids {
            let track = &self.features.tracks[&id];
            let mut views: Vec<(Pose, Vector2<f64>)> = Vec::new();
            let anchor = &track.obs[0];
            let Some(ai) = self.frame_index(anchor.seq) else {
                continue;
            };
            let anchor_cam = self.camera_pose(ai, 0);
            for o in &track.obs {
                let Some(fi) = self.frame_index(o.seq) else {
                    continue;
                };
                for cam in 0..2 {
                    if let Some(m) = o.meas[cam] {
                        views.push((self.camera_pose(fi, cam), m.point));
                    }
                }
            }
            if views.len() < 2 {
                continue;
            }
            let Some(p_w) = triangulate(&views) else {
                continue;
            };
            let p_c = anchor_cam.inverse().transform(&p_w);
            if p_c.z < self.config.min_depth_m || p_c.z > self.config.max_depth_m {
                continue;
            }
            // Reject triangulations that do not reproject onto their observations.
            let ok = views.iter().all(|(t_w_c, z)| {
                let q = t_w_c.inverse().transform(&p_w);
                q.z > 0.0
                    && (Vector2::new(q.x / q.z, q.y / q.z) - z).norm() * self.focal[0]
                        < 5.0 * self.config.outlier_reprojection_px
            });
            if ok {
                self.features.tracks.get_mut(&id).expect("exists").inv_depth = Some(1.0 / p_c.z);
            }
        }
    }

    /// Builds the window problem at the current estimates.
    fn build(&self, imu_active: bool) -> Built {
        let mut problem = Problem::new();
        let mut refs = Vec::new();
        let pose_m: Arc<PoseManifold> = Arc::new(PoseManifold);
        let sb_m = Arc::new(Euclidean::new(9));
        let one = Arc::new(Euclidean::new(1));
        for f in &self.frames {
            let b = problem
                .add_block(&f.pose.to_array(), pose_m.clone(), BlockKind::State)
                .expect("finite pose");
            refs.push((BlockRef::Pose(f.seq), b));
            if imu_active {
                let sb: Vec<f64> =
                    f.v.iter()
                        .chain(f.ba.iter())
                        .chain(f.bg.iter())
                        .copied()
                        .collect();
                let b = problem
                    .add_block(&sb, sb_m.clone(), BlockKind::State)
                    .expect("finite");
                refs.push((BlockRef::SpeedBias(f.seq), b));
            }
        }
        for (i, e) in self.extrinsics.iter().enumerate() {
            let b = problem
                .add_block(&e.to_array(), pose_m.clone(), BlockKind::State)
                .expect("finite");
            problem.set_constant(b, !self.config.estimate_extrinsics);
            refs.push((BlockRef::Extrinsic(i), b));
        }
        let td_block = problem
            .add_block(&[self.td], one.clone(), BlockKind::State)
            .expect("finite");
        problem.set_constant(td_block, !self.config.estimate_td);
        refs.push((BlockRef::Td, td_block));
        let mut built = Built {
            problem,
            refs,
            landmarks: Vec::new(),
            imu: Vec::new(),
            visual: Vec::new(),
            prior: None,
        };
        if !imu_active {
            // Vision only: the oldest pose fixes the gauge.
            let b = built
                .block(BlockRef::Pose(self.frames[0].seq))
                .expect("exists");
            built.problem.set_constant(b, true);
        }

        // Prior.
        if let Some((factor, blocks)) = &self.prior {
            let ids: Option<Vec<BlockId>> = blocks.iter().map(|r| built.block(*r)).collect();
            if let Some(ids) = ids {
                let f: Arc<dyn Factor> = factor.clone();
                built.prior = built.problem.add_factor(f, None, &ids).ok();
            }
        }

        // IMU.
        if imu_active {
            for k in 1..self.frames.len() {
                let (a, b) = (&self.frames[k - 1], &self.frames[k]);
                let Some(p) = &b.preint else { continue };
                let Ok(factor) = ImuFactor::new(p) else {
                    continue;
                };
                let ids = [
                    built.block(BlockRef::Pose(a.seq)).expect("pose"),
                    built.block(BlockRef::SpeedBias(a.seq)).expect("sb"),
                    built.block(BlockRef::Pose(b.seq)).expect("pose"),
                    built.block(BlockRef::SpeedBias(b.seq)).expect("sb"),
                ];
                let r = built
                    .problem
                    .add_factor(Arc::new(factor), None, &ids)
                    .expect("sizes match");
                built.imu.push((r, k));
            }
        }

        // Vision.
        let ex = [
            built.block(BlockRef::Extrinsic(0)).expect("ex0"),
            built.block(BlockRef::Extrinsic(1)).expect("ex1"),
        ];
        let weights = [
            self.focal[0] / self.config.cameras[0].pixel_sigma,
            self.focal[1] / self.config.cameras[1].pixel_sigma,
        ];
        // Pose block of each window frame, by seq (frames are in seq order).
        let pose_ids: Vec<(u64, BlockId)> = self
            .frames
            .iter()
            .filter_map(|f| built.block(BlockRef::Pose(f.seq)).map(|b| (f.seq, b)))
            .collect();
        let pose_block = |seq: u64| {
            pose_ids
                .binary_search_by_key(&seq, |(s, _)| *s)
                .ok()
                .map(|i| pose_ids[i].1)
        };
        for (id, track) in &self.features.tracks {
            let Some(inv_depth) = track.inv_depth else {
                continue;
            };
            if track.obs.len() < self.config.min_track_frames || track.measurement_count() < 2 {
                continue;
            }
            let anchor = &track.obs[0];
            let Some(obs_i) = anchor.meas[0] else {
                continue;
            };
            let Some(pose_i) = pose_block(anchor.seq) else {
                continue;
            };
            let lm = built
                .problem
                .add_block(&[inv_depth], one.clone(), BlockKind::Landmark)
                .expect("finite");
            built.landmarks.push((*id, lm));
            let loss = Some(self.huber.clone());
            if let Some(obs_b) = anchor.meas[1] {
                let f = ProjectionOneFrameTwoCam {
                    obs_a: obs_i,
                    obs_b,
                    weight: weights[1],
                };
                let r = built
                    .problem
                    .add_factor(Arc::new(f), loss.clone(), &[ex[0], ex[1], lm, td_block])
                    .expect("sizes");
                built.visual.push((r, *id));
            }
            for o in &track.obs[1..] {
                let Some(pose_j) = pose_block(o.seq) else {
                    continue;
                };
                if let Some(obs_j) = o.meas[0] {
                    let f = ProjectionTwoFrameOneCam {
                        obs_i,
                        obs_j,
                        weight: weights[0],
                    };
                    let r = built
                        .problem
                        .add_factor(
                            Arc::new(f),
                            loss.clone(),
                            &[pose_i, pose_j, ex[0], lm, td_block],
                        )
                        .expect("sizes");
                    built.visual.push((r, *id));
                }
                if let Some(obs_j) = o.meas[1] {
                    let f = ProjectionTwoFrameTwoCam {
                        obs_i,
                        obs_j,
                        weight: weights[1],
                    };
                    let r = built
                        .problem
                        .add_factor(
                            Arc::new(f),
                            loss.clone(),
                            &[pose_i, pose_j, ex[0], ex[1], lm, td_block],
                        )
                        .expect("sizes");
                    built.visual.push((r, *id));
                }
            }
        }
        built
    }

    /// Copies the solved values back into the window.
    fn write_back(&mut self, built: &Built) {
        for f in self.frames.iter_mut() {
            if let Some(b) = built.block(BlockRef::Pose(f.seq)) {
                f.pose = Pose::from_slice(built.problem.values(b));
            }
            if let Some(b) = built.block(BlockRef::SpeedBias(f.seq)) {
                let v = built.problem.values(b);
                f.v = Vector3::new(v[0], v[1], v[2]);
                f.ba = Vector3::new(v[3], v[4], v[5]);
                f.bg = Vector3::new(v[6], v[7], v[8]);
            }
        }
        for (i, e) in self.extrinsics.iter_mut().enumerate() {
            if let Some(b) = built.block(BlockRef::Extrinsic(i)) {
                *e = Pose::from_slice(built.problem.values(b));
            }
        }
        if let Some(b) = built.block(BlockRef::Td) {
            self.td = built.problem.values(b)[0];
        }
        for (id, b) in &built.landmarks {
            let d = built.problem.values(*b)[0];
            if let Some(t) = self.features.tracks.get_mut(id) {
                let depth = 1.0 / d;
                t.inv_depth = (d.is_finite()
                    && depth >= self.config.min_depth_m
                    && depth <= self.config.max_depth_m)
                    .then_some(d);
            }
        }
        // Keep the preintegrations' linearization points close to the estimates.
        let (tba, tbg) = (self.config.repropagate_ba, self.config.repropagate_bg);
        for k in 1..self.frames.len() {
            let (ba, bg) = (self.frames[k - 1].ba, self.frames[k - 1].bg);
            if let Some(p) = &mut self.frames[k].preint {
                p.repropagate_if_needed(ba, bg, tba, tbg);
            }
        }
    }

    /// Stereo+IMU initialization from the visually solved window.
    fn try_initialize(&mut self) {
        let poses: Vec<Pose> = self.frames.iter().map(|f| f.pose).collect();
        if self.frames.iter().skip(1).any(|f| f.preint.is_none()) {
            return;
        }
        let intervals: Vec<&Preintegration> = self
            .frames
            .iter()
            .skip(1)
            .filter_map(|f| f.preint.as_ref())
            .collect();
        let Some(bg) = init::estimate_gyro_bias(&poses, &intervals) else {
            return;
        };
        let ba = Vector3::zeros();
        for f in self.frames.iter_mut().skip(1) {
            if let Some(p) = &mut f.preint {
                p.repropagate(ba, bg);
            }
        }
        let intervals: Vec<&Preintegration> = self
            .frames
            .iter()
            .skip(1)
            .filter_map(|f| f.preint.as_ref())
            .collect();
        let Some((vel, g)) =
            init::align_velocities_and_gravity(&poses, &intervals, &ba, &bg, crate::GRAVITY)
        else {
            return;
        };
        // Rotate the world so that gravity points along −z (minimal rotation).
        let Some(r_align) = UnitQuaternion::rotation_between(&g, &crate::gravity_w()) else {
            return;
        };
        let origin = self.frames[0].pose.p;
        for (f, v) in self.frames.iter_mut().zip(vel) {
            f.pose = Pose::new(r_align * f.pose.q, r_align * (f.pose.p - origin));
            f.v = r_align * v;
            f.ba = ba;
            f.bg = bg;
        }
        // Landmarks are anchored in camera frames: unaffected. The prior starts as a bias prior
        // on the oldest frame (no earlier prior exists: vision-only frames carry none).
        self.set_initial_prior();
        self.status = Status::Tracking;
    }

    /// Replaces the prior by the initial prior on the oldest frame: its position and yaw (the
    /// four directions no sensor observes, pinned with `gauge_sigma` so that the solver never
    /// wanders along them) and its biases (`initial_ba_sigma`, `initial_bg_sigma` around their
    /// current estimates). Marginalization carries it forward.
    fn set_initial_prior(&mut self) {
        let first = &self.frames[0];
        let sb0: Vec<f64> = first
            .v
            .iter()
            .chain(first.ba.iter())
            .chain(first.bg.iter())
            .copied()
            .collect();
        // Rows: position (3), yaw (1), ba (3), bg (3); columns: pose tangent (6), speed-bias (9).
        let (rows, cols) = (10, 15);
        let mut jac = vec![0.0; rows * cols];
        let w_gauge = 1.0 / self.config.gauge_sigma;
        for i in 0..3 {
            jac[i * cols + i] = w_gauge;
        }
        // Yaw of R·Exp(δθ) about world z: e_zᵀ R δθ.
        let r = first.pose.q.to_rotation_matrix().into_inner();
        for c in 0..3 {
            jac[3 * cols + 3 + c] = w_gauge * r[(2, c)];
        }
        for i in 0..3 {
            jac[(4 + i) * cols + 6 + 3 + i] = 1.0 / self.config.initial_ba_sigma;
            jac[(7 + i) * cols + 6 + 6 + i] = 1.0 / self.config.initial_bg_sigma;
        }
        let manifolds: Vec<Arc<dyn crate::problem::Manifold>> =
            vec![Arc::new(PoseManifold), Arc::new(Euclidean::new(9))];
        let points = vec![first.pose.to_array().to_vec(), sb0];
        self.prior = PriorFactor::new(manifolds, points, jac, vec![0.0; rows])
            .ok()
            .map(|f| {
                (
                    Arc::new(f),
                    vec![BlockRef::Pose(first.seq), BlockRef::SpeedBias(first.seq)],
                )
            });
    }

    /// Marginalizes the oldest frame (its pose, speed-bias and anchored landmarks) into the
    /// prior, then slides the window.
    fn marginalize_oldest(&mut self, built: &Built, imu_active: bool) {
        let oldest = self.frames[0].seq;
        if imu_active {
            let pose = built.block(BlockRef::Pose(oldest)).expect("pose");
            let mut remove = vec![pose];
            remove.extend(built.block(BlockRef::SpeedBias(oldest)));
            let mut residuals: Vec<ResidualId> = built
                .imu
                .iter()
                .filter(|(_, k)| *k == 1)
                .map(|(r, _)| *r)
                .collect();
            if let Some(r) = built.prior
                && remove
                    .iter()
                    .any(|b| built.problem.residual_blocks(r).contains(b))
            {
                residuals.push(r);
            }
            // Landmarks anchored in the oldest frame (sorted ids: membership by binary search).
            let mut anchored: Vec<u64> = Vec::new();
            for (id, lm) in &built.landmarks {
                if self.features.tracks[id].obs[0].seq == oldest {
                    remove.push(*lm);
                    anchored.push(*id);
                }
            }
            anchored.sort_unstable();
            residuals.extend(
                built
                    .visual
                    .iter()
                    .filter(|(_, id)| anchored.binary_search(id).is_ok())
                    .map(|(r, _)| *r),
            );
            residuals.sort();
            self.set_prior(built, &residuals, &remove);
        } else {
            self.prior = None;
        }
        // Slide. Tracks anchored in the oldest frame: with a prior, their landmark and all its
        // observations are now in the prior, so by default the track ends here and a later
        // sighting of the same feature starts a new track; re-anchoring and re-using the
        // observations (VINS-Fusion's choice, `reuse_marginalized_tracks`) counts them twice.
        // Without a prior (vision only, or during initialization) they are re-anchored in
        // their next left view.
        let removed = self.frames[0].clone();
        if self.status == Status::Tracking {
            self.finalized.push((removed.t_ns, removed.pose));
        }
        let in_prior = imu_active && self.prior.is_some() && !self.config.reuse_marginalized_tracks;
        let ids: Vec<u64> = self.features.tracks.keys().copied().collect();
        for id in ids {
            if self.features.tracks[&id].obs[0].seq != removed.seq {
                continue;
            }
            if in_prior {
                self.features.tracks.remove(&id);
                continue;
            }
            let world = self.track_world_point(id);
            let t = self.features.tracks.get_mut(&id).expect("exists");
            t.obs.remove(0);
            while t.obs.first().is_some_and(|o| o.meas[0].is_none()) {
                t.obs.remove(0);
            }
            if t.obs.is_empty() {
                self.features.tracks.remove(&id);
                continue;
            }
            t.inv_depth = None;
            let new_anchor = t.obs[0].seq;
            if let (Some(p_w), Some(fi)) = (world, self.frame_index(new_anchor)) {
                let z = self.camera_pose(fi, 0).inverse().transform(&p_w).z;
                if z >= self.config.min_depth_m && z <= self.config.max_depth_m {
                    self.features.tracks.get_mut(&id).expect("exists").inv_depth = Some(1.0 / z);
                }
            }
        }
        self.frames.pop_front();
    }

    /// Drops the second-newest frame: its IMU interval is merged into the newest frame's and,
    /// if the prior involves it, it is marginalized out of the prior alone.
    fn marginalize_second_newest(&mut self, built: &Built) {
        let n = self.frames.len();
        let drop = self.frames[n - 2].seq;
        if let Some(r) = built.prior {
            let mut remove: Vec<BlockId> = Vec::new();
            remove.extend(built.block(BlockRef::Pose(drop)));
            remove.extend(built.block(BlockRef::SpeedBias(drop)));
            remove.retain(|b| built.problem.residual_blocks(r).contains(b));
            if !remove.is_empty() {
                self.set_prior(built, &[r], &remove);
            }
        }
        let dropped = self.frames.remove(n - 2).expect("exists");
        if self.status == Status::Tracking {
            self.finalized.push((dropped.t_ns, dropped.pose));
        }
        let newest = self.frames.back_mut().expect("exists");
        if let (Some(mut a), Some(b)) = (dropped.preint, newest.preint.take()) {
            newest.preint = a.merge(&b).is_ok().then_some(a);
        }
        let ids: Vec<u64> = self.features.tracks.keys().copied().collect();
        for id in ids {
            let t = self.features.tracks.get_mut(&id).expect("exists");
            let Some(k) = t.obs.iter().position(|o| o.seq == drop) else {
                continue;
            };
            t.obs.remove(k);
            if k == 0 {
                // The anchor left: re-triangulate from what remains.
                while t.obs.first().is_some_and(|o| o.meas[0].is_none()) {
                    t.obs.remove(0);
                }
                t.inv_depth = None;
            }
            if t.obs.is_empty() {
                self.features.tracks.remove(&id);
            }
        }
    }

    fn set_prior(&mut self, built: &Built, residuals: &[ResidualId], remove: &[BlockId]) {
        match marginalize(
            &built.problem,
            residuals,
            remove,
            &MarginalizationOptions::default(),
        ) {
            Ok(mp) => {
                let refs: Vec<BlockRef> = mp
                    .blocks
                    .iter()
                    .map(|b| built.refs.iter().find(|(_, x)| x == b).map(|(r, _)| *r))
                    .collect::<Option<Vec<_>>>()
                    .unwrap_or_default();
                self.prior = (refs.len() == mp.blocks.len() && mp.rank > 0)
                    .then(|| (Arc::new(mp.factor), refs));
            }
            Err(_) => self.prior = None,
        }
    }

    /// World position of a track's landmark.
    fn track_world_point(&self, id: u64) -> Option<Vector3<f64>> {
        let t = self.features.tracks.get(&id)?;
        let d = t.inv_depth?;
        let m = t.obs[0].meas[0]?;
        let fi = self.frame_index(t.obs[0].seq)?;
        let p_c = Vector3::new(m.point.x, m.point.y, 1.0) / d;
        Some(self.camera_pose(fi, 0).transform(&p_c))
    }

    /// Drops tracks whose mean reprojection error exceeds the threshold.
    fn reject_outliers(&mut self) {
        let mut bad = Vec::new();
        for (id, t) in &self.features.tracks {
            let Some(p_w) = self.track_world_point(*id) else {
                continue;
            };
            let (mut sum, mut n) = (0.0, 0);
            for o in &t.obs {
                let Some(fi) = self.frame_index(o.seq) else {
                    continue;
                };
                for cam in 0..2 {
                    let (Some(uv), Some(_)) = (o.uv[cam], o.meas[cam]) else {
                        continue;
                    };
                    let p_c = self.camera_pose(fi, cam).inverse().transform(&p_w);
                    match self.config.cameras[cam].model.project(&p_c) {
                        Some(px) if p_c.z > 0.0 => sum += (px - uv).norm(),
                        _ => sum += 1e3,
                    }
                    n += 1;
                }
            }
            if n > 0 && sum / n as f64 > self.config.outlier_reprojection_px {
                bad.push(*id);
            }
        }
        for id in bad {
            self.features.tracks.remove(&id);
        }
    }

    /// Poses of frames that have left the window since the last call, as last estimated inside
    /// it (fixed-lag smoothed: keyframes after `window_size` keyframes, non-keyframes after one
    /// frame), in the order they left.
    pub fn take_finalized(&mut self) -> Vec<(i64, Pose)> {
        std::mem::take(&mut self.finalized)
    }

    /// Solves all recorded frames at once without marginalization (the "physical limit"
    /// reference), starting from the causal estimates. Requires `record_history`. Returns the
    /// smoothed estimates `(t_ns, T_w_b)` of every frame, or `None` without history.
    pub fn batch_solve(&self, options: &crate::problem::SolverOptions) -> Option<Vec<(i64, Pose)>> {
        let history = self.history.as_ref()?;
        let uses_imu = self.config.suite.uses_imu();
        let mut est = Estimator::new(EstimatorConfig {
            record_history: false,
            ..self.config.clone()
        })
        .ok()?;
        est.extrinsics = self.extrinsics.clone();
        est.td = self.td;
        est.status = self.status;
        // Frames: every frame processed while tracking, chained by their own IMU intervals.
        let mut frames: VecDeque<WindowFrame> = VecDeque::new();
        for f in &history.frames {
            let mut f = f.clone();
            if frames.is_empty() {
                f.preint = None;
            }
            frames.push_back(f);
        }
        // An interval is used only if it starts at the previous frame (not across a gap).
        for k in 1..frames.len() {
            let contiguous = frames[k]
                .preint
                .as_ref()
                .is_some_and(|p| p.start_ns() == frames[k - 1].t_ns);
            if !contiguous {
                frames[k].preint = None;
            }
        }
        est.frames = frames;
        for (seq, obs) in &history.observations {
            if est.frames.iter().any(|f| f.seq == *seq) {
                est.features.add_frame(obs.clone());
            }
        }
        est.triangulate_tracks();
        let imu_active = uses_imu && self.status == Status::Tracking;
        let mut built = est.build(imu_active);
        solve(&mut built.problem, options);
        est.write_back(&built);
        Some(est.frames.iter().map(|f| (f.t_ns, f.pose)).collect())
    }
}

/// Linear triangulation (DLT) of one point from camera poses `T_w_c` and normalized
/// observations, by the smallest eigenvector of `AᵀA`.
fn triangulate(views: &[(Pose, Vector2<f64>)]) -> Option<Vector3<f64>> {
    let mut ata = Matrix4::<f64>::zeros();
    for (t_w_c, z) in views {
        let t_c_w = t_w_c.inverse();
        let r = t_c_w.q.to_rotation_matrix().into_inner();
        let p = [
            Vector4::new(r[(0, 0)], r[(0, 1)], r[(0, 2)], t_c_w.p.x),
            Vector4::new(r[(1, 0)], r[(1, 1)], r[(1, 2)], t_c_w.p.y),
            Vector4::new(r[(2, 0)], r[(2, 1)], r[(2, 2)], t_c_w.p.z),
        ];
        for row in [p[0] - p[2] * z.x, p[1] - p[2] * z.y] {
            ata += row * row.transpose();
        }
    }
    let eig = SymmetricEigen::new(ata);
    let (mut imin, mut vmin) = (0, f64::INFINITY);
    for i in 0..4 {
        if eig.eigenvalues[i] < vmin {
            vmin = eig.eigenvalues[i];
            imin = i;
        }
    }
    let x = eig.eigenvectors.column(imin);
    if x[3].abs() < 1e-12 {
        return None;
    }
    let p = Vector3::new(x[0] / x[3], x[1] / x[3], x[2] / x[3]);
    p.iter().all(|v| v.is_finite()).then_some(p)
}
