//! IMU samples, noise model and on-manifold preintegration.

use nalgebra::Vector3;

/// One IMU reading in the body (= IMU) frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// Timestamp (ns).
    pub t_ns: i64,
    /// Angular rate ω_b (rad/s).
    pub gyro: Vector3<f64>,
    /// Specific force f_b = R_w_bᵀ (a_w − g_w) (m/s²).
    pub accel: Vector3<f64>,
}

impl ImuSample {
    /// Builds a sample, rejecting non-finite values.
    pub fn new(t_ns: i64, gyro: Vector3<f64>, accel: Vector3<f64>) -> Result<Self, ImuError> {
        if gyro.iter().chain(accel.iter()).any(|v| !v.is_finite()) {
            return Err(ImuError::NonFiniteSample { t_ns });
        }
        Ok(Self { t_ns, gyro, accel })
    }
}

/// IMU noise as Kalibr continuous-time densities.
///
/// Discretized at sample period `dt`: white-noise σ_d = σ_c / √dt; bias random-walk step
/// σ = σ_w · √dt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuNoise {
    /// Gyroscope white noise density (rad/s/√Hz).
    pub gyroscope_noise_density: f64,
    /// Accelerometer white noise density (m/s²/√Hz).
    pub accelerometer_noise_density: f64,
    /// Gyroscope bias random walk (rad/s²/√Hz).
    pub gyroscope_random_walk: f64,
    /// Accelerometer bias random walk (m/s³/√Hz).
    pub accelerometer_random_walk: f64,
}

impl ImuNoise {
    /// Builds a noise model; every density must be finite and > 0.
    pub fn new(
        gyroscope_noise_density: f64,
        accelerometer_noise_density: f64,
        gyroscope_random_walk: f64,
        accelerometer_random_walk: f64,
    ) -> Result<Self, ImuError> {
        for (name, v) in [
            ("gyroscope_noise_density", gyroscope_noise_density),
            ("accelerometer_noise_density", accelerometer_noise_density),
            ("gyroscope_random_walk", gyroscope_random_walk),
            ("accelerometer_random_walk", accelerometer_random_walk),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(ImuError::InvalidNoise {
                    field: name,
                    value: v,
                });
            }
        }
        Ok(Self {
            gyroscope_noise_density,
            accelerometer_noise_density,
            gyroscope_random_walk,
            accelerometer_random_walk,
        })
    }

    /// The EuRoC MAV ADIS16448 values (Kalibr `imu.yaml` of the EuRoC datasets).
    pub fn euroc() -> Self {
        Self {
            gyroscope_noise_density: 1.6968e-4,
            accelerometer_noise_density: 2.0e-3,
            gyroscope_random_walk: 1.9393e-5,
            accelerometer_random_walk: 3.0e-3,
        }
    }
}

/// Errors from IMU constructors and preintegration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ImuError {
    /// A noise density was not finite and positive.
    #[error("IMU noise field `{field}` must be finite and > 0, got {value}")]
    InvalidNoise {
        /// Field name.
        field: &'static str,
        /// Offending value.
        value: f64,
    },
    /// A sample held NaN or ∞.
    #[error("IMU sample at t_ns={t_ns} has non-finite values")]
    NonFiniteSample {
        /// Timestamp of the sample.
        t_ns: i64,
    },
    /// Samples must have strictly increasing timestamps.
    #[error("IMU sample at t_ns={t_ns} does not follow the previous one at {prev_t_ns}")]
    NonIncreasingTime {
        /// Timestamp of the rejected sample.
        t_ns: i64,
        /// Timestamp of the previous sample.
        prev_t_ns: i64,
    },
    /// Merging preintegrations that do not meet end to start.
    #[error("cannot merge: first ends at {end_ns} but second starts at {start_ns}")]
    NotContiguous {
        /// End of the first interval.
        end_ns: i64,
        /// Start of the second interval.
        start_ns: i64,
    },
}
