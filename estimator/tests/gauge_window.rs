use std::sync::Arc; use super::common::Analytic; use super::common::world::{FRAME_NS, IMU_NS, World}; use estimator::factors::*; use estimator::imu::{ImuNoise, Preintegration}; use estimator::problem::{BlockId, BlockKind, Euclidean, PoseManifold, Problem}; use nalgebra::{Vector2, Vector3}; const FRAMES: usize = 8;
pub fn window(imu: bool) -> (Problem, Vec<BlockId>, Vec<BlockId>) {
    let world = World::new(5, 1500, 0.0);
    let mut p = Problem::new();
    let times: Vec<i64> = (0..FRAMES as i64)
        .map(|k| 2_000_000_000 + k * FRAME_NS)
        .collect();
    let poses: Vec<BlockId> = times
        .iter()
        .map(|t| {
            p.add_block(
                &Analytic::pose(*t).to_array(),
                Arc::new(PoseManifold),
                BlockKind::State,
            )
            .unwrap()
        })
        .collect();
    let mut sbs = Vec::new();
    if imu {
        for t in &times {
            let v = Analytic::velocity(*t as f64 * 1e-9);
            let sb = [v.x, v.y, v.z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            sbs.push(
                p.add_block(&sb, Arc::new(Euclidean::new(9)), BlockKind::State)
                    .unwrap(),
            );
        }
        for k in 1..FRAMES {
            let mut pre = Preintegration::new(
                Analytic::sample(times[k - 1]),
                Vector3::zeros(),
                Vector3::zeros(),
                ImuNoise::euroc(),
            )
            .unwrap();
            let mut t = times[k - 1] + IMU_NS;
            while t <= times[k] {
                pre.push(Analytic::sample(t)).unwrap();
                t += IMU_NS;
            }
            let f = ImuFactor::new(&pre).unwrap();
            p.add_factor(
                Arc::new(f),
                None,
                &[poses[k - 1], sbs[k - 1], poses[k], sbs[k]],
            )
            .unwrap();
        }
    }
    let ex: Vec<BlockId> = world
        .extrinsics
        .iter()
        .map(|e| {
            let b = p
                .add_block(&e.to_array(), Arc::new(PoseManifold), BlockKind::State)
                .unwrap();
            p.set_constant(b, true);
            b
        })
        .collect();
    let td = p
        .add_block(&[0.0], Arc::new(Euclidean::new(1)), BlockKind::State)
        .unwrap();
    p.set_constant(td, true);
    let normalized = |k: usize, cam: usize, l: &Vector3<f64>| -> Option<Vector2<f64>> {
        let p_c = Analytic::pose(times[k])
            .compose(&world.extrinsics[cam])
            .inverse()
            .transform(l);
        (p_c.z > 0.5 && (p_c.x / p_c.z).abs() < 0.8 && (p_c.y / p_c.z).abs() < 0.5)
            .then(|| Vector2::new(p_c.x / p_c.z, p_c.y / p_c.z))
    };
    let mut landmarks = 0;
    for l in world.landmarks.iter() {
        let (Some(z0), Some(z0r)) = (normalized(0, 0, l), normalized(0, 1, l)) else {
            continue;
        };
        let depth = Analytic::pose(times[0])
            .compose(&world.extrinsics[0])
            .inverse()
            .transform(l)
            .z;
        let lm = p
            .add_block(
                &[1.0 / depth],
                Arc::new(Euclidean::new(1)),
                BlockKind::Landmark,
            )
            .unwrap();
        let m = FeatureMeasurement::new;
        p.add_factor(
            Arc::new(ProjectionOneFrameTwoCam {
                obs_a: m(z0),
                obs_b: m(z0r),
                weight: 300.0,
            }),
            None,
            &[ex[0], ex[1], lm, td],
        )
        .unwrap();
        for k in 1..FRAMES {
            if let Some(z) = normalized(k, 0, l) {
                p.add_factor(
                    Arc::new(ProjectionTwoFrameOneCam {
                        obs_i: m(z0),
                        obs_j: m(z),
                        weight: 300.0,
                    }),
                    None,
                    &[poses[0], poses[k], ex[0], lm, td],
                )
                .unwrap();
            }
            if let Some(z) = normalized(k, 1, l) {
                p.add_factor(
                    Arc::new(ProjectionTwoFrameTwoCam {
                        obs_i: m(z0),
                        obs_j: m(z),
                        weight: 300.0,
                    }),
                    None,
                    &[poses[0], poses[k], ex[0], ex[1], lm, td],
                )
                .unwrap();
            }
        }
        landmarks += 1;
        if landmarks == 60 {
            break;
        }
    }
    assert_eq!(landmarks, 60);
    (p, poses, sbs)
}
