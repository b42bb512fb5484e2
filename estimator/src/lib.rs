//! `estimator`: optimization-based sliding-window visual-inertial odometry after
//! "A General Optimization-based Framework for Local Odometry Estimation with Multiple Sensors"
//! (Qin et al., VINS-Fusion). Every sensor contributes residual factors over shared states; the
//! factors are summed into one nonlinear least-squares problem.
//!
//! This crate knows nothing about simulation: it is the product for real sensors.

pub mod aiding;
pub mod camera;
pub mod estimator;
pub mod factors;
pub mod frontend;
pub mod geometry;
pub mod imu;
pub mod problem;

/// Standard gravity magnitude (m/s²); the world frame is z-up with `g_w = (0, 0, −GRAVITY)`.
pub const GRAVITY: f64 = 9.81;

/// Gravity vector in the world frame.
pub fn gravity_w() -> nalgebra::Vector3<f64> {
    nalgebra::Vector3::new(0.0, 0.0, -GRAVITY)
}
