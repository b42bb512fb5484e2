//! The IMU's error model beyond the datasheet: vibration is quiet at rest and at its stated RMS
//! in motion, bias instability wanders at its stated level and is part of the ground-truth
//! bias, and an IMU without them draws the same samples as before they existed.

use std::sync::Arc;

use nalgebra::{UnitQuaternion, Vector3};
use sim::bias_instability::{ALLAN_PEAK_PER_SIGMA, BiasInstability, BiasWander};
use sim::imu::{ImuBias, ImuConfig, ImuSim, ImuWindow};
use sim::motion::{BodyParams, ControllerGains, MotionSim, RefState, Reference, TruthBuffer};
use sim::rng::sensor_rng;
use sim::vibration::{ActivityProxy, Vibration, VibrationBand, VibrationLine, VibrationProfile};

/// A level body moving along x at a constant speed (0: at rest).
#[derive(Debug)]
struct Cruise(f64);

impl Reference for Cruise {
    fn state(&self, t: f64) -> RefState {
        RefState {
            p: Vector3::new(self.0 * t, 0.0, 0.0),
            v: Vector3::new(self.0, 0.0, 0.0),
            a: Vector3::zeros(),
            q: UnitQuaternion::identity(),
            omega_w: Vector3::zeros(),
            alpha_w: Vector3::zeros(),
        }
    }

    fn duration(&self) -> Option<f64> {
        None
    }
}

/// `n` samples at 200 Hz of a noise-free IMU with `cfg`'s error model, cruising at `speed`:
/// each sample's reading less the ideal one and its bias, and the bias.
fn errors(cfg: ImuConfig, speed: f64, n: usize, seed: u64) -> Vec<(Vector3<f64>, ImuBias)> {
    let cfg = ImuConfig {
        window: ImuWindow::Forward,
        noise: None,
        initial_gyro_bias: Vector3::zeros(),
        initial_accel_bias: Vector3::zeros(),
        gyro_range: None,
        accel_range: None,
        ..cfg
    };
    let motion = MotionSim::new(
        Arc::new(Cruise(speed)),
        BodyParams::default(),
        ControllerGains::default(),
        cfg.period_ns(),
        0,
    );
    let mut truth = TruthBuffer::new(motion);
    let mut imu = ImuSim::new(cfg, seed);
    (0..n)
        .map(|_| {
            let t = imu.next_time_ns();
            let (ideal_f, _) = imu.ideal(&mut truth, t);
            let (s, b) = imu.next_sample(&mut truth);
            truth.trim(imu.needs_from_ns());
            (s.accel - ideal_f - b.accel, b)
        })
        .collect()
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

fn shaking_in_flight() -> Vibration {
    Vibration {
        rest: VibrationProfile::default(),
        flight: VibrationProfile {
            bands: vec![VibrationBand {
                lo_hz: 20.0,
                hi_hz: 40.0,
                gyro_rms: Vector3::zeros(),
                accel_rms: Vector3::new(0.5, 0.3, 0.0),
            }],
            lines: vec![VibrationLine {
                freq_hz: 60.0,
                gyro_rms: Vector3::zeros(),
                accel_rms: Vector3::new(0.0, 0.0, 0.2),
            }],
        },
        activity: ActivityProxy {
            speed_at_rest_m_s: 0.02,
            speed_in_flight_m_s: 0.05,
            time_constant_s: 0.0,
        },
    }
}

#[test]
fn vibration_is_silent_at_rest_and_at_its_rms_in_motion() {
    let cfg = ImuConfig {
        vibration: Some(shaking_in_flight()),
        ..ImuConfig::default()
    };
    let still = errors(cfg.clone(), 0.0, 4000, 1);
    let largest = still.iter().map(|(e, _)| e.amax()).fold(0.0, f64::max);
    assert!(largest < 1e-9, "at rest the platform shakes by {largest}");

    // 60 s in motion: the band's and the line's RMS per axis, within 4 % (the band estimate's
    // scatter over ~2400 independent cycles is about 2 %).
    let moving = errors(cfg, 1.0, 12_000, 1);
    let axis = |a: usize| rms(&moving.iter().map(|(e, _)| e[a]).collect::<Vec<_>>());
    for (a, want) in [(0, 0.5), (1, 0.3), (2, 0.2)] {
        let got = axis(a);
        assert!((got / want - 1.0).abs() < 0.04, "axis {a}: {got} vs {want}");
    }
}

#[test]
fn the_activity_blends_the_profiles_by_speed() {
    let a = shaking_in_flight().activity;
    assert_eq!(a.target(0.0), 0.0);
    assert_eq!(a.target(0.02), 0.0);
    assert!((a.target(0.035) - 0.5).abs() < 1e-12);
    assert_eq!(a.target(3.0), 1.0);
}

#[test]
fn bias_instability_wanders_at_its_stated_level_and_is_in_the_ground_truth_bias() {
    // The steady-state deviation σ_b = floor / 0.617 over 2000 correlation times.
    let b = BiasInstability {
        gyro_rad_s: 1e-4,
        accel_m_s2: 2e-3,
        correlation_s: 0.5,
    };
    let mut w = BiasWander::new(&b, 0.005, sensor_rng(4, "imu/bias_instability"));
    let mut g = Vec::new();
    let mut acc = Vec::new();
    for _ in 0..200_000 {
        let (x, y) = w.current();
        g.push(x.x);
        acc.push(y.z);
        w.step();
    }
    let sigma = |floor: f64| floor / ALLAN_PEAK_PER_SIGMA;
    assert!((rms(&g) / sigma(1e-4) - 1.0).abs() < 0.08, "{}", rms(&g));
    assert!(
        (rms(&acc) / sigma(2e-3) - 1.0).abs() < 0.08,
        "{}",
        rms(&acc)
    );

    // Through the IMU: the reading carries the wander, and so does its ground-truth bias.
    let cfg = ImuConfig {
        bias_instability: Some(b),
        ..ImuConfig::default()
    };
    let e = errors(cfg, 0.0, 2000, 4);
    let left = e.iter().map(|(x, _)| x.amax()).fold(0.0, f64::max);
    assert!(left < 1e-9, "reading less ideal less bias: {left}");
    let spread = e
        .iter()
        .map(|(_, b)| b.accel.x)
        .fold(0.0, |m: f64, x| m.max(x.abs()));
    assert!(
        spread > 0.2 * sigma(2e-3),
        "the bias does not wander: {spread}"
    );
}

#[test]
fn an_imu_without_an_error_model_draws_what_it_drew_before() {
    // The datasheet IMU's stream is its own; vibration draws from its own stream, so an IMU
    // with a vibration model that is silent (at rest) draws exactly the datasheet samples.
    let cfg = ImuConfig {
        window: ImuWindow::Forward,
        ..ImuConfig::default()
    };
    let motion = MotionSim::new(
        Arc::new(Cruise(0.0)),
        BodyParams::default(),
        ControllerGains::default(),
        cfg.period_ns(),
        0,
    );
    let mut truth = TruthBuffer::new(motion);
    let mut plain = ImuSim::new(cfg.clone(), 9);
    let vibrating = ImuConfig {
        vibration: Some(shaking_in_flight()),
        ..cfg
    };
    let mut shaken = ImuSim::new(vibrating, 9);
    for _ in 0..50 {
        let (a, _) = plain.next_sample(&mut truth);
        let (b, _) = shaken.next_sample(&mut truth);
        // At rest the vibration is silent: the two IMUs agree sample for sample.
        assert_eq!(a.accel, b.accel);
        assert_eq!(a.gyro, b.gyro);
    }
}
