//! Bias instability: the slow wander of an IMU's bias that a random walk does not describe,
//! modelled as a first-order Gauss–Markov process per axis on top of the random walk.
//!
//! A Gauss–Markov process of steady-state deviation `σ_b` and correlation time `T` has its Allan
//! deviation peak at `≈ 0.617·σ_b` near `τ ≈ 1.89·T` (the peak of
//! `σ²(τ) = 2σ_b²/x·(1 − (3 − 4e^{−x} + e^{−2x})/(2x))`, `x = τ/T`). Datasheets and `vio
//! imu-model` state the bias instability as that Allan floor, so the configuration takes the
//! floor and the correlation time and derives `σ_b = floor / 0.617`. The process starts from
//! its steady-state distribution and steps exactly: `b ← e^{−Δ/T}·b + σ_b·√(1 − e^{−2Δ/T})·n`.

use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Allan-deviation peak of a first-order Gauss–Markov process per unit steady-state deviation
/// (the estimator's model of the same process uses the same constant).
pub use estimator::bias_process::ALLAN_PEAK_PER_SIGMA;

/// Bias instability of both sensors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasInstability {
    /// Gyroscope Allan-deviation floor (rad/s).
    pub gyro_rad_s: f64,
    /// Accelerometer Allan-deviation floor (m/s²).
    pub accel_m_s2: f64,
    /// Correlation time of the process (s); the floor sits near `1.89×` it.
    pub correlation_s: f64,
}

/// The Gauss–Markov bias parts, stepped once per IMU sample.
#[derive(Debug)]
pub struct BiasWander {
    gyro: Vector3<f64>,
    accel: Vector3<f64>,
    keep: f64,
    drive: f64,
    sigma_gyro: f64,
    sigma_accel: f64,
    rng: ChaCha8Rng,
}

fn gauss3(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    let mut n = || -> f64 { StandardNormal.sample(rng) };
    Vector3::new(n(), n(), n())
}

impl BiasWander {
    /// The process for samples every `period_s`, drawing from `rng` (its own stream).
    pub fn new(b: &BiasInstability, period_s: f64, mut rng: ChaCha8Rng) -> Self {
        let sigma_gyro = b.gyro_rad_s / ALLAN_PEAK_PER_SIGMA;
        let sigma_accel = b.accel_m_s2 / ALLAN_PEAK_PER_SIGMA;
        let keep = (-period_s / b.correlation_s).exp();
        let gyro = gauss3(&mut rng) * sigma_gyro;
        let accel = gauss3(&mut rng) * sigma_accel;
        Self {
            gyro,
            accel,
            keep,
            drive: (1.0 - keep * keep).sqrt(),
            sigma_gyro,
            sigma_accel,
            rng,
        }
    }

    /// The current (gyro, accel) wander.
    pub fn current(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.gyro, self.accel)
    }

    /// Steps to the next sample.
    pub fn step(&mut self) {
        let n = gauss3(&mut self.rng);
        self.gyro = self.gyro * self.keep + n * (self.sigma_gyro * self.drive);
        let n = gauss3(&mut self.rng);
        self.accel = self.accel * self.keep + n * (self.sigma_accel * self.drive);
    }
}
