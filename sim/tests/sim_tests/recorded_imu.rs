//! A recorded IMU log replaces the simulated IMU in the stream: its samples from `t = 0` to
//! the end come out unchanged (faults still apply), the ground truth carries its biases, the
//! frames are the simulated ones, and a log that misses part of the run is refused.

use std::sync::Arc;

use estimator::imu::ImuSample;
use nalgebra::Vector3;
use sim::faults::Fault;
use sim::imu_source::RecordedImu;
use sim::stream::Measurement;
use sim::{World, WorldConfig};

const MS: i64 = 1_000_000;

/// A 200 Hz log from −20 ms to 1.1 s whose values encode their index, with a bias that grows
/// with time.
fn log() -> RecordedImu {
    let samples: Vec<ImuSample> = (-4..=220)
        .map(|k| ImuSample {
            t_ns: k * 5 * MS,
            gyro: Vector3::new(0.001 * k as f64, 0.0, 0.0),
            accel: Vector3::new(0.0, 0.0, 9.81 + 0.001 * k as f64),
        })
        .collect();
    let biases = samples
        .iter()
        .map(|s| {
            let t = s.t_ns as f64 * 1e-9;
            (Vector3::new(t, 0.0, 0.0), Vector3::new(0.0, 2.0 * t, 0.0))
        })
        .collect();
    RecordedImu::new(samples, biases).unwrap()
}

fn world(log: RecordedImu, faults: Vec<Fault>) -> World {
    World::new(WorldConfig {
        duration_s: 1.0,
        faults,
        recorded_imu: Some(Arc::new(log)),
        ..WorldConfig::default()
    })
    .unwrap()
}

fn imu_of(world: &World) -> Vec<ImuSample> {
    world
        .stream()
        .filter_map(|m| match m {
            Measurement::Imu(s) => Some(s),
            _ => None,
        })
        .collect()
}

#[test]
fn the_stream_emits_the_log_from_zero_to_the_end() {
    let log = log();
    let expected: Vec<ImuSample> = log
        .samples()
        .iter()
        .filter(|s| (0..=1000 * MS).contains(&s.t_ns))
        .copied()
        .collect();
    let w = world(log, Vec::new());
    assert_eq!(imu_of(&w), expected);
    // The frames are the simulated rig's, as without a log.
    let frames = w
        .stream()
        .filter(|m| matches!(m, Measurement::Frame(_)))
        .count();
    let simulated = World::new(WorldConfig {
        duration_s: 1.0,
        ..WorldConfig::default()
    })
    .unwrap();
    let frames_sim = simulated
        .stream()
        .filter(|m| matches!(m, Measurement::Frame(_)))
        .count();
    assert_eq!(frames, frames_sim);
    // Ground truth carries the log's biases, linear between samples.
    let mut stream = w.stream();
    let g = stream.truth(502_500_000).unwrap();
    assert!((g.gyro_bias.x - 0.5025).abs() < 1e-12, "{:?}", g.gyro_bias);
    assert!((g.accel_bias.y - 1.005).abs() < 1e-12, "{:?}", g.accel_bias);
}

#[test]
fn faults_apply_to_the_log() {
    let w = world(
        log(),
        vec![Fault::ImuDropout {
            start_ns: 200 * MS,
            end_ns: 400 * MS,
        }],
    );
    let imu = imu_of(&w);
    assert_eq!(imu.len(), 201 - 40);
    assert!(imu.iter().all(|s| !(200 * MS..400 * MS).contains(&s.t_ns)));
}

#[test]
fn a_log_that_misses_part_of_the_run_is_refused() {
    let short: Vec<ImuSample> = log()
        .samples()
        .iter()
        .filter(|s| s.t_ns <= 600 * MS)
        .copied()
        .collect();
    let err = World::new(WorldConfig {
        duration_s: 1.0,
        recorded_imu: Some(Arc::new(RecordedImu::new(short, Vec::new()).unwrap())),
        ..WorldConfig::default()
    })
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("0.600000 s to 1.000000 s are missing"),
        "{err}"
    );
}
