//! The frozen-camera monitor. A camera whose driver keeps delivering its last image (a stuck
//! sensor, a frozen capture pipeline) yields tracks that stand still while the body turns; fed
//! to the window they claim the body is static against the IMU. A camera is frozen when the
//! median displacement of the features it shares with its previous frame is below
//! [`STILL_PX`] while the gyroscope's rotation since then predicts at least
//! [`MIN_PREDICTED_PX`] of image motion; it stays frozen (its features are dropped, the live
//! suite loses it) until its features move again. Only with an IMU: without one, a frozen image
//! cannot be told from a still platform.

use std::collections::BTreeMap;

use nalgebra::{Vector2, Vector3};

use super::Estimator;
use crate::frontend::FeatureFrame;

/// Median displacement (px) below which a camera's shared features stand still. Pixel noise
/// alone moves a real feature by more than this (a tracker on a real image ~0.05–0.1 px,
/// the simulator's 1 px σ by ~1.2 px), while a repeated image gives 0 exactly at feature level
/// and a few hundredths of a pixel through KLT's convergence tolerance.
pub const STILL_PX: f64 = 0.02;

/// Image motion (px, gyro rotation angle × focal length) that the features must show before
/// standing still counts as frozen: a platform that barely turns may have still features.
pub const MIN_PREDICTED_PX: f64 = 1.0;

/// Fewest shared features for a decision.
pub const MIN_SHARED: usize = 10;

/// A camera's features by id (px).
type Features = BTreeMap<u64, Vector2<f64>>;

/// Per camera: the previous frame's features and stamp, and whether the camera is frozen.
#[derive(Clone, Debug, Default)]
pub(super) struct FrozenMonitor {
    last: [Option<(i64, Features)>; 2],
    /// Camera frozen now.
    pub frozen: [bool; 2],
}

impl FrozenMonitor {
    /// Updates camera `cam` with its features at `t_ns`; `predicted_px` is the image motion
    /// the gyroscope predicts since the camera's previous frame (`None` without IMU data).
    /// Returns whether the camera is frozen now.
    fn update(
        &mut self,
        cam: usize,
        t_ns: i64,
        features: Features,
        predicted_px: impl FnOnce(i64) -> Option<f64>,
    ) -> bool {
        let previous = self.last[cam].replace((t_ns, features));
        let (Some((t_prev, prev)), Some((_, now))) = (previous, self.last[cam].as_ref()) else {
            return false;
        };
        let mut moved: Vec<f64> = now
            .iter()
            .filter_map(|(id, uv)| prev.get(id).map(|p| (uv - p).norm()))
            .collect();
        if moved.len() < MIN_SHARED {
            // Too little to judge: a frozen camera keeps its state, a live one stays live.
            return self.frozen[cam];
        }
        moved.sort_by(f64::total_cmp);
        let still = moved[moved.len() / 2] < STILL_PX;
        self.frozen[cam] = if self.frozen[cam] {
            still
        } else {
            still && predicted_px(t_prev).is_some_and(|px| px >= MIN_PREDICTED_PX)
        };
        self.frozen[cam]
    }
}

impl Estimator {
    /// Drops the features of frozen cameras from `frame` (IMU suites only; see the module
    /// documentation); `t_imu` is its time in the IMU clock.
    pub(super) fn drop_frozen(&mut self, frame: &mut FeatureFrame, t_imu: i64) {
        if !self.config.suite.uses_imu() {
            return;
        }
        for cf in &mut frame.cameras {
            let c = cf.cam_id;
            if c >= 2 || c >= self.focal.len() {
                continue;
            }
            let features = cf.features.iter().map(|o| (o.feature_id, o.uv)).collect();
            let focal = self.focal[c];
            let imu = &self.imu;
            let predicted = |t_prev: i64| {
                // Gyro rotation over (t_prev, t_imu] from the samples at hand.
                let samples: Vec<_> = imu
                    .recent(t_imu, usize::MAX)
                    .into_iter()
                    .take_while(|s| s.t_ns > t_prev)
                    .collect();
                let mut angle = Vector3::zeros();
                let mut t_next = t_imu;
                for s in &samples {
                    angle += s.gyro * ((t_next - s.t_ns.max(t_prev)) as f64 * 1e-9);
                    t_next = s.t_ns;
                }
                (!samples.is_empty()).then(|| angle.norm() * focal)
            };
            if self.frozen.update(c, t_imu, features, predicted) {
                cf.features.clear();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` features on a grid, shifted by `dx` px.
    fn features(n: u64, dx: f64) -> Features {
        (0..n)
            .map(|i| (i, Vector2::new(50.0 + 30.0 * i as f64 + dx, 200.0)))
            .collect()
    }

    #[test]
    fn still_features_while_turning_are_frozen_until_they_move() {
        let mut m = FrozenMonitor::default();
        let turning = |_| Some(5.0);
        assert!(!m.update(0, 0, features(20, 0.0), turning));
        // The same pixels while the gyro predicts 5 px: frozen.
        assert!(m.update(0, 50, features(20, 0.0), turning));
        // Still frozen whatever the rotation, while the features stand still.
        assert!(m.update(0, 100, features(20, 0.0), |_| Some(0.0)));
        // They move: back.
        assert!(!m.update(0, 150, features(20, 3.0), turning));
        // The other camera is judged on its own.
        assert!(!m.update(1, 150, features(20, 0.0), turning));
    }

    #[test]
    fn still_features_are_not_frozen_on_a_still_platform_or_with_too_few() {
        let mut m = FrozenMonitor::default();
        m.update(0, 0, features(20, 0.0), |_| Some(0.0));
        // A platform that does not turn (0.3 px predicted) may see still features.
        assert!(!m.update(0, 50, features(20, 0.0), |_| Some(0.3)));
        // No IMU data: no decision.
        assert!(!m.update(0, 100, features(20, 0.0), |_| None));
        // Sub-threshold noise (0.05 px) is motion, not a repeated image.
        assert!(!m.update(0, 150, features(20, 0.05), |_| Some(5.0)));
        // Fewer than MIN_SHARED shared features: no decision.
        let mut m = FrozenMonitor::default();
        m.update(0, 0, features(5, 0.0), |_| Some(5.0));
        assert!(!m.update(0, 50, features(5, 0.0), |_| Some(5.0)));
    }
}
