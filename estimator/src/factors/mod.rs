//! Residual factors over the estimator's states (the marginalization prior and the linear
//! factor live beside marginalization, in [`crate::problem`]).
//!
//! State blocks (ambient / tangent): pose `[p, q]` 7/6, speed-bias `[v, ba, bg]` 9/9,
//! extrinsic `T_b_c` 7/6, landmark `[inverse depth, anchor bearing correction]` 3/3, camera-IMU time offset `td` 1/1 (s); the
//! world point 3/3 (the structure from motion's points and the window's persistent landmarks,
//! these in world coordinates or as inverse distance about an anchor: [`PointForm`]);
//! the GNSS alignment `[t, ψ]` 4/4.

mod body_velocity;
mod gnss_position;
mod imu;
mod point;
mod point_form;
mod relative_pose_prior;
mod reprojection;
mod row_blocks;
mod zero_velocity;

pub use body_velocity::BodyVelocityFactor;
pub use gnss_position::{ALIGNMENT_SIZE, GnssPositionFactor, yaw_rotation};
pub use imu::ImuFactor;
pub use point::{PointProjection, WorldPointProjection};
pub use point_form::{PointForm, ScaledRay};
pub use relative_pose_prior::RelativePosePrior;
pub use reprojection::{
    AnchorBearing, FeatureMeasurement, LANDMARK_SIZE, ProjectionOneFrameTwoCam,
    ProjectionTwoFrameOneCam, ProjectionTwoFrameTwoCam,
};
pub use zero_velocity::ZeroVelocityFactor;
