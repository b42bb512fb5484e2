//! The full-batch references (`record_history`): every recorded frame, or the window's own
//! keyframes, solved at once without marginalization, on the measurements the window had; and
//! the full-information filter, the same batch with the window's initial prior solved while
//! the run goes on.

use super::features::Observation;
use super::frame::{BlockRef, Prior, WindowFrame};
use super::triangulation;
use super::window::Window;
use super::window_information::{RelativePose, newest_covariance};
use super::{Estimator, Status};
use crate::geometry::Pose;
use crate::problem::{SolverOptions, SolverSummary, solve_keeping_linearization};
use nalgebra::{DMatrix, Vector3};

/// What the estimator keeps, with `record_history`, for the batch solves.
#[derive(Clone, Debug, Default)]
pub(super) struct History {
    /// Every frame as it was solved as the newest while tracking.
    pub(super) frames: Vec<WindowFrame>,
    /// The keyframes as they were marginalized while tracking (their IMU intervals joined
    /// across the frames dropped between them).
    pub(super) keyframes: Vec<WindowFrame>,
    /// Per frame seq: the observations (feature id, observation).
    pub(super) observations: Vec<(u64, Vec<(u64, Observation)>)>,
    /// The window's prior when it began tracking (the initial gauge and bias prior).
    pub(super) initial_prior: Option<Prior>,
}

/// The full-information filter's estimate of the newest frame
/// ([`Estimator::filter_reference`]).
#[derive(Clone, Debug)]
pub struct FilterEstimate {
    /// The newest frame's time (ns, IMU clock).
    pub t_ns: i64,
    /// Its pose as the batch over everything so far solves it.
    pub pose: Pose,
    /// Its velocity (world frame, m/s), as the batch solves it.
    pub v_w: Vector3<f64>,
    /// Its accelerometer bias (m/s²).
    pub ba: Vector3<f64>,
    /// Its gyroscope bias (rad/s).
    pub bg: Vector3<f64>,
    /// With `EstimatorConfig::compute_covariance`: the batch's marginal covariance of the newest
    /// state, in the layout of the window's (`Estimate::covariance`), from the solve's last
    /// linearization.
    pub covariance: Option<DMatrix<f64>>,
    /// With `compute_covariance`: the newest pose relative to the batch frame closest to
    /// `relative_pose_interval_s` before it, as `Estimate::relative_pose`.
    pub relative_pose: Option<RelativePose>,
    /// Frames in the batch (keyframes marginalized so far, then the window's).
    pub frames: usize,
    /// The solve's statistics.
    pub summary: SolverSummary,
}

/// The batch's marginal covariance of its newest state and its relative pose.
type BatchUncertainty = (DMatrix<f64>, Option<RelativePose>);

impl Estimator {
    /// Solves all recorded frames at once without marginalization (the "physical limit"
    /// reference), starting from the causal estimates. Requires `record_history`. Returns the
    /// smoothed estimates `(t_ns, T_w_b)` of every frame, or `None` without history.
    pub fn batch_solve(&self, options: &SolverOptions) -> Option<Vec<(i64, Pose)>> {
        let history = self.history.as_ref()?;
        Some(self.solve_batch(history, history.frames.iter(), options).0)
    }

    /// The full batch over the window's own states: every keyframe marginalized while
    /// tracking, then the frames in the window now, with the observations each had and the IMU
    /// intervals that joined them, solved at once without marginalization, starting from the
    /// estimates they had as they left the window. What the window would have estimated had it
    /// kept everything: the reference for what marginalization loses. Requires
    /// `record_history`; `None` without history. Also returns the solve's statistics.
    pub fn batch_solve_keyframes(
        &self,
        options: &SolverOptions,
    ) -> Option<(Vec<(i64, Pose)>, SolverSummary)> {
        let history = self.history.as_ref()?;
        let tracking = self.status == Status::Tracking;
        let window = self.window.frames.iter().filter(|_| tracking);
        // A run that never tracked has nothing to solve.
        if history.keyframes.is_empty() && !tracking {
            return None;
        }
        Some(self.solve_batch(history, history.keyframes.iter().chain(window), options))
    }

