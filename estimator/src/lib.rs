//! `estimator`: optimization-based sliding-window visual-inertial odometry after
//! "A General Optimization-based Framework for Local Odometry Estimation with Multiple Sensors"
//! (Qin et al., VINS-Fusion). Every sensor contributes residual factors over shared states; the
//! factors are summed into one nonlinear least-squares problem.
//!
//! This crate knows nothing about simulation: it is the product for real sensors.
//!
//! The front door: an [`Estimator`] built from an [`EstimatorConfig`] takes [`ImuSample`]s,
//! [`FeatureFrame`]s (from [`frontend::FeatureTracker`] or any tracker), [`GnssSample`]s and
//! [`WheelSample`]s in time order and answers with [`Estimate`]s (each with its [`Status`]) and
//! [`Event`]s. The modules below are its parts, for those who build their own:
//!
//! - [`odometry`]: the sliding-window estimator itself (window, initialization,
//!   marginalization, health checks, online calibration);
//! - [`problem`]: the nonlinear least-squares problem and its solver;
//! - [`factors`]: the residuals (IMU, reprojection, prior, GNSS, wheel, calibration);
//! - [`frontend`]: the KLT image front end; [`camera`]: camera models; [`imu`]:
//!   preintegration; [`bias_process`]: the biases' Gauss–Markov model; [`aiding_samples`]: GNSS
//!   and wheel inputs; [`geometry`]: poses and rotations.

pub mod aiding_samples;
pub mod bias_process;
pub mod camera;
pub mod factors;
pub mod frontend;
pub mod geometry;
pub mod imu;
pub mod odometry;
pub mod problem;

pub use aiding_samples::{GnssSample, WheelSample};
pub use frontend::FeatureFrame;
pub use imu::ImuSample;
pub use odometry::{
    CameraConfig, ConfigError, Estimate, Estimator, EstimatorConfig, EstimatorError, Event,
    EventKind, FilterEstimate, GnssConfig, HealthLimits, ImuNoiseModel, LiveSuite,
    PointCoordinates, Status, Suite, WheelConfig, ZeroVelocityConfig,
};

/// Standard gravity magnitude (m/s²); the world frame is z-up with `g_w = (0, 0, −GRAVITY)`.
pub const GRAVITY: f64 = 9.81;

/// Gravity vector in the world frame.
pub fn gravity_w() -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::new(0.0, 0.0, -GRAVITY)
}
