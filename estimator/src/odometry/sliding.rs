//! Sliding the window: which frame leaves after a solve (VINS-Fusion's keyframe rule) and the
//! leaving itself (the prior it leaves behind, the estimate it finalizes).

use super::events::{Event, EventKind};
use super::window_problem::WindowProblem;
use super::{Estimator, Status, marginalization_policy};
use crate::frontend::FeatureFrame;

impl Estimator {
    /// Whether the second-newest frame is a keyframe (stays when the window slides), given
    /// the newest frame and how many of its observations continue a track: average parallax
    /// against the last keyframe, too few tracked features, or (a monocular window waiting for
    /// initialization) time spacing.
    pub(super) fn second_newest_is_keyframe(&self, frame: &FeatureFrame, continued: usize) -> bool {
        let n = self.window.frames.len();
        if let Some(spacing_s) = self.init_spacing_s().filter(|_| n >= 3) {
            // A window waiting for the visual-inertial alignment spreads its frames evenly
            // over a time span, not a frame count (see `init_spacing_s`).
            let (a, b) = (&self.window.frames[n - 3], &self.window.frames[n - 2]);
            (b.t_ns - a.t_ns) as f64 * 1e-9 >= spacing_s
        } else if n < 3 || continued < self.config.keyframe_min_tracked {
            true
        } else {
            let a = self.window.frames[n - 3].seq;
            let b = self.window.frames[n - 2].seq;
            // Parallax in the lowest camera that delivered this frame (the left one while it
            // works).
            let cam = frame
                .cameras
                .iter()
                .filter(|c| c.cam_id < self.config.cameras.len() && !c.features.is_empty())
                .map(|c| c.cam_id)
                .min()
                .unwrap_or(0);
            match self.window.features.parallax(a, b, cam) {
                Some(p) => p * self.focal[0] >= self.config.keyframe_parallax_px,
                None => true,
            }
        }
    }

    /// While the window waits for the visual-inertial alignment, the least time (s) between
    /// the frames it keeps. Monocular: `mono_init_window_s / init_frames` (the alignment needs
    /// the acceleration to change within the window, or a constant acceleration passes for a
    /// tilt of gravity and the scale is lost). Stereo: `stereo_init_window_s / init_frames`
    /// (gravity from a short window's poses is noisy), where a rounding margin of 1 µs keeps
    /// a rate whose period equals the spacing from dropping frames. `None` once initialized
    /// and without an IMU.
    pub(super) fn init_spacing_s(&self) -> Option<f64> {
        let frames = self.config.init_frames as f64;
        if self.mono_init_camera().is_some() {
            Some(self.config.mono_init_window_s / frames)
        } else if self.status == Status::Initializing
            && self.config.suite.uses_imu()
            && self.config.stereo_init_window_s > 0.0
        {
            Some(self.config.stereo_init_window_s / frames - 1e-6)
        } else {
            None
        }
    }

    /// The keyframes the window keeps at frame time `t_ns`: `startup_window_size` for the
    /// first `startup_window_s` of tracking with the IMU, `window_size` otherwise.
    fn window_capacity(&self, t_ns: i64, imu_active: bool) -> usize {
        let c = &self.config;
        let startup_ns = (c.startup_window_s * 1e9).round() as i64;
        let in_startup = imu_active
            && self.status == Status::Tracking
            && self
                .tracking_since
                .is_some_and(|t0| t_ns.saturating_sub(t0) < startup_ns);
        if in_startup {
            c.startup_window_size.max(c.window_size)
        } else {
            c.window_size
        }
    }

    /// Which frame leaves the window after the solve of the frame at `t_ns` (`keyframe`: the
    /// second-newest is one): none while the window has room; the oldest when the
    /// second-newest is a keyframe, or when the window holds more than a full window (the
    /// start-up phase just ended: it shrinks by one keyframe a frame); the second-newest
    /// otherwise.
    pub(super) fn leaving(&self, keyframe: bool, t_ns: i64, imu_active: bool) -> Option<Leaving> {
        let (len, capacity) = (
            self.window.frames.len(),
            self.window_capacity(t_ns, imu_active),
        );
        if len <= capacity {
            None
        } else if keyframe || len > capacity + 1 {
            Some(Leaving::Oldest)
        } else {
            Some(Leaving::SecondNewest)
        }
    }

