//! Cost of evaluating factors with Jacobians and of preintegrating one IMU sample.
//!
//! `cargo bench -p estimator --bench factors`

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use estimator::factors::{
    FeatureMeasurement, ImuFactor, ProjectionOneFrameTwoCam, ProjectionTwoFrameOneCam,
    ProjectionTwoFrameTwoCam,
};
use estimator::geometry::{Pose, so3_exp};
use estimator::imu::{ImuNoise, ImuSample, Preintegration};
use estimator::problem::Factor;
use nalgebra::{Vector2, Vector3};

fn sample(k: i64) -> ImuSample {
    let t = k as f64 * 0.005;
    ImuSample {
        t_ns: k * 5_000_000,
        gyro: Vector3::new((3.0 * t).sin(), (2.0 * t).cos(), 0.5 * t) * 0.3,
        accel: Vector3::new((5.0 * t).cos(), (1.0 * t).sin(), 9.81 + (4.0 * t).sin()),
    }
}

fn preintegrate(n: i64) -> Preintegration {
    let mut p = Preintegration::new(
        sample(0),
        Vector3::zeros(),
        Vector3::zeros(),
        ImuNoise::euroc(),
    )
    .unwrap();
    for k in 1..=n {
        p.push(sample(k)).unwrap();
    }
    p
}

/// Evaluates `factor` with every Jacobian block requested.
fn bench_factor(c: &mut Criterion, name: &str, factor: &dyn Factor, params: &[Vec<f64>]) {
    let m = factor.residual_dim();
    let views: Vec<&[f64]> = params.iter().map(|p| p.as_slice()).collect();
    let mut store: Vec<Vec<f64>> = factor
        .parameter_tangent_sizes()
        .iter()
        .map(|t| vec![0.0; m * t])
        .collect();
    let mut r = vec![0.0; m];
    c.bench_function(name, |b| {
        b.iter(|| {
            let mut jacs: Vec<Option<&mut [f64]>> =
                store.iter_mut().map(|j| Some(j.as_mut_slice())).collect();
            black_box(factor.evaluate(black_box(&views), &mut r, Some(&mut jacs)))
        })
    });
}

fn factors(c: &mut Criterion) {
    let pose_i = Pose::new(
        so3_exp(&Vector3::new(0.1, -0.2, 0.3)),
        Vector3::new(1.0, 2.0, 0.5),
    );
    let pose_j = Pose::new(
        so3_exp(&Vector3::new(0.12, -0.18, 0.33)),
        Vector3::new(1.1, 2.05, 0.5),
    );
    let ex0 = Pose::new(
        so3_exp(&Vector3::new(-1.5, 0.0, -1.5)),
        Vector3::new(-0.02, -0.06, 0.01),
    );
    let ex1 = Pose::new(ex0.q, Vector3::new(-0.02, 0.05, 0.01));
    let obs = |x: f64, y: f64| FeatureMeasurement {
        point: Vector2::new(x, y),
        velocity: Vector2::new(0.1, -0.05),
        td: 0.0,
    };
    let w = 460.0 / 1.5;

    let f = ProjectionTwoFrameOneCam {
        obs_i: obs(0.1, 0.2),
        obs_j: obs(0.12, 0.19),
        weight: w,
    };
    let p = vec![
        pose_i.to_array().to_vec(),
        pose_j.to_array().to_vec(),
        ex0.to_array().to_vec(),
        vec![0.2, 0.001, -0.002],
        vec![0.003],
    ];
    bench_factor(c, "reprojection_two_frame_one_cam", &f, &p);

    let f = ProjectionTwoFrameTwoCam {
        obs_i: obs(0.1, 0.2),
        obs_j: obs(0.02, 0.19),
        weight: w,
    };
    let p = vec![
        pose_i.to_array().to_vec(),
        pose_j.to_array().to_vec(),
        ex0.to_array().to_vec(),
        ex1.to_array().to_vec(),
        vec![0.2, 0.001, -0.002],
        vec![0.003],
    ];
    bench_factor(c, "reprojection_two_frame_two_cam", &f, &p);

    let f = ProjectionOneFrameTwoCam {
        obs_a: obs(0.1, 0.2),
        obs_b: obs(0.02, 0.2),
        weight: w,
    };
    let p = vec![
        ex0.to_array().to_vec(),
        ex1.to_array().to_vec(),
        vec![0.2, 0.001, -0.002],
        vec![0.003],
    ];
    bench_factor(c, "reprojection_one_frame_two_cam", &f, &p);

    let preint = preintegrate(20);
    let f = ImuFactor::new(&preint).unwrap();
    let (pj, vj) = preint.predict(
        &pose_i,
        &Vector3::new(0.5, 0.0, 0.1),
        &Vector3::zeros(),
        &Vector3::zeros(),
    );
    let sb = |v: Vector3<f64>| [v.as_slice(), &[0.0; 6]].concat();
    let p = vec![
        pose_i.to_array().to_vec(),
        sb(Vector3::new(0.5, 0.0, 0.1)),
        pj.to_array().to_vec(),
        sb(vj),
    ];
    bench_factor(c, "imu_factor", &f, &p);

    let mut group = c.benchmark_group("preintegration");
    const N: i64 = 200;
    group.throughput(Throughput::Elements(N as u64));
    let samples: Vec<ImuSample> = (0..=N).map(sample).collect();
    group.bench_function("push_200_samples_with_covariance", |b| {
        b.iter_batched(
            || {
                Preintegration::new(
                    samples[0],
                    Vector3::zeros(),
                    Vector3::zeros(),
                    ImuNoise::euroc(),
                )
                .unwrap()
            },
            |mut p| {
                for s in &samples[1..] {
                    p.push(*s).unwrap();
                }
                p
            },
            BatchSize::SmallInput,
        )
    });
    group.finish();
}

criterion_group!(benches, factors);
criterion_main!(benches);
