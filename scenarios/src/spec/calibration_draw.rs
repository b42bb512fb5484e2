//! Calibration error drawn per seed (`[rig.calibration_draw]`): the estimator is handed the
//! rig's calibration off by errors of the stated standard deviations, a new draw for every
//! seed, as a real rig is flown on one imperfect calibration out of the many its calibration
//! procedure could have given.
//!
//! Two parts, per axis, zero-mean Gaussian: the camera–IMU error moves the stereo pair as one
//! rigid body against the IMU (rotation about the body origin, then a translation in the body
//! frame), which is what a camera–IMU calibration gets wrong together for both cameras; the
//! stereo error moves the second camera alone against the first. The draws come from the
//! seed's own stream (`calibration`), so no other sensor's noise changes.

use estimator::EstimatorConfig;
use estimator::geometry::{Pose, so3_exp};
use nalgebra::Vector3;
use rand_distr::{Distribution, StandardNormal};

use super::schema::CalibrationDrawSpec;
use super::{Scenario, SpecError};

/// The estimator's calibration errors of one seed: `(rotation vector rad, translation m)` of
/// the pair against the IMU, then of the second camera against the first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawnCalibrationError {
    /// The pair against the IMU.
    pub camera_imu: (Vector3<f64>, Vector3<f64>),
    /// The second camera against the first.
    pub stereo: (Vector3<f64>, Vector3<f64>),
}

impl DrawnCalibrationError {
    /// The errors of `seed` at the standard deviations of `spec`.
    pub fn draw(spec: &CalibrationDrawSpec, seed: u64) -> Self {
        let mut rng = sim::rng::sensor_rng(seed, "calibration");
        let mut gauss = |sigma: f64| {
            let mut n = || -> f64 { StandardNormal.sample(&mut rng) };
            Vector3::new(n(), n(), n()) * sigma
        };
        let camera_imu = (
            gauss(spec.camera_imu_rotation_deg.to_radians()),
            gauss(spec.camera_imu_translation_m),
        );
        let stereo = (
            gauss(spec.stereo_rotation_deg.to_radians()),
            gauss(spec.stereo_translation_m),
        );
        Self { camera_imu, stereo }
    }

    /// Camera `i`'s extrinsic `T_b_c` as the estimator is given it.
    pub fn apply(&self, i: usize, t_b_c: &Pose) -> Pose {
        let r = so3_exp(&self.camera_imu.0);
        let moved = Pose::new(r * t_b_c.q, r * t_b_c.p + self.camera_imu.1);
        if i == 0 {
            return moved;
        }
        Pose::new(so3_exp(&self.stereo.0) * moved.q, moved.p + self.stereo.1)
    }
}

impl Scenario {
    /// The estimator configuration of a run at `seed`: [`Scenario::estimator_config`] with
    /// the seed's drawn calibration error applied (`rig.calibration_draw`; none: the same).
    pub fn estimator_config_at(&self, seed: u64) -> Result<EstimatorConfig, SpecError> {
        let mut cfg = self.estimator_config()?;
        if let Some(e) = self.drawn_calibration_error(seed) {
            for (i, c) in cfg.cameras.iter_mut().enumerate() {
                c.T_b_c = e.apply(i, &c.T_b_c);
            }
        }
        Ok(cfg)
    }

    /// The calibration error drawn for `seed`, when the scenario draws one.
    pub fn drawn_calibration_error(&self, seed: u64) -> Option<DrawnCalibrationError> {
        self.spec
            .rig
            .calibration_draw
            .as_ref()
            .map(|d| DrawnCalibrationError::draw(d, seed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pair_moves_as_one_body_and_the_draw_follows_the_seed() {
        let spec = CalibrationDrawSpec {
            camera_imu_rotation_deg: 0.2,
            camera_imu_translation_m: 0.003,
            stereo_rotation_deg: 0.0,
            stereo_translation_m: 0.0,
        };
        let a = DrawnCalibrationError::draw(&spec, 1);
        assert_eq!(a, DrawnCalibrationError::draw(&spec, 1));
        assert_ne!(a, DrawnCalibrationError::draw(&spec, 2));
        let c0 = Pose::new(
            so3_exp(&Vector3::new(0.1, -0.2, 1.5)),
            Vector3::new(0.0, 0.055, 0.0),
        );
        let c1 = Pose::new(c0.q, Vector3::new(0.0, -0.055, 0.0));
        let (g0, g1) = (a.apply(0, &c0), a.apply(1, &c1));
        // The stereo geometry is untouched without a stereo error: T_c0_c1 is the same.
        let rel = |x: &Pose, y: &Pose| (x.q.inverse() * y.q, x.q.inverse() * (y.p - x.p));
        let (q_true, p_true) = rel(&c0, &c1);
        let (q_drawn, p_drawn) = rel(&g0, &g1);
        assert!(q_true.angle_to(&q_drawn) < 1e-12);
        assert!((p_true - p_drawn).norm() < 1e-12);
        assert!(c0.q.angle_to(&g0.q) > 0.0);
        // Many seeds: per-axis deviation as asked (within 10 % over 2000 draws).
        let sd = (1..=2000u64)
            .map(|s| DrawnCalibrationError::draw(&spec, s).camera_imu.1.x.powi(2))
            .sum::<f64>()
            / 2000.0;
        assert!((sd.sqrt() / 0.003 - 1.0).abs() < 0.1, "{}", sd.sqrt());
    }
}