    /// Slides the window after the solve `built` (see [`Self::leaving`]): the oldest frame
    /// leaves into the prior, or the second-newest leaves (its IMU interval merges into the
    /// newest's); the frame that left is finalized. A window past a full one (the start-up
    /// phase just ended) loses a second frame by the same rule, from the window rebuilt
    /// without the first, so that it shrinks by one frame per frame.
    pub(super) fn slide(
        &mut self,
        built: &WindowProblem,
        keyframe: bool,
        imu_active: bool,
        t_ns: i64,
    ) {
        let Some(leaving) = self.leaving(keyframe, t_ns, imu_active) else {
            return;
        };
        self.remove_frame(built, leaving, imu_active, t_ns);
        if let Some(leaving) = self.leaving(keyframe, t_ns, imu_active) {
            if leaving == Leaving::Oldest {
                self.promote_leaving_tracks(imu_active);
            }
            let rebuilt = self.window.build(&self.problem_settings(), imu_active);
            self.remove_frame(&rebuilt, leaving, imu_active, t_ns);
        }
    }

    /// Live tracks of the oldest keyframe continue as persistent points instead of ending with
    /// it, when it is about to leave into a prior (with the IMU, by default).
    pub(super) fn promote_leaving_tracks(&mut self, imu_active: bool) {
        if imu_active && self.window.prior.is_some() && !self.config.reuse_marginalized_tracks {
            self.window.promote_to_points(&self.config);
        }
    }

    /// Removes the frame `leaving` names from the window solved as `built`, leaving its
    /// information in the prior, and finalizes it.
    fn remove_frame(
        &mut self,
        built: &WindowProblem,
        leaving: Leaving,
        imu_active: bool,
        t_ns: i64,
    ) {
        let had_prior = self.window.prior.is_some();
        let removed = match leaving {
            Leaving::Oldest => {
                let lost = if imu_active && self.config.marginalize_lost_points {
                    marginalization_policy::lost_points(&self.window, built)
                } else {
                    Vec::new()
                };
                self.window.prior = marginalization_policy::prior_without_oldest(
                    &self.window,
                    built,
                    imu_active,
                    &lost,
                );
                if self.window.prior.is_some() {
                    // Their observations are in the prior now.
                    self.window.forget_points(&lost);
                }
                // With a prior, the oldest frame's anchored landmarks and all their observations
                // are now in it, so by default those tracks end here; re-anchoring and re-using
                // the observations (VINS-Fusion's choice, `reuse_marginalized_tracks`) counts
                // them twice. Without a prior (vision only, or during initialization) they are
                // re-anchored in their next left view.
                let in_prior = imu_active
                    && self.window.prior.is_some()
                    && !self.config.reuse_marginalized_tracks;
                self.window.remove_oldest(in_prior, &self.config)
            }
            Leaving::SecondNewest => {
                self.window.prior =
                    marginalization_policy::prior_without_second_newest(&self.window, built);
                self.window.remove_second_newest()
            }
        };
        if self.status == Status::Tracking {
            self.finalized.push((removed.t_ns, removed.pose));
            if let Some(h) = self.history.as_mut().filter(|_| leaving == Leaving::Oldest) {
                h.keyframes.push(removed.clone());
            }
        }
        if had_prior && imu_active && self.window.prior.is_none() {
            self.events.push(Event {
                t_ns,
                kind: EventKind::PriorDropped,
            });
        }
    }
}

/// The frame that leaves a full window ([`Estimator::leaving`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Leaving {
    /// The oldest keyframe, marginalized into the prior.
    Oldest,
    /// The second-newest frame, not a keyframe: dropped, its IMU interval merged forward.
    SecondNewest,
}
