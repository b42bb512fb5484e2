//! Residual factors over the estimator's states (the marginalization prior and the linear
//! factor live beside marginalization, in [`crate::problem`]).
//!
//! State blocks (ambient / tangent): pose `[p, q]` 7/6, speed-bias `[v, ba, bg]` 9/9,
//! extrinsic `T_b_c` 7/6, landmark `[inverse depth, anchor bearing correction]` 3/3, camera-IMU time offset `td` 1/1 (s); the
//! world point 3/3 (the structure from motion's points and the window's persistent landmarks);
//! the GNSS alignment `[t, ψ]` 4/4.

mod aiding;
mod calibration;
mod imu;
mod point;
mod reprojection;
mod zero_velocity;

pub use aiding::{ALIGNMENT_SIZE, BodyVelocityFactor, GnssPositionFactor, yaw_rotation};
pub use calibration::RelativePosePrior;
pub use imu::ImuFactor;
pub use point::{PointProjection, WorldPointProjection};
pub use reprojection::{
    AnchorBearing, FeatureMeasurement, LANDMARK_SIZE, ProjectionOneFrameTwoCam,
    ProjectionTwoFrameOneCam, ProjectionTwoFrameTwoCam,
};
pub use zero_velocity::ZeroVelocityFactor;
