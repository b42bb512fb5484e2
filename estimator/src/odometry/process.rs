//! One frame through the window, as named steps: predict its state, add its observations,
//! decide the keyframe, initialize (or wait), prepare and solve the window, judge the solve,
//! take what the solve gives (calibration, covariance, GNSS alignment), slide and reject
//! outliers. [`Estimator::process`] reads as that list; each step is a method below.

use std::time::Instant;

use nalgebra::{DMatrix, UnitQuaternion, Vector3};

use super::calibration_gates::Gate;
use super::frame::WindowFrame;
use super::health::FailureReason;
use super::sliding::Leaving;
use super::window_information::{self, RelativePose};
use super::window_problem::WindowProblem;
use super::{
    Estimate, Estimator, Event, EventKind, LiveSuite, Status, Suite, init, marginalization_policy,
    triangulation,
};
use crate::frontend::FeatureFrame;
use crate::geometry::Pose;
use crate::problem::{Linearization, SolverSummary, solve_keeping_linearization_in};

/// What one window solve produced, for the frame's [`Estimate`].
struct Solved {
    landmarks: usize,
    newest_observations: usize,
    summary: SolverSummary,
    marginalization_s: f64,
    covariance: Option<DMatrix<f64>>,
    relative_pose: Option<RelativePose>,
    td_sigma_s: Option<f64>,
}

impl Estimator {
    /// Processes one frame at IMU time `t_ns` (its camera stamp plus the time offset).
    pub(super) fn process(&mut self, frame: FeatureFrame, t_ns: i64) -> Estimate {
        let start = Instant::now();
        let stamp_ns = frame.t_ns;
        let seq = self.next_seq;
        self.next_seq += 1;
        let uses_imu = self.config.suite.uses_imu();

        // 1. State prediction.
        let wf = self.predict_state(seq, t_ns, uses_imu);
        let rest = self.detect_rest(&frame, &wf);
        self.last_frame_t = Some(t_ns);
        // The predicted state, without its IMU interval (for the health check and the estimate
        // of a frame whose solve fails it).
        let predicted = WindowFrame {
            seq,
            t_ns,
            pose: wf.pose,
            v: wf.v,
            ba: wf.ba,
            bg: wf.bg,
            preint: None,
        };

        // 2. Observations.
        let continued = self.add_observations(&frame, seq, wf, rest);

        // 3. Keyframe decision about the second-newest frame.
        let keyframe = self.second_newest_is_keyframe(&frame, continued);

        // 4. Initialization: a window not yet aligned with gravity aligns now, or waits.
        let Some(was_tracking) = self.initialize_or_wait(keyframe, uses_imu) else {
            let newest = self.window.frames.back().expect("just pushed").clone();
            return self.estimate(&newest, stamp_ns, keyframe, start, None);
        };

        // 5. Solve the window.
        let imu_active = uses_imu && self.status == Status::Tracking;
        self.prepare_solve(keyframe, imu_active, t_ns);
        let mut built = self.window.build(&self.problem_settings(), imu_active);
        let (summary, linearization) = solve_keeping_linearization_in(
            &mut built.problem,
            &self.config.solver,
            &mut self.workspace,
        );
        self.window.write_back(&built, &self.config);

        // 6. Judge the solve: a failed one resets to the last good state.
        if let Some(reason) =
            self.judge_solve(&built, &summary, &predicted, imu_active, was_tracking)
        {
            self.reset(t_ns, reason);
            return self.estimate(&predicted, stamp_ns, keyframe, start, None);
        }

        // 7. What the solve gives: calibration released, the newest covariance, fixes for the
        // GNSS alignment.
        let td_held = self.window.calibration.td == Gate::Held;
        let free = self.release_calibration(t_ns, &built, linearization.as_ref(), imu_active);
        let (covariance, relative_pose, td_sigma_s) =
            self.newest_covariance(&built, linearization.as_ref());
        if let Some(linearization) = linearization {
            self.workspace.recycle(linearization);
        }
        // The time offset's σ: while the solve held it, what the data alone give (σ if free);
        // the hold's own σ says nothing about how well the offset is known.
        let td_sigma_s = if td_held {
            free.filter(|_| covariance.is_some()).map(|f| f.td.sigma)
        } else {
            td_sigma_s
        };
        self.collect_alignment_fixes(imu_active, t_ns);

        // 8. Slide: marginalize or drop a frame, reject outliers, judge the rejections.
        let landmarks = built.landmarks.len() + built.points.len();
        let newest_observations = self.window.newest_observations(&built);
        // The newest frame's state and (not yet merged) IMU interval, as solved.
        let newest = self.window.frames.back().expect("just pushed").clone();
        if self.status == Status::Tracking
            && let Some(h) = self.history.as_mut().filter(|h| h.initial_prior.is_none())
        {
            // The prior the window began tracking with (before anything slid into it).
            h.initial_prior = self.window.prior.clone();
        }
        let marg_start = Instant::now();
        self.slide(&built, keyframe, imu_active, t_ns);
        let marginalization_s = marg_start.elapsed().as_secs_f64();
        let (checked, rejected) = triangulation::reject_outliers(&mut self.window, &self.config);
        self.window.drop_unused_points();
        let rejection = self.rejections.push(checked, rejected, &self.config.health);
        if was_tracking && let Some(reason) = rejection {
            self.reset(t_ns, reason);
            return self.estimate(&predicted, stamp_ns, keyframe, start, None);
        }

        // 9. The frame's outcome.
        if !uses_imu {
            self.status = Status::Tracking;
        }
        if self.status == Status::Tracking {
            self.last_good = Some(newest.clone());
            if let Some(h) = &mut self.history {
                h.frames.push(newest.clone());
            }
        }
        let solved = Solved {
            landmarks,
            newest_observations,
            summary,
            marginalization_s,
            covariance,
            relative_pose,
            td_sigma_s,
        };
        self.estimate(&newest, stamp_ns, keyframe, start, Some(solved))
    }

