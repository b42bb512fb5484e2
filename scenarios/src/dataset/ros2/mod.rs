//! ROS 2 bags in MCAP (rosbag2's default storage): the message types they hold, their CDR
//! encoding, conversions from the estimator's geometry, and a writer and a reader of bags.

mod bag_checksums;
mod bag_reader;
mod bag_writer;
mod camera_info_rig;
mod cdr;
mod conversions;
mod definitions;
mod image_message;
mod messages;

pub use bag_reader::{BagContents, BagFile, Topic};
pub use bag_writer::BagWriter;
pub use camera_info_rig::{camera_info_rig, camera_info_topic};
pub use cdr::{decode, decode_header, encode};
pub use definitions::complete as complete_definition;
pub use image_message::gray_image;
pub use messages::{
    CameraInfo, CompressedImage, Float64, Header, Image, Imu, Log, NavSatFix, NavSatStatus, Path,
    Point, PointCloud2, PointField, Pose, PoseArray, PoseStamped, PoseWithCovariance,
    PoseWithCovarianceStamped, Quaternion, RegionOfInterest, RosMessage, TfMessage, Time,
    Transform, TransformStamped, Twist, TwistStamped, Vector3, Vector3Stamped,
};
