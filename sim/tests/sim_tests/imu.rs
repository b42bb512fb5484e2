//! IMU: exact consistency with the integrator, midpoint accuracy at 200 Hz, noise statistics and
//! known initial biases.

use estimator::geometry::Pose;
use nalgebra::{UnitQuaternion, Vector3};
use sim::imu::{ImuConfig, ImuWindow};
use sim::motion::{Lissajous, Reference, integrate_step};
use sim::stream::Measurement;
use sim::{TrajectoryConfig, World, WorldConfig};
use std::sync::Arc;

fn aggressive() -> TrajectoryConfig {
    TrajectoryConfig::Lissajous(Lissajous::aggressive(Vector3::new(0.0, 0.0, 1.5)))
}

#[test]
fn noise_free_imu_at_physics_rate_reintegrates_exactly_over_60s() {
    let mut imu = ImuConfig::ideal(1000.0);
    imu.window = ImuWindow::Forward;
    let world = World::new(WorldConfig {
        duration_s: 60.0,
        trajectory: aggressive(),
        physics_steps_per_imu: 1,
        imu,
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    let gt0 = stream.truth(0).unwrap();
    // Rapier's state at t = 0: position/attitude exact; velocity of the step into t = 0.
    let mut motion = world.motion();
    let s0 = motion.step();
    assert_eq!(s0.t_ns, 0);
    assert!((s0.p - gt0.pose.p).norm() < 1e-12);
    let (mut p, mut q, mut v) = (s0.p, s0.q, s0.v);
    let samples: Vec<_> = stream
        .by_ref()
        .filter_map(|m| match m {
            Measurement::Imu(s) => Some(s),
            _ => None,
        })
        .collect();
    assert_eq!(samples.len(), 60_001);
    for s in &samples[..60_000] {
        integrate_step(&mut p, &mut q, &mut v, &s.accel, &s.gyro, 1e-3);
    }
    let mut m2 = world.motion();
    let mut last = m2.step();
    while last.t_ns < 60_000_000_000 {
        last = m2.step();
    }
    let ep = (p - last.p).norm();
    let er = q.angle_to(&last.q).to_degrees();
    println!("IMU consistency over 60 s: position {ep:.3e} m, attitude {er:.3e} deg");
    assert!(ep < 1e-3, "position error {ep} m");
    assert!(er < 0.01, "attitude error {er} deg");
}

/// Midpoint integration of the 200 Hz (centred-window) samples between 20 Hz frames, started
/// from ground truth each frame, as an estimator's preintegration does. Measured on the
/// aggressive Lissajous: position 4.3e-6 m, velocity 2.1e-5 m/s, attitude 1.8e-4° worst over
/// 50 ms; with each step's specific force taken over the step after its state (half a physics
/// step late, as before 2026-11-28) the velocity error was 1.1e-3 m/s and the position 2.5e-5 m.
#[test]
fn centred_200hz_samples_make_midpoint_preintegration_accurate() {
    let world = World::new(WorldConfig {
        duration_s: 20.0,
        trajectory: aggressive(),
        imu: ImuConfig::ideal(200.0),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    let samples: Vec<_> = stream
        .by_ref()
        .filter_map(|m| match m {
            Measurement::Imu(s) => Some(s),
            _ => None,
        })
        .collect();
    let mut stream = world.stream();
    let mut truth = Vec::new();
    for s in &samples {
        truth.push(stream.truth(s.t_ns).unwrap());
        while stream.next().is_some_and(|m| m.t_ns() < s.t_ns) {}
    }
    let dt = 0.005;
    let g = estimator::gravity_w();
    let (mut worst_p, mut worst_r, mut worst_v): (f64, f64, f64) = (0.0, 0.0, 0.0);
    for start in (0..samples.len() - 10).step_by(10) {
        let gt = &truth[start];
        let (mut p, mut q, mut v) = (gt.pose.p, gt.pose.q, gt.v_w);
        for k in start..start + 10 {
            let (a, b) = (&samples[k], &samples[k + 1]);
            let w = (a.gyro + b.gyro) * 0.5;
            let q1 = q * UnitQuaternion::from_scaled_axis(w * dt);
            let acc = (q * a.accel + q1 * b.accel) * 0.5 + g;
            p += v * dt + acc * (0.5 * dt * dt);
            v += acc * dt;
            q = q1;
        }
        let end = &truth[start + 10];
        worst_p = worst_p.max((p - end.pose.p).norm());
        worst_v = worst_v.max((v - end.v_w).norm());
        worst_r = worst_r.max(q.angle_to(&end.pose.q).to_degrees());
    }
    println!(
        "midpoint over 50 ms: position {worst_p:.2e} m, velocity {worst_v:.2e} m/s, attitude {worst_r:.2e} deg"
    );
    assert!(worst_p < 1e-5 && worst_v < 1e-4 && worst_r < 1e-3);
}

/// A body at rest with noise and bias random walk: sample statistics match the densities.
#[test]
fn noise_statistics_match_densities_and_initial_bias_is_reported() {
    let rest = Lissajous {
        amplitude: Vector3::zeros(),
        yaw_amplitude: 0.0,
        tilt_amplitude: 0.0,
        yaw0: 0.7,
        ..Lissajous::default()
    };
    let imu = ImuConfig {
        gyro_range: None,
        accel_range: None,
        ..ImuConfig::default()
    };
    let noise = imu.noise.unwrap();
    let world = World::new(WorldConfig {
        seed: 7,
        duration_s: 200.0,
        trajectory: TrajectoryConfig::Reference(Arc::new(rest.clone())),
        imu: imu.clone(),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    let gt0 = stream.truth(0).unwrap();
    assert_eq!(gt0.gyro_bias, imu.initial_gyro_bias);
    assert_eq!(gt0.accel_bias, imu.initial_accel_bias);
    let pose: Pose = Pose::new(rest.state(0.0).q, rest.center);
    let f_true = pose.q.inverse() * -estimator::gravity_w();
    let (mut n_g, mut n_a, mut d_g, mut d_a) = (vec![], vec![], vec![], vec![]);
    let mut prev: Option<(Vector3<f64>, Vector3<f64>)> = None;
    while let Some(m) = stream.next() {
        let Measurement::Imu(s) = m else { continue };
        let gt = stream.truth(s.t_ns).unwrap();
        n_g.extend((s.gyro - gt.gyro_bias).iter().copied());
        n_a.extend((s.accel - f_true - gt.accel_bias).iter().copied());
        if let Some((bg, ba)) = prev {
            d_g.extend((gt.gyro_bias - bg).iter().copied());
            d_a.extend((gt.accel_bias - ba).iter().copied());
        }
        prev = Some((gt.gyro_bias, gt.accel_bias));
    }
    let std = |x: &[f64]| {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
    };
    let dt: f64 = 0.005;
    let checks = [
        (
            "gyro noise",
            std(&n_g),
            noise.gyroscope_noise_density / dt.sqrt(),
        ),
        (
            "accel noise",
            std(&n_a),
            noise.accelerometer_noise_density / dt.sqrt(),
        ),
        (
            "gyro bias step",
            std(&d_g),
            noise.gyroscope_random_walk * dt.sqrt(),
        ),
        (
            "accel bias step",
            std(&d_a),
            noise.accelerometer_random_walk * dt.sqrt(),
        ),
    ];
    for (name, got, want) in checks {
        println!("{name}: sample σ {got:.4e}, configured {want:.4e}");
        assert!((got / want - 1.0).abs() < 0.05, "{name}: {got} vs {want}");
    }
}

#[test]
fn scale_misalignment_and_saturation_apply() {
    let mut imu = ImuConfig::ideal(200.0);
    imu.accel_matrix = nalgebra::Matrix3::from_diagonal(&Vector3::new(1.01, 0.99, 1.0));
    imu.accel_range = Some(9.0);
    let rest = Lissajous {
        amplitude: Vector3::zeros(),
        yaw_amplitude: 0.0,
        tilt_amplitude: 0.0,
        ..Lissajous::default()
    };
    let world = World::new(WorldConfig {
        duration_s: 0.1,
        trajectory: TrajectoryConfig::Reference(Arc::new(rest)),
        imu,
        ..WorldConfig::default()
    })
    .unwrap();
    for m in world.stream() {
        if let Measurement::Imu(s) = m {
            // At rest the specific force is +9.81 along body z: clamped to the 9 m/s² range.
            assert_eq!(s.accel.z, 9.0);
            assert!(s.accel.x.abs() < 1e-6 && s.accel.y.abs() < 1e-6);
        }
    }
}
