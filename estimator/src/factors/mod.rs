//! Residual factors over the estimator's states (the marginalization prior and the linear
//! factor live beside marginalization, in [`crate::problem`]).
//!
//! State blocks (ambient / tangent): pose `[p, q]` 7/6, speed-bias `[v, ba, bg]` 9/9,
//! extrinsic `T_b_c` 7/6, inverse depth 1/1, camera-IMU time offset `td` 1/1 (s); the
//! structure from motion's world point 3/3.

mod imu;
mod point;
mod reprojection;

pub use imu::ImuFactor;
pub use point::PointProjection;
pub use reprojection::{
    FeatureMeasurement, ProjectionOneFrameTwoCam, ProjectionTwoFrameOneCam,
    ProjectionTwoFrameTwoCam,
};
