//! The estimator's configuration: [`EstimatorConfig`] and the sub-configurations it holds, each
//! with its defaults and its range checks ([`ConfigError`] names the field). The floor of
//! `odometry`: it uses none of the modules that use it.

mod error;
mod estimator_config;
mod gnss_wheel;
mod health_limits;
mod imu_noise_model;
mod validation;
mod zero_velocity;

pub use error::ConfigError;
pub use estimator_config::{
    CameraConfig, EstimatorConfig, MAX_PERSISTENT_POINTS, MAX_WINDOW_SIZE, PointCoordinates, Suite,
};
pub use gnss_wheel::{GnssConfig, WheelConfig};
pub use health_limits::HealthLimits;
pub use imu_noise_model::ImuNoiseModel;
pub use zero_velocity::ZeroVelocityConfig;
