//! The GNSS position and wheel (body velocity) factors: analytic Jacobians against central
//! differences through the shared checker, and the properties the residuals must have (zero at
//! the truth, invariance to the gauge they do not observe).

use crate::common;

use common::{check, pose, speed_bias, vec3};
use estimator::factors::{BodyVelocityFactor, GnssPositionFactor, yaw_rotation};
use estimator::geometry::Pose;
use estimator::problem::{Euclidean, Factor, PoseManifold};
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

const POSE: PoseManifold = PoseManifold;
const R4: Euclidean = Euclidean::new(4);
const R9: Euclidean = Euclidean::new(9);

fn residual(factor: &dyn Factor, params: &[Vec<f64>]) -> Vec<f64> {
    let views: Vec<&[f64]> = params.iter().map(|p| p.as_slice()).collect();
    let mut r = vec![0.0; factor.residual_dim()];
    assert!(factor.evaluate(&views, &mut r, None));
    r
}

/// A yaw rotation about z by `yaw` and a translation: the 4-dof gauge of a gravity-aligned
/// world frame.
fn yaw_pose(yaw: f64, t: Vector3<f64>) -> Pose {
    Pose::new(UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw), t)
}

proptest! {
    #![proptest_config(common::proptest_config(256, 3))]

    #[test]
    fn gnss_position_jacobians(
        t_w_b in pose(200.0), v in vec3(10.0), ba in vec3(0.2), bg in vec3(0.05),
        lever in vec3(1.0), t in vec3(500.0), yaw in -7.0..7.0f64, dt in -0.05..0.05f64,
        z in vec3(500.0), sigma in (0.01..5.0f64, 0.01..5.0f64, 0.01..5.0f64),
    ) {
        let factor = GnssPositionFactor {
            z,
            weight: Vector3::new(1.0 / sigma.0, 1.0 / sigma.1, 1.0 / sigma.2),
            lever_arm_b: lever,
            dt_s: dt,
        };
        let params = vec![
            t_w_b.to_array().to_vec(),
            speed_bias(v, ba, bg),
            vec![t.x, t.y, t.z, yaw],
        ];
        check(&factor, &params, &[&POSE, &R9, &R4]);
    }

    #[test]
    fn gnss_position_is_zero_at_the_truth_and_blind_to_the_world_gauge(
        t_w_b in pose(100.0), v in vec3(10.0), lever in vec3(1.0), t in vec3(100.0),
        yaw in -3.0..3.0f64, dt in -0.05..0.05f64, gauge_yaw in -3.0..3.0f64,
        gauge_t in vec3(100.0),
    ) {
        let (r_gw, _) = yaw_rotation(yaw);
        let antenna = t_w_b.p + t_w_b.q * lever + v * dt;
        let factor = GnssPositionFactor {
            z: r_gw * antenna + t,
            weight: Vector3::new(2.0, 2.0, 1.0),
            lever_arm_b: lever,
            dt_s: dt,
        };
        let zero = Vector3::zeros();
        let params = vec![t_w_b.to_array().to_vec(), speed_bias(v, zero, zero), vec![t.x, t.y, t.z, yaw]];
        let r = residual(&factor, &params);
        prop_assert!(r.iter().all(|x| x.abs() < 1e-9), "{r:?}");
        // Moving the world frame by a yaw-translation G (states G·x, alignment T_g_w·G⁻¹)
        // changes nothing the receiver can see.
        let g = yaw_pose(gauge_yaw, gauge_t);
        let moved = g.compose(&t_w_b);
        let align = yaw_pose(yaw, t).compose(&g.inverse());
        let align_yaw = yaw + -gauge_yaw;
        let params = vec![
            moved.to_array().to_vec(),
            speed_bias(g.q * v, zero, zero),
            vec![align.p.x, align.p.y, align.p.z, align_yaw],
        ];
        let r = residual(&factor, &params);
        prop_assert!(r.iter().all(|x| x.abs() < 1e-7), "{r:?}");
    }

    #[test]
    fn body_velocity_jacobians(
        t_w_b in pose(100.0), v in vec3(20.0), ba in vec3(0.2), bg in vec3(0.05),
        speed in -20.0..20.0f64, s_speed in 0.005..1.0f64, s_lat in 0.005..1.0f64,
    ) {
        let factor = BodyVelocityFactor {
            speed_m_s: speed,
            speed_sigma: s_speed,
            lateral_sigma: s_lat,
        };
        let params = vec![t_w_b.to_array().to_vec(), speed_bias(v, ba, bg)];
        check(&factor, &params, &[&POSE, &R9]);
    }

    #[test]
    fn body_velocity_is_zero_for_a_car_driving_straight_and_blind_to_the_world_gauge(
        t_w_b in pose(100.0), speed in -20.0..20.0f64, gauge_yaw in -3.0..3.0f64,
        gauge_t in vec3(100.0), slide in 0.01..5.0f64,
    ) {
        let factor = BodyVelocityFactor {
            speed_m_s: speed,
            speed_sigma: 0.05,
            lateral_sigma: 0.05,
        };
        let zero = Vector3::zeros();
        let v = t_w_b.q * Vector3::new(speed, 0.0, 0.0);
        let r = residual(&factor, &[t_w_b.to_array().to_vec(), speed_bias(v, zero, zero)]);
        prop_assert!(r.iter().all(|x| x.abs() < 1e-9), "{r:?}");
        let g = yaw_pose(gauge_yaw, gauge_t);
        let moved = vec![g.compose(&t_w_b).to_array().to_vec(), speed_bias(g.q * v, zero, zero)];
        let r = residual(&factor, &moved);
        prop_assert!(r.iter().all(|x| x.abs() < 1e-8), "{r:?}");
        // A sideways slide is seen, in proportion to its speed.
        let sliding = v + t_w_b.q * Vector3::new(0.0, slide, 0.0);
        let r = residual(&factor, &[t_w_b.to_array().to_vec(), speed_bias(sliding, zero, zero)]);
        prop_assert!((r[1] - slide / 0.05).abs() < 1e-6 && r[0].abs() < 1e-6);
    }
}
