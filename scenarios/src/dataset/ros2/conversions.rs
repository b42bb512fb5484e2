//! The geometry types of the estimator as ROS 2 message parts (what every bag writer here
//! needs): vectors, unit quaternions (Hamilton, `x y z w`), poses and transforms.

use estimator::geometry::Pose as BodyPose;
use nalgebra::UnitQuaternion;

use super::messages::{Pose, Quaternion, Transform, Vector3};

impl From<&nalgebra::Vector3<f64>> for Vector3 {
    fn from(v: &nalgebra::Vector3<f64>) -> Self {
        Self {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}

impl From<&UnitQuaternion<f64>> for Quaternion {
    fn from(q: &UnitQuaternion<f64>) -> Self {
        let q = q.quaternion();
        Self {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }
    }
}

impl From<&BodyPose> for Pose {
    fn from(p: &BodyPose) -> Self {
        Self {
            position: (&p.p).into(),
            orientation: (&p.q).into(),
        }
    }
}

impl From<&BodyPose> for Transform {
    fn from(p: &BodyPose) -> Self {
        Self {
            translation: (&p.p).into(),
            rotation: (&p.q).into(),
        }
    }
}