    /// The full-information filter at this instant: every keyframe marginalized so far and the
    /// frames in the window now, with every observation and IMU interval they had and the
    /// window's initial prior, solved at once without marginalization or a fixed lag (starting
    /// from the estimates the frames had as they left the window). With exact marginalization
    /// of a linear-Gaussian problem its newest state would be the window's; the gap is what
    /// linearizing early, the point budget and dropped tracks cost. Requires `record_history`
    /// and a tracking estimator whose initial prior's frame is among the keyframes; `None`
    /// otherwise.
    pub fn filter_reference(&self, options: &SolverOptions) -> Option<FilterEstimate> {
        let history = self.history.as_ref()?;
        if self.status != Status::Tracking {
            return None;
        }
        let prior = history.initial_prior.clone()?;
        let frames: Vec<&WindowFrame> = history
            .keyframes
            .iter()
            .chain(self.window.frames.iter())
            .collect();
        let anchored = prior.1.iter().all(|r| match r {
            BlockRef::Pose(seq) | BlockRef::SpeedBias(seq) => frames.iter().any(|f| f.seq == *seq),
            _ => false,
        });
        if !anchored {
            return None;
        }
        let count = frames.len();
        let (window, summary, uncertainty) =
            self.solve_batch_window(history, frames.into_iter(), Some(prior), options);
        let newest = window.frames.back()?;
        let (covariance, relative_pose) = uncertainty.map_or((None, None), |u| (Some(u.0), u.1));
        Some(FilterEstimate {
            t_ns: newest.t_ns,
            pose: newest.pose,
            v_w: newest.v,
            ba: newest.ba,
            bg: newest.bg,
            covariance,
            relative_pose,
            frames: count,
            summary,
        })
    }

    fn solve_batch<'a>(
        &self,
        history: &History,
        frames: impl Iterator<Item = &'a WindowFrame>,
        options: &SolverOptions,
    ) -> (Vec<(i64, Pose)>, SolverSummary) {
        let (window, summary, _) = self.solve_batch_window(history, frames, None, options);
        let poses = window.frames.iter().map(|f| (f.t_ns, f.pose)).collect();
        (poses, summary)
    }

    /// The batch over `frames` (chained by their own IMU intervals) with `prior`, solved: the
    /// window it built, at the solution, the solve's statistics, and with `compute_covariance`
    /// the newest state's marginal covariance and relative pose.
    fn solve_batch_window<'a>(
        &self,
        history: &History,
        frames: impl Iterator<Item = &'a WindowFrame>,
        prior: Option<Prior>,
        options: &SolverOptions,
    ) -> (Window, SolverSummary, Option<BatchUncertainty>) {
        let uses_imu = self.config.suite.uses_imu();
        // A window over the given frames, chained by their own IMU intervals, with today's
        // extrinsics and time offset, and no prior. Extrinsics the window estimates online are
        // estimated here too, under the same gates and priors: held constant, a calibration
        // that is off makes the filter sure of what it is not (its relative-pose NEES read
        // 31–40 against a band to 10.5 on the realistic V1_01 stand-in, 3 seeds × 20 s; 11.3
        // estimated). The time offset stays today's constant, as before.
        let mut window = Window::new(self.window.extrinsics.clone(), self.window.td);
        window.calibration.rotation = self.window.calibration.rotation;
        window.calibration.translation = self.window.calibration.translation;
        window.prior = prior;
        for f in frames {
            let mut f = f.clone();
            if window.frames.is_empty() {
                f.preint = None;
            }
            window.frames.push_back(f);
        }
        // An interval is used only if it starts at the previous frame (not across a gap).
        let frames = &mut window.frames;
        for k in 1..frames.len() {
            let contiguous = frames[k]
                .preint
                .as_ref()
                .is_some_and(|p| p.start_ns() == frames[k - 1].t_ns);
            if !contiguous {
                frames[k].preint = None;
            }
        }
        for (seq, obs) in &history.observations {
            if window.frames.iter().any(|f| f.seq == *seq) {
                window.features.add_frame(obs.clone());
            }
        }
        triangulation::triangulate_tracks(&mut window, &self.config, &self.focal);
        let imu_active = uses_imu && self.status == Status::Tracking;
        let mut built = window.build(&self.problem_settings(), imu_active);
        let (summary, linearization) = solve_keeping_linearization(&mut built.problem, options);
        window.write_back(&built, &self.config);
        let uncertainty = linearization
            .filter(|_| self.config.compute_covariance)
            .and_then(|lin| {
                let frames: Vec<&WindowFrame> = window.frames.iter().collect();
                let interval_s = self.config.relative_pose_interval_s;
                newest_covariance(&built, &lin, &frames, interval_s)
            })
            .map(|u| (u.covariance, u.relative_pose));
        (window, summary, uncertainty)
    }
}
