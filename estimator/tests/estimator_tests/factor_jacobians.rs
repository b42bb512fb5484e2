//! Every factor's analytic Jacobians against central differences on the manifold, through the
//! one shared checker, over random states including the hard cases.

use crate::common;

use std::sync::Arc;

use common::{check, pose, rotation, small_rotation, speed_bias, vec3};
use estimator::bias_process::BiasProcess;
use estimator::camera::{ReadoutDirection, RollingShutter};
use estimator::factors::{
    AnchorBearing, FeatureMeasurement, ImuFactor, PointForm, PointProjection,
    ProjectionOneFrameTwoCam, ProjectionTwoFrameOneCam, ProjectionTwoFrameTwoCam,
    WorldPointProjection,
};
use estimator::geometry::Pose;
use estimator::imu::{ImuNoise, ImuSample, Preintegration};
use estimator::problem::{
    CheckOptions, Euclidean, Factor, Manifold, PoseManifold, PriorFactor, QuaternionManifold,
    check_factor_jacobians,
};
use nalgebra::{Vector2, Vector3};
use proptest::prelude::*;

const POSE: PoseManifold = PoseManifold;
const R1: Euclidean = Euclidean::new(1);
const R3: Euclidean = Euclidean::new(3);
const R6: Euclidean = Euclidean::new(6);
const R9: Euclidean = Euclidean::new(9);

/// An IMU interval of `n` samples at `rate_hz` with smoothly varying random motion.
fn preintegration(
    n: usize,
    rate_hz: f64,
    w0: Vector3<f64>,
    a0: Vector3<f64>,
    ba: Vector3<f64>,
    bg: Vector3<f64>,
) -> Preintegration {
    let dt_ns = (1e9 / rate_hz) as i64;
    let sample = |k: usize| {
        let t = k as f64 / rate_hz;
        ImuSample {
            t_ns: k as i64 * dt_ns,
            gyro: w0 + Vector3::new((3.0 * t).sin(), (2.0 * t).cos(), 0.5 * t) * 0.3,
            accel: a0 + Vector3::new((5.0 * t).cos(), (1.0 * t).sin(), (4.0 * t).sin()),
        }
    };
    let mut p = Preintegration::new(sample(0), ba, bg, ImuNoise::euroc()).unwrap();
    for k in 1..=n {
        p.push(sample(k)).unwrap();
    }
    p
}

fn measurement(point: Vector2<f64>, velocity: Vector2<f64>, td: f64) -> FeatureMeasurement {
    FeatureMeasurement {
        point,
        velocity,
        td,
    }
}

/// Projects a world point into a camera at body pose `t_w_b` with extrinsic `t_b_c`.
fn project(t_w_b: &Pose, t_b_c: &Pose, p_w: &Vector3<f64>) -> Option<Vector2<f64>> {
    let p_c = t_w_b.compose(t_b_c).inverse().transform(p_w);
    (p_c.z > 0.2).then(|| Vector2::new(p_c.x / p_c.z, p_c.y / p_c.z))
}

