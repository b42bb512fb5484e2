//! The IMU biases as a first-order Gauss–Markov wander about an unknown constant: the model of a
//! bias instability, for an estimator whose sensor has one.
//!
//! A random walk spreads without bound; a real bias instability does not — it wanders by a
//! steady-state deviation `σ_b` with a correlation time `T` about the sensor's turn-on bias `c`
//! (unknown, constant for the flight). Between two states `Δt` apart,
//! `b_j − c = φ·(b_i − c) + w`, `φ = e^{−Δt/T}`, `w ~ N(0, σ_b²(1 − φ²))` — exact for any `Δt`.
//! The estimator holds `c` as one state (`[c_a, c_g]`), every IMU factor's bias rows read
//! `b_j − φ b_i − (1 − φ) c` (the sensor's own random walk added to `w`'s variance), and the
//! first state of a flight is tied to `c` by the process's stationary law, `b₀ − c ~ N(0, σ_b²)`.
//! Over times short against `T` this is a random walk of density `σ_b·√(2/T)`; over longer
//! ones the bias stays within `σ_b` of `c`, which the data pin down better with every
//! correlation time flown.
//!
//! Datasheets (and `vio imu-model`) state a bias instability as its Allan-deviation floor;
//! a first-order Gauss–Markov process's Allan deviation peaks at `0.617·σ_b` near `τ ≈ 1.89·T`.

/// Allan-deviation peak of a first-order Gauss–Markov process per unit steady-state deviation.
pub const ALLAN_PEAK_PER_SIGMA: f64 = 0.6174;

/// Gauss–Markov bias wander of both sensors about their constant turn-on biases.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasProcess {
    /// Accelerometer bias steady-state deviation `σ_b` (m/s²).
    pub sigma_accel: f64,
    /// Gyroscope bias steady-state deviation `σ_b` (rad/s).
    pub sigma_gyro: f64,
    /// Correlation time `T` (s).
    pub correlation_s: f64,
}

impl BiasProcess {
    /// The process whose Allan deviation floors are `gyro_rad_s` and `accel_m_s2`, correlation
    /// time `correlation_s`.
    pub fn from_allan_floors(gyro_rad_s: f64, accel_m_s2: f64, correlation_s: f64) -> Self {
        Self {
            sigma_accel: accel_m_s2 / ALLAN_PEAK_PER_SIGMA,
            sigma_gyro: gyro_rad_s / ALLAN_PEAK_PER_SIGMA,
            correlation_s,
        }
    }

    /// `φ = e^{−Δt/T}`: how much of the bias's deviation from its mean is kept over `dt` (s).
    pub fn keep(&self, dt: f64) -> f64 {
        (-dt.max(0.0) / self.correlation_s).exp()
    }

    /// Variances of the wander's drive over `dt`, `σ_b²(1 − φ²)`: (accelerometer, gyroscope).
    pub fn drive_variances(&self, dt: f64) -> (f64, f64) {
        let k = self.keep(dt);
        let f = 1.0 - k * k;
        (self.sigma_accel.powi(2) * f, self.sigma_gyro.powi(2) * f)
    }

    /// The densities of the random walks the wander spreads like over times short against
    /// `T`, `σ_b·√(2/T)`: (accelerometer m/s³/√Hz, gyroscope rad/s²/√Hz). What an estimator
    /// whose biases only random-walk would add to its random walks.
    pub fn random_walk_equivalents(&self) -> (f64, f64) {
        let per_sigma = (2.0 / self.correlation_s).sqrt();
        (self.sigma_accel * per_sigma, self.sigma_gyro * per_sigma)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_steps_spread_like_the_random_walk_and_long_ones_saturate() {
        let p = BiasProcess::from_allan_floors(4.2e-4, 1.3e-2, 8.4);
        assert!((p.sigma_gyro - 4.2e-4 / 0.6174).abs() < 1e-12);
        // Over 0.1 s (≪ T): σ_b²·2Δt/T, the equivalent random walk, to a relative Δt/T (1.2 %).
        let (_, g) = p.drive_variances(0.1);
        let walk = p.sigma_gyro.powi(2) * 2.0 * 0.1 / 8.4;
        assert!((1.0 - g / walk - 0.1 / 8.4).abs() < 1e-3, "{g} {walk}");
        // Over 100 s (≫ T): the whole steady-state variance, no more.
        let (a, g) = p.drive_variances(100.0);
        assert!((g / p.sigma_gyro.powi(2) - 1.0).abs() < 1e-9);
        assert!((a / p.sigma_accel.powi(2) - 1.0).abs() < 1e-9);
        // Steps compose: keeping over 0.3 s is keeping thrice over 0.1 s.
        assert!((p.keep(0.3) - p.keep(0.1).powi(3)).abs() < 1e-15);
    }
}
