//! The calibration priors: analytic Jacobians against central differences through the shared
//! checker, and the properties the residual must have (zero at the configured relative pose,
//! blind to a rigid motion of the whole rig).

use crate::common;

use common::{check, pose, small_rotation, vec3};
use estimator::factors::RelativePosePrior;
use estimator::geometry::Pose;
use estimator::problem::{Factor, PoseManifold};
use proptest::prelude::*;

const POSE: PoseManifold = PoseManifold;

fn residual(factor: &dyn Factor, a: &Pose, b: &Pose) -> Vec<f64> {
    let (a, b) = (a.to_array(), b.to_array());
    let mut r = vec![0.0; 6];
    assert!(factor.evaluate(&[&a, &b], &mut r, None));
    r
}

proptest! {
    #![proptest_config(common::proptest_config(256, 5))]

    /// Any rig, the relative pose off its configured value by up to 2.5 rad (the logarithm is
    /// not differentiable at π, where no prior is ever evaluated).
    #[test]
    fn relative_pose_prior_jacobians(
        t_b_a in pose(0.5), t_a_b in pose(0.5), dq in small_rotation(2.5), dp in vec3(0.5),
        sigma_m in 1e-4..0.1f64, sigma_rad in 1e-4..0.1f64,
    ) {
        let factor = RelativePosePrior { T_a_b: t_a_b, sigma_m, sigma_rad };
        let t_b_b = t_b_a.compose(&t_a_b).compose(&Pose::new(dq, dp));
        check(
            &factor,
            &[t_b_a.to_array().to_vec(), t_b_b.to_array().to_vec()],
            &[&POSE, &POSE],
        );
    }

    /// Zero when the two extrinsics are the configured relative pose apart, wherever the rig
    /// sits on the body: moving the whole rig (what camera–IMU calibration estimates) costs
    /// nothing, and only a change of the baseline or the relative rotation is seen.
    #[test]
    fn relative_pose_prior_sees_only_the_relative_pose(
        t_b_a in pose(0.5), t_a_b in pose(0.2), rig in pose(0.1),
        dq in small_rotation(0.01), dp in vec3(0.005),
    ) {
        let factor = RelativePosePrior { T_a_b: t_a_b, sigma_m: 1e-3, sigma_rad: 1e-3 };
        let t_b_b = t_b_a.compose(&t_a_b);
        let moved_a = rig.compose(&t_b_a);
        let moved_b = rig.compose(&t_b_b);
        for r in residual(&factor, &moved_a, &moved_b) {
            prop_assert!(r.abs() < 1e-9, "rigid rig motion seen: {r}");
        }
        // Camera b alone off by (dp, dq): the residual is that error in camera a's frame.
        let off = Pose::new(dq, dp);
        let r = residual(&factor, &t_b_a, &t_b_b.compose(&off));
        let seen = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt() * 1e-3;
        let expected = (t_a_b.q * dp).norm();
        prop_assert!((seen - expected).abs() < 1e-9, "translation {seen} vs {expected}");
        let angle = (r[3] * r[3] + r[4] * r[4] + r[5] * r[5]).sqrt() * 1e-3;
        prop_assert!((angle - dq.angle()).abs() < 1e-9, "rotation {angle} vs {}", dq.angle());
    }
}