proptest! {
    #![proptest_config(common::proptest_config(256, 2))]

    #[test]
    fn imu_factor_jacobians(
        n in prop_oneof![1usize..4, 10usize..40, 150usize..400],
        w0 in vec3(2.0), a0 in vec3(3.0),
        lin_ba in vec3(0.5), lin_bg in vec3(0.1),
        pose_i in pose(20.0), v_i in vec3(3.0),
        dq in small_rotation(0.3), dp in vec3(0.5), dv in vec3(0.5),
        dba in vec3(0.05), dbg in vec3(0.01), ba_j in vec3(0.5), bg_j in vec3(0.1),
    ) {
        let preint = preintegration(n, 200.0, w0, a0 + Vector3::new(0.0, 0.0, 9.81), lin_ba, lin_bg);
        let factor = ImuFactor::new(&preint).unwrap();
        let ba_i = lin_ba + dba;
        let bg_i = lin_bg + dbg;
        let (pred, v_pred) = preint.predict(&pose_i, &v_i, &ba_i, &bg_i);
        let pose_j = Pose::new(pred.q * dq, pred.p + dp);
        let params = vec![
            pose_i.to_array().to_vec(),
            speed_bias(v_i, ba_i, bg_i),
            pose_j.to_array().to_vec(),
            speed_bias(v_pred + dv, ba_j, bg_j),
        ];
        check(&factor, &params, &[&POSE, &R9, &POSE, &R9]);
    }

    #[test]
    fn imu_factor_with_a_bias_process_jacobians(
        n in prop_oneof![1usize..4, 10usize..40],
        lin_ba in vec3(0.5), lin_bg in vec3(0.1), pose_i in pose(20.0), v_i in vec3(3.0),
        dq in small_rotation(0.3), dp in vec3(0.5), dba in vec3(0.05), dbg in vec3(0.01),
        ba_j in vec3(0.5), bg_j in vec3(0.1), c_a in vec3(0.5), c_g in vec3(0.1),
        correlation_s in 0.01..100.0f64,
    ) {
        let preint = preintegration(n, 200.0, Vector3::zeros(), Vector3::new(0.0, 0.0, 9.81), lin_ba, lin_bg);
        let process = BiasProcess::from_allan_floors(4e-4, 1e-2, correlation_s);
        let factor = ImuFactor::with_bias_process(&preint, &process).unwrap();
        let ba_i = lin_ba + dba;
        let bg_i = lin_bg + dbg;
        let (pred, v_pred) = preint.predict(&pose_i, &v_i, &ba_i, &bg_i);
        let pose_j = Pose::new(pred.q * dq, pred.p + dp);
        let params = vec![
            pose_i.to_array().to_vec(),
            speed_bias(v_i, ba_i, bg_i),
            pose_j.to_array().to_vec(),
            speed_bias(v_pred, ba_j, bg_j),
            vec![c_a.x, c_a.y, c_a.z, c_g.x, c_g.y, c_g.z],
        ];
        check(&factor, &params, &[&POSE, &R9, &POSE, &R9, &R6]);
        // The bias rows are the Gauss–Markov step (raw, at a zero mean): b_j − φ b_i.
        let keep = process.keep(preint.dt());
        let raw = factor.raw_residual(&pose_i, &params[1], &pose_j, &params[3]);
        for k in 0..3 {
            prop_assert!((raw[9 + k] - (ba_j[k] - keep * ba_i[k])).abs() < 1e-12);
            prop_assert!((raw[12 + k] - (bg_j[k] - keep * bg_i[k])).abs() < 1e-12);
        }
    }

    #[test]
    fn two_frame_one_cam_jacobians(
        pose_i in pose(10.0), ex in pose(0.2), dq in small_rotation(0.4), dp in vec3(1.0),
        x in -0.85..0.85f64, y in -0.55..0.55f64, depth in 0.3..60.0f64,
        vel_i in vec3(2.0), vel_j in vec3(2.0), td in -0.03..0.03f64, noise in vec3(0.01),
        corr in vec3(0.01),
    ) {
        let pose_j = Pose::new(pose_i.q * dq, pose_i.p + dp);
        let p_w = pose_i.compose(&ex).transform(&(Vector3::new(x, y, 1.0) * depth));
        let z_j = project(&pose_j, &ex, &p_w);
        prop_assume!(z_j.is_some());
        let factor = ProjectionTwoFrameOneCam {
            obs_i: measurement(Vector2::new(x, y), vel_i.xy(), 0.0),
            obs_j: measurement(z_j.unwrap() + noise.xy(), vel_j.xy(), 0.01),
            weight: 460.0 / 1.5,
        };
        let params = vec![
            pose_i.to_array().to_vec(),
            pose_j.to_array().to_vec(),
            ex.to_array().to_vec(),
            vec![1.0 / depth, corr.x, corr.y],
            vec![td],
        ];
        check(&factor, &params, &[&POSE, &POSE, &POSE, &R3, &R1]);
    }

    #[test]
    fn rolling_shutter_observation_jacobians(
        pose_i in pose(10.0), ex in pose(0.2), dq in small_rotation(0.4), dp in vec3(1.0),
        x in -0.85..0.85f64, y in -0.55..0.55f64, depth in 0.3..60.0f64,
        vel_i in vec3(2.0), vel_j in vec3(2.0), td in -0.03..0.03f64, noise in vec3(0.01),
        corr in vec3(0.01), readout_s in 0.0..0.033f64, bottom_first in any::<bool>(),
    ) {
        // Each observation stamped as the window stamps a rolling-shutter row: earlier than
        // the frame's offset by its row's time (pixel rows of a 480-row EuRoC-like pinhole).
        let shutter = RollingShutter {
            readout_s,
            direction: if bottom_first { ReadoutDirection::BottomToTop } else { ReadoutDirection::TopToBottom },
        };
        let row_s = |z: Vector2<f64>| shutter.row_time_s(&Vector2::new(458.0 * z.x + 367.0, 457.0 * z.y + 248.0), 480);
        let pose_j = Pose::new(pose_i.q * dq, pose_i.p + dp);
        let p_w = pose_i.compose(&ex).transform(&(Vector3::new(x, y, 1.0) * depth));
        let z_j = project(&pose_j, &ex, &p_w);
        prop_assume!(z_j.is_some());
        let (z_i, z_j) = (Vector2::new(x, y), z_j.unwrap() + noise.xy());
        let factor = ProjectionTwoFrameOneCam {
            obs_i: measurement(z_i, vel_i.xy(), 0.002 - row_s(z_i)),
            obs_j: measurement(z_j, vel_j.xy(), 0.002 - row_s(z_j)),
            weight: 460.0 / 1.5,
        };
        let params = vec![
            pose_i.to_array().to_vec(),
            pose_j.to_array().to_vec(),
            ex.to_array().to_vec(),
            vec![1.0 / depth, corr.x, corr.y],
            vec![td],
        ];
        check(&factor, &params, &[&POSE, &POSE, &POSE, &R3, &R1]);
    }

    #[test]
    fn world_point_projection_jacobians(
        t_w_b in pose(10.0), ex in pose(0.2), x in -0.85..0.85f64, y in -0.55..0.55f64,
        depth in 0.3..60.0f64, vel in vec3(2.0), td in -0.03..0.03f64, noise in vec3(0.01),
    ) {
        let x_w = t_w_b.compose(&ex).transform(&(Vector3::new(x, y, 1.0) * depth));
        let factor = WorldPointProjection {
            obs: measurement(Vector2::new(x, y) + noise.xy(), vel.xy(), 0.004),
            weight: 460.0 / 1.5,
            form: PointForm::World,
        };
        let params = vec![
            t_w_b.to_array().to_vec(),
            ex.to_array().to_vec(),
            x_w.as_slice().to_vec(),
            vec![td],
        ];
        check(&factor, &params, &[&POSE, &POSE, &R3, &R1]);
    }

    #[test]
    fn inverse_distance_point_projection_jacobians(
        t_w_b in pose(10.0), ex in pose(0.2), anchor in pose(10.0), x in -0.85..0.85f64,
        y in -0.55..0.55f64, depth in 0.3..200.0f64, vel in vec3(2.0), td in -0.03..0.03f64,
        noise in vec3(0.01),
    ) {
        // A point in front of the camera, anchored at another camera that sees it in front.
        let x_w = t_w_b.compose(&ex).transform(&(Vector3::new(x, y, 1.0) * depth));
        let frame = anchor.q.to_rotation_matrix().into_inner();
        let m = frame.transpose() * (x_w - anchor.p);
        let flip = if m.z > 0.0 { 1.0 } else { -1.0 };
        let frame = frame * nalgebra::Matrix3::from_diagonal(&Vector3::new(flip, 1.0, flip));
        prop_assume!((frame.transpose() * (x_w - anchor.p)).z > 0.1);
        let (form, c) = PointForm::anchored(anchor.p, frame, &x_w).expect("in front");
        let factor = WorldPointProjection {
            obs: measurement(Vector2::new(x, y) + noise.xy(), vel.xy(), 0.004),
            weight: 460.0 / 1.5,
            form,
        };
        let params = vec![
            t_w_b.to_array().to_vec(),
            ex.to_array().to_vec(),
            c.as_slice().to_vec(),
            vec![td],
        ];
        check(&factor, &params, &[&POSE, &POSE, &R3, &R1]);
    }

    #[test]
    fn anchor_bearing_jacobians(
        inv_depth in 0.01..3.0f64, corr in vec3(0.05), weight in 10.0..1000.0f64,
    ) {
        let factor = AnchorBearing { weight };
        check(&factor, &[vec![inv_depth, corr.x, corr.y]], &[&R3]);
    }

    #[test]
    fn point_projection_jacobians(
        t_w_c in pose(10.0), x in -0.85..0.85f64, y in -0.55..0.55f64, depth in 0.3..60.0f64,
        noise in vec3(0.01), weight in 10.0..1000.0f64,
    ) {
        let x_w = t_w_c.transform(&(Vector3::new(x, y, 1.0) * depth));
        let factor = PointProjection {
            obs: Vector2::new(x + noise.x, y + noise.y),
            weight,
        };
        let params = vec![t_w_c.to_array().to_vec(), x_w.as_slice().to_vec()];
        check(&factor, &params, &[&POSE, &R3]);
    }

    #[test]
    fn two_frame_two_cam_jacobians(
        pose_i in pose(10.0), ex0 in pose(0.2), ex1 in pose(0.2),
        dq in small_rotation(0.4), dp in vec3(1.0),
        x in -0.85..0.85f64, y in -0.55..0.55f64, depth in 0.3..60.0f64,
        vel_i in vec3(2.0), vel_j in vec3(2.0), td in -0.03..0.03f64, noise in vec3(0.01),
        corr in vec3(0.01),
    ) {
        let pose_j = Pose::new(pose_i.q * dq, pose_i.p + dp);
        let p_w = pose_i.compose(&ex0).transform(&(Vector3::new(x, y, 1.0) * depth));
        let z_j = project(&pose_j, &ex1, &p_w);
        prop_assume!(z_j.is_some());
        let factor = ProjectionTwoFrameTwoCam {
            obs_i: measurement(Vector2::new(x, y), vel_i.xy(), -0.005),
            obs_j: measurement(z_j.unwrap() + noise.xy(), vel_j.xy(), 0.0),
            weight: 460.0 / 1.5,
        };
        let params = vec![
            pose_i.to_array().to_vec(),
            pose_j.to_array().to_vec(),
            ex0.to_array().to_vec(),
            ex1.to_array().to_vec(),
            vec![1.0 / depth, corr.x, corr.y],
            vec![td],
        ];
        check(&factor, &params, &[&POSE, &POSE, &POSE, &POSE, &R3, &R1]);
    }

    #[test]
    fn one_frame_two_cam_jacobians(
        ex0 in pose(0.2), baseline in vec3(0.3), dq in small_rotation(0.2),
        x in -0.85..0.85f64, y in -0.55..0.55f64, depth in 0.3..60.0f64,
        vel_i in vec3(2.0), vel_j in vec3(2.0), td in -0.03..0.03f64, noise in vec3(0.01),
        corr in vec3(0.01),
    ) {
        let ex1 = Pose::new(ex0.q * dq, ex0.p + baseline);
        let id = Pose::identity();
        let p_b = ex0.transform(&(Vector3::new(x, y, 1.0) * depth));
        let z_b = project(&id, &ex1, &p_b);
        prop_assume!(z_b.is_some());
        let factor = ProjectionOneFrameTwoCam {
            obs_a: measurement(Vector2::new(x, y), vel_i.xy(), 0.0),
            obs_b: measurement(z_b.unwrap() + noise.xy(), vel_j.xy(), 0.0),
            weight: 460.0 / 1.5,
        };
        let params = vec![
            ex0.to_array().to_vec(),
            ex1.to_array().to_vec(),
            vec![1.0 / depth, corr.x, corr.y],
            vec![td],
        ];
        check(&factor, &params, &[&POSE, &POSE, &R3, &R1]);
    }

    #[test]
    fn prior_factor_jacobians(
        x0_pose in pose(5.0), dpose in (vec3(0.5), vec3(1.0)),
        x0_q in rotation(), dq in vec3(1.0),
        x0_sb in proptest::collection::vec(-1.0..1.0f64, 9),
        dsb in proptest::collection::vec(-0.2..0.2f64, 9),
        jac in proptest::collection::vec(-3.0..3.0f64, 7 * 18),
        r0 in proptest::collection::vec(-1.0..1.0f64, 7),
    ) {
        let manifolds: Vec<Arc<dyn Manifold>> =
            vec![Arc::new(PoseManifold), Arc::new(R9), Arc::new(QuaternionManifold)];
        let x0 = vec![
            x0_pose.to_array().to_vec(),
            x0_sb.clone(),
            x0_q.quaternion().coords.as_slice().to_vec(),
        ];
        let delta = [
            [dpose.0.as_slice(), dpose.1.as_slice()].concat(),
            dsb,
            dq.as_slice().to_vec(),
        ];
        let x: Vec<Vec<f64>> = (0..3)
            .map(|k| {
                let mut out = vec![0.0; x0[k].len()];
                manifolds[k].plus(&x0[k], &delta[k], &mut out);
                out
            })
            .collect();
        let prior = PriorFactor::new(manifolds, x0, jac, r0).unwrap();
        check(&prior, &x, &[&POSE, &R9, &QuaternionManifold]);
    }
}

