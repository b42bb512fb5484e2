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

    /// Slides a full window after the solve `built`: the oldest frame leaves into the prior
    /// when the second-newest is a keyframe, the second-newest leaves otherwise (its IMU
    /// interval merges into the newest's); the frame that left is finalized.
    pub(super) fn slide(
        &mut self,
        built: &WindowProblem,
        keyframe: bool,
        imu_active: bool,
        t_ns: i64,
    ) {
        let window_full = self.window.frames.len() > self.config.window_size;
        if window_full {
            let had_prior = self.window.prior.is_some();
            let removed = if keyframe {
                self.window.prior =
                    marginalization_policy::prior_without_oldest(&self.window, built, imu_active);
                // With a prior, the oldest frame's anchored landmarks and all their observations
                // are now in it, so by default those tracks end here; re-anchoring and re-using
                // the observations (VINS-Fusion's choice, `reuse_marginalized_tracks`) counts
                // them twice. Without a prior (vision only, or during initialization) they are
                // re-anchored in their next left view.
                let in_prior = imu_active
                    && self.window.prior.is_some()
                    && !self.config.reuse_marginalized_tracks;
                self.window.remove_oldest(in_prior, &self.config)
            } else {
                self.window.prior =
                    marginalization_policy::prior_without_second_newest(&self.window, built);
                self.window.remove_second_newest()
            };
            if self.status == Status::Tracking {
                self.finalized.push((removed.t_ns, removed.pose));
                if let Some(h) = self.history.as_mut().filter(|_| keyframe) {
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
}