    /// Step 1: the new frame's state — a known start, a gravity-aligned first pose, the IMU's
    /// prediction from the newest frame once tracking, else a constant-velocity guess (also
    /// across an IMU gap, which the window then joins by vision only).
    fn predict_state(&mut self, seq: u64, t_ns: i64, uses_imu: bool) -> WindowFrame {
        let mut wf = match self.window.frames.back() {
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
                    let recent = self.imu.recent(t_ns, 20);
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
                    self.imu
                        .take_interval(last.t_ns, t_ns, last.ba, last.bg, self.config.imu_noise)
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
        if uses_imu && wf.preint.is_none() && !self.window.frames.is_empty() {
            // IMU gap: the window joins this frame by vision only. Predict at constant velocity
            // and take the velocity from that motion (the IMU interval after the gap starts
            // from it).
            let last = self.window.frames.back().expect("non-empty").clone();
            wf.pose = self.constant_velocity_guess(&last, t_ns);
            let dt = (t_ns - last.t_ns) as f64 * 1e-9;
            if dt > 0.0 {
                wf.v = (wf.pose.p - last.pose.p) / dt;
            }
        }
        wf
    }

    /// Step 2: the frame's observations join the tracks and the frame joins the window (with
    /// its rest interval, if it was detected at rest). Returns how many tracks it continued.
    fn add_observations(
        &mut self,
        frame: &FeatureFrame,
        seq: u64,
        wf: WindowFrame,
        rest: Option<super::stationary::Rest>,
    ) -> usize {
        let observations = self.observations(frame, seq);
        if let Some(h) = &mut self.history {
            h.observations.push((seq, observations.clone()));
        }
        let continued = self.window.features.add_frame(observations);
        self.window.frames.push_back(wf);
        if let Some(rest) = rest {
            self.window.rest.insert(seq, rest);
        }
        continued
    }

    /// Step 4: the initial prior once the start is known, the initializing window trimmed to
    /// spread frames, tracks triangulated, and the IMU alignment tried when enough frames are
    /// in. Returns whether the estimator was tracking before this frame, or `None` when a
    /// monocular window still waits for its structure from motion (nothing to solve).
    fn initialize_or_wait(&mut self, keyframe: bool, uses_imu: bool) -> Option<bool> {
        if self.pending_bias_prior {
            self.pending_bias_prior = false;
            self.window.prior = init::initial_prior(&self.window.frames[0], &self.config);
        }
        let mono_cam = self.mono_init_camera();
        let mono = mono_cam.is_some();
        if !mono && !keyframe && self.window.frames.len() >= 3 && self.init_spacing_s().is_some() {
            // A stereo window waiting for the alignment keeps only frames spread over
            // `stereo_init_window_s`; the others leave before anything is solved.
            self.window.remove_second_newest();
        }
        // The prediction is comparable with the solution only if the world did not change
        // (initialization rotates and, for mono, rescales it).
        let was_tracking = self.status == Status::Tracking;
        if !(mono && self.status == Status::Initializing) {
            triangulation::triangulate_tracks(&mut self.window, &self.config, &self.focal);
        }
        // Mono+IMU tries its (costly) structure from motion only when a keyframe arrives.
        if uses_imu
            && self.status == Status::Initializing
            && self.window.frames.len() >= self.config.init_frames
            && (keyframe || !mono)
        {
            let initialized = if let Some(cam) = mono_cam {
                init::initialize_mono_inertial(&mut self.window, &self.config, &self.focal, cam)
                    .is_ok()
            } else {
                init::initialize_stereo_inertial(&mut self.window, &self.config)
            };
            if initialized {
                self.status = Status::Tracking;
                // The solves before the alignment judged a window without the IMU (a stereo
                // window waiting for it, a mono one before its structure from motion): the
                // tracking window's rejections count from here.
                self.rejections.clear();
                if mono {
                    triangulation::triangulate_tracks(&mut self.window, &self.config, &self.focal);
                }
            }
        }
        if mono && self.status == Status::Initializing {
            // Monocular frames have no depth before the structure from motion succeeds:
            // nothing to solve. A non-keyframe leaves at once (the keyframes stay spread over
            // `mono_init_window_s`), the oldest keyframe once the window is full.
            if !keyframe && self.window.frames.len() >= 3 {
                self.window.remove_second_newest();
            } else if self.window.frames.len() > self.config.window_size {
                self.window.remove_oldest(false, &self.config);
            }
            return None;
        }
        Some(was_tracking)
    }

    /// Step 5, before the solve: live tracks of a leaving keyframe become persistent points,
    /// the calibration gates are set, GNSS fixes screened (a moved receiver frame drops the
    /// alignment), drifted states relinearized, image velocities predicted for the time offset.
    fn prepare_solve(&mut self, keyframe: bool, imu_active: bool, t_ns: i64) {
        // Tracking time: the calibration warm-up and the start-up window count from here.
        if self.status == Status::Tracking {
            self.tracking_since.get_or_insert(t_ns);
        } else {
            self.tracking_since = None;
        }
        if self.leaving(keyframe, t_ns, imu_active) == Some(Leaving::Oldest) {
            // The oldest keyframe leaves after this solve.
            self.promote_leaving_tracks(imu_active);
        }
        // Calibration: held at the configured values until the window determines it (see
        // `calibration_gates.rs`).
        self.configure_calibration();
        let window = &mut self.window;
        if imu_active && window.aiding.screen_fixes(&window.frames, &self.config) {
            // The receiver's frame moved: the alignment leaves the prior and starts again.
            let built = self.window.build(&self.problem_settings(), imu_active);
            self.window.prior =
                marginalization_policy::prior_without_alignment(&self.window, &built);
            self.window.aiding.forget_alignment();
            self.events.push(Event {
                t_ns,
                kind: EventKind::GnssAlignmentDropped,
            });
        }
        if imu_active && self.config.first_estimate_jacobians {
            let points = if self.config.first_estimate_points {
                self.config.point_relinearize_fraction
            } else {
                f64::INFINITY
            };
            self.points_relinearized += self.window.relinearize_drifted_states(
                points,
                self.config.frame_relinearize_fraction,
                self.config.release_drifted_points,
            );
        }
        // The image velocities the time-offset model shifts along: needed when `td` moves, and
        // for rolling-shutter rows, which are shifted to their frame's time even with `td` fixed.
        if imu_active && (self.window.calibration.td_variable() || self.models_rolling_shutter()) {
            self.window.predict_image_velocities();
        }
    }

    /// Step 6: the health checks of the solve. The frame that initialized is judged too (a
    /// wrong initialization shows in its first solve: implausible biases, IMU factors no state
    /// explains), but not against its prediction, which lives in the world frame before the
    /// initialization. A failure counts only once the estimator tracks.
    fn judge_solve(
        &mut self,
        built: &WindowProblem,
        summary: &SolverSummary,
        predicted: &WindowFrame,
        imu_active: bool,
        was_tracking: bool,
    ) -> Option<FailureReason> {
        let just_initialized = imu_active && !was_tracking;
        let reference = match self.window.frames.back() {
            Some(newest) if just_initialized => newest.pose,
            _ => predicted.pose,
        };
        let failure = self.window_failure(built, summary, &reference, imu_active);
        failure.filter(|_| was_tracking || just_initialized)
    }

    /// Step 7: the newest state's marginal covariance and the relative pose over
    /// `relative_pose_interval_s`, from the solve's kept linearization (when asked for).
    fn newest_covariance(
        &self,
        built: &WindowProblem,
        linearization: Option<&Linearization>,
    ) -> (Option<DMatrix<f64>>, Option<RelativePose>, Option<f64>) {
        match linearization {
            Some(lin) if self.config.compute_covariance => {
                let frames: Vec<&WindowFrame> = self.window.frames.iter().collect();
                let interval_s = self.config.relative_pose_interval_s;
                window_information::newest_covariance(built, lin, &frames, interval_s)
                    .map_or((None, None, None), |n| {
                        (Some(n.covariance), n.relative_pose, n.td_sigma_s)
                    })
            }
            _ => (None, None, None),
        }
    }

    /// Step 7: GNSS fixes collected for the alignment; an event when it is made.
    fn collect_alignment_fixes(&mut self, imu_active: bool, t_ns: i64) {
        let window = &mut self.window;
        if imu_active
            && window
                .aiding
                .collect_for_alignment(&window.frames, &self.config)
        {
            self.events.push(Event {
                t_ns,
                kind: EventKind::GnssAligned,
            });
        }
    }

    /// Whether the window shifts observations by their rolling-shutter row times.
    fn models_rolling_shutter(&self) -> bool {
        self.config.model_rolling_shutter
            && self
                .config
                .cameras
                .iter()
                .any(|c| c.rolling_shutter.is_rolling())
    }

    /// The camera a monocular initialization uses: the mono+IMU suite's camera, or the one
    /// camera still delivering when a stereo+IMU suite lost the other before it initialized
    /// (stereo initialization needs both). `None` once initialized.
    pub(super) fn mono_init_camera(&self) -> Option<usize> {
        if self.status != Status::Initializing {
            return None;
        }
        match (self.config.suite, self.live_suite()) {
            (Suite::MonoImu, _) => Some(0),
            (Suite::StereoImu, LiveSuite::MonoImu { cam }) => Some(cam),
            _ => None,
        }
    }

    /// The estimate of the newest frame (camera stamp `stamp_ns`) after `process` (`solved`:
    /// what the window solve and marginalization produced, `None` when nothing was solved).
    fn estimate(
        &self,
        newest: &WindowFrame,
        stamp_ns: i64,
        keyframe: bool,
        start: Instant,
        solved: Option<Solved>,
    ) -> Estimate {
        let newest_observations = solved.as_ref().map_or(0, |s| s.newest_observations);
        Estimate {
            t_ns: newest.t_ns,
            stamp_ns,
            T_w_b: newest.pose,
            v_w: newest.v,
            ba: newest.ba,
            bg: newest.bg,
            td_s: self.window.td,
            T_b_c: self.window.extrinsics.clone(),
            status: match self.status {
                Status::Tracking if newest_observations < self.config.min_tracking_observations => {
                    Status::Degraded
                }
                s => s,
            },
            live: self.live_suite(),
            keyframe,
            landmarks: solved.as_ref().map_or(0, |s| s.landmarks),
            newest_observations,
            solver: solved.as_ref().map(|s| s.summary),
            backend_s: start.elapsed().as_secs_f64(),
            solve_s: solved
                .as_ref()
                .map_or(0.0, |s| s.summary.time.as_secs_f64()),
            marginalization_s: solved.as_ref().map_or(0.0, |s| s.marginalization_s),
            at_rest: self.window.rest.contains_key(&newest.seq),
            relative_pose: solved.as_ref().and_then(|s| s.relative_pose.clone()),
            gnss_alignment: self.window.aiding.alignment(),
            td_sigma_s: solved.as_ref().and_then(|s| s.td_sigma_s),
            covariance: solved.and_then(|s| s.covariance),
        }
    }

    fn constant_velocity_guess(&self, last: &WindowFrame, t_ns: i64) -> Pose {
        let n = self.window.frames.len();
        if n < 2 {
            return last.pose;
        }
        let prev = &self.window.frames[n - 2];
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
}