#[test]
fn prior_rejects_bad_dimensions_and_nan() {
    let m: Vec<Arc<dyn Manifold>> = vec![Arc::new(R1)];
    assert!(PriorFactor::new(m.clone(), vec![vec![0.0]], vec![1.0, 2.0], vec![0.0]).is_err());
    assert!(PriorFactor::new(m.clone(), vec![vec![0.0, 1.0]], vec![1.0], vec![0.0]).is_err());
    assert!(PriorFactor::new(m, vec![vec![f64::NAN]], vec![1.0], vec![0.0]).is_err());
}

#[test]
fn checker_catches_a_wrong_jacobian() {
    // A factor whose Jacobian is deliberately off by 1% must fail the shared checker.
    struct Wrong;
    impl Factor for Wrong {
        fn residual_dim(&self) -> usize {
            1
        }
        fn parameter_block_sizes(&self) -> &[usize] {
            &[1]
        }
        fn parameter_tangent_sizes(&self) -> &[usize] {
            &[1]
        }
        fn evaluate(
            &self,
            p: &[&[f64]],
            r: &mut [f64],
            j: Option<&mut [Option<&mut [f64]>]>,
        ) -> bool {
            r[0] = p[0][0].sin();
            if let Some(j) = j
                && let Some(b) = j[0].as_deref_mut()
            {
                b[0] = 1.01 * p[0][0].cos();
            }
            true
        }
    }
    assert!(check_factor_jacobians(&Wrong, &[vec![0.3]], &[&R1], CheckOptions::default()).is_err());
}
