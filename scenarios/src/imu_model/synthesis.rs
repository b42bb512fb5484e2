//! The residual an error model predicts for a log: what the simulated IMU minus the IMU its
//! ground truth implies would be, sample by sample, without simulating the motion.
//!
//! The simulator's ground truth holds the bias exactly (random walk and bias instability), so
//! its residual is the white noise plus the vibration: the same generators
//! ([`sim::vibration::VibrationSource`]) driven by the recording's ground-truth speed, and white
//! noise at the datasheet densities.

use nalgebra::Vector3;
use rand_distr::{Distribution, StandardNormal};
use sim::rng::sensor_rng;
use sim::vibration::VibrationSource;

use crate::spec::ImuErrorModelSpec;

/// Gyroscope and accelerometer residual series.
pub struct Series {
    /// Gyroscope (rad/s).
    pub gyro: Vec<Vector3<f64>>,
    /// Accelerometer (m/s²).
    pub accel: Vec<Vector3<f64>>,
}

/// The residual `model` predicts for samples every `dt` s at the ground-truth speeds `speed`,
/// with white noise of densities `white` (gyro, accel), drawn from `seed`.
pub fn residual(
    model: &ImuErrorModelSpec,
    white: (f64, f64),
    speed: &[f64],
    dt: f64,
    seed: u64,
) -> Series {
    let mut rng = sensor_rng(seed, "imu");
    let mut vibration = model
        .vibration()
        .map(|v| VibrationSource::new(&v, 1.0 / dt, sensor_rng(seed, "imu/vibration")));
    let (sg, sa) = (white.0 / dt.sqrt(), white.1 / dt.sqrt());
    let mut gyro = Vec::with_capacity(speed.len());
    let mut accel = Vec::with_capacity(speed.len());
    for (i, v) in speed.iter().enumerate() {
        let mut n = || -> f64 { StandardNormal.sample(&mut rng) };
        let mut g = Vector3::new(n(), n(), n()) * sg;
        let mut a = Vector3::new(n(), n(), n()) * sa;
        if let Some(vib) = &mut vibration {
            let (vg, va) = vib.next(i as f64 * dt, *v);
            g += vg;
            a += va;
        }
        gyro.push(g);
        accel.push(a);
    }
    Series { gyro, accel }
}
