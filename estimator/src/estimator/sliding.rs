//! Sliding the window: which frame leaves after a solve (VINS-Fusion's keyframe rule) and the
//! leaving itself (the prior it leaves behind, the estimate it finalizes).

use super::events::{Event, EventKind};
use super::window::Built;
use super::{Estimator, Status, marginalization};
use crate::frontend::FeatureFrame;

impl Estimator {
    /// Whether the second-newest frame is a keyframe (stays when the window slides), given
    /// the newest frame and how many of its observations continue a track: average parallax
    /// against the last keyframe, too few tracked features, or (a monocular window waiting for
    /// initialization) time spacing.
    pub(super) fn second_newest_is_keyframe(&self, frame: &FeatureFrame, continued: usize) -> bool {
        let n = self.window.frames.len();
        let mono_waiting = self.mono_init_camera().is_some();
        if mono_waiting && n >= 3 {
            // A monocular window waiting for initialization spreads its keyframes evenly over
            // `mono_init_window_s`: the alignment needs the acceleration to change within the
            // window, or a constant acceleration passes for a tilt of gravity and the scale is
            // lost.
            let (a, b) = (&self.window.frames[n - 3], &self.window.frames[n - 2]);
            let spacing = self.config.mono_init_window_s / self.config.init_frames as f64;
            (b.t_ns - a.t_ns) as f64 * 1e-9 >= spacing
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

    /// Slides a full window after the solve `built`: the oldest frame leaves into the prior
    /// when the second-newest is a keyframe, the second-newest leaves otherwise (its IMU
    /// interval merges into the newest's); the frame that left is finalized.
    pub(super) fn slide(&mut self, built: &Built, keyframe: bool, imu_active: bool, t_ns: i64) {
        let window_full = self.window.frames.len() > self.config.window_size;
        if window_full {
            let had_prior = self.window.prior.is_some();
            let removed = if keyframe {
                self.window.prior =
                    marginalization::prior_without_oldest(&self.window, built, imu_active);
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
                    marginalization::prior_without_second_newest(&self.window, built);
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
