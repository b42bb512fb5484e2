//! The ROS 2 message types the bags hold, as Rust structs whose field order is the `.msg` field
//! order (CDR writes fields in declaration order, fixed-size arrays without a length, sequences
//! and strings with one), each with its type name and its complete `ros2msg` definition.

use serde::{Deserialize, Serialize};

use super::definitions;

/// A message type of a bag: its name and complete definition.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> {
    /// `package/msg/Name`.
    const TYPE: &'static str;
    /// The `.msg` text of this type and, after rosbag2's delimiters, of every type it uses.
    fn definition() -> String {
        definitions::complete(Self::TYPE)
    }
}

macro_rules! message {
    ($t:ty, $name:literal) => {
        impl RosMessage for $t {
            const TYPE: &'static str = $name;
        }
    };
}

/// `builtin_interfaces/msg/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds in `[0, 1e9)`.
    pub nanosec: u32,
}

impl Time {
    /// The stamp of `t_ns` nanoseconds, `None` outside what `int32` seconds hold.
    pub fn from_ns(t_ns: i64) -> Option<Self> {
        let sec = i32::try_from(t_ns.div_euclid(1_000_000_000)).ok()?;
        Some(Self {
            sec,
            nanosec: t_ns.rem_euclid(1_000_000_000) as u32,
        })
    }

    /// Nanoseconds, `None` for `nanosec ≥ 1e9`.
    pub fn to_ns(self) -> Option<i64> {
        (self.nanosec < 1_000_000_000)
            .then(|| i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec))
    }
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// The measurement's time.
    pub stamp: Time,
    /// The frame its data are expressed in.
    pub frame_id: String,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Point`.
pub type Point = Vector3;

/// `geometry_msgs/msg/Quaternion` (Hamilton, `x, y, z, w`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}
message!(PoseStamped, "geometry_msgs/msg/PoseStamped");

/// `geometry_msgs/msg/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation.
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`: `child_frame_id` expressed in `header.frame_id`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent.
    pub transform: Transform,
}
message!(TransformStamped, "geometry_msgs/msg/TransformStamped");

/// `tf2_msgs/msg/TFMessage` (`/tf`, `/tf_static`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TfMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}
message!(TfMessage, "tf2_msgs/msg/TFMessage");

/// `geometry_msgs/msg/Twist`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity.
    pub linear: Vector3,
    /// Angular velocity.
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The twist.
    pub twist: Twist,
}
message!(TwistStamped, "geometry_msgs/msg/TwistStamped");

/// `sensor_msgs/msg/Imu`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Imu {
    /// Stamp and frame.
    pub header: Header,
    /// Orientation (unknown: covariance element 0 is −1).
    pub orientation: Quaternion,
    /// Row-major 3×3.
    pub orientation_covariance: [f64; 9],
    /// rad/s.
    pub angular_velocity: Vector3,
    /// Row-major 3×3.
    pub angular_velocity_covariance: [f64; 9],
    /// m/s² (specific force).
    pub linear_acceleration: Vector3,
    /// Row-major 3×3.
    pub linear_acceleration_covariance: [f64; 9],
}
message!(Imu, "sensor_msgs/msg/Imu");

/// `sensor_msgs/msg/Image`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// Stamp and frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`mono8`).
    pub encoding: String,
    /// Whether multi-byte pixels are big-endian.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// `step × height` bytes.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}
message!(Image, "sensor_msgs/msg/Image");

/// `sensor_msgs/msg/RegionOfInterest`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left column.
    pub x_offset: u32,
    /// Top row.
    pub y_offset: u32,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Whether to rectify.
    pub do_rectify: bool,
}

/// `sensor_msgs/msg/CameraInfo`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Stamp and frame.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// `plumb_bob` (radial-tangential `k1 k2 t1 t2 k3`) or `equidistant` (`k1…k4`).
    pub distortion_model: String,
    /// Distortion coefficients.
    pub d: Vec<f64>,
    /// Intrinsic matrix, row-major.
    pub k: [f64; 9],
    /// Rectification rotation, row-major.
    pub r: [f64; 9],
    /// Projection matrix, row-major 3×4.
    pub p: [f64; 12],
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}
message!(CameraInfo, "sensor_msgs/msg/CameraInfo");

/// `sensor_msgs/msg/NavSatStatus`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavSatStatus {
    /// −1 no fix, 0 fix, 1 SBAS, 2 GBAS.
    pub status: i8,
    /// Bit mask: 1 GPS, 2 GLONASS, 4 COMPASS, 8 GALILEO.
    pub service: u16,
}

/// `sensor_msgs/msg/NavSatFix`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavSatFix {
    /// Stamp and frame.
    pub header: Header,
    /// Fix status.
    pub status: NavSatStatus,
    /// Degrees, WGS-84.
    pub latitude: f64,
    /// Degrees, WGS-84.
    pub longitude: f64,
    /// Metres above the WGS-84 ellipsoid.
    pub altitude: f64,
    /// ENU, row-major 3×3 (m²).
    pub position_covariance: [f64; 9],
    /// 0 unknown, 1 approximated, 2 diagonal known, 3 known.
    pub position_covariance_type: u8,
}
message!(NavSatFix, "sensor_msgs/msg/NavSatFix");

/// `sensor_msgs/msg/PointField`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointField {
    /// Field name.
    pub name: String,
    /// Byte offset in a point.
    pub offset: u32,
    /// [`PointField::UINT32`], [`PointField::FLOAT64`], ….
    pub datatype: u8,
    /// Elements.
    pub count: u32,
}

impl PointField {
    /// `uint32`.
    pub const UINT32: u8 = 6;
    /// `float32`.
    pub const FLOAT32: u8 = 7;
    /// `float64`.
    pub const FLOAT64: u8 = 8;
}

/// `sensor_msgs/msg/PointCloud2`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Stamp and frame.
    pub header: Header,
    /// Rows (1: unordered).
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// The layout of a point.
    pub fields: Vec<PointField>,
    /// Whether the data are big-endian.
    pub is_bigendian: bool,
    /// Bytes per point.
    pub point_step: u32,
    /// Bytes per row.
    pub row_step: u32,
    /// The points.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
    /// No invalid points.
    pub is_dense: bool,
}
message!(PointCloud2, "sensor_msgs/msg/PointCloud2");

/// `geometry_msgs/msg/PoseArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseArray {
    /// Stamp and frame.
    pub header: Header,
    /// The poses.
    pub poses: Vec<Pose>,
}
message!(PoseArray, "geometry_msgs/msg/PoseArray");

/// `nav_msgs/msg/Path`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Path {
    /// Stamp and frame.
    pub header: Header,
    /// The poses, oldest first.
    pub poses: Vec<PoseStamped>,
}
message!(Path, "nav_msgs/msg/Path");

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6×6 over `(x, y, z, rotation about x, y, z)`, all in the header's frame (rows
    /// of six: the same 36 numbers on the wire as `float64[36]`).
    pub covariance: [[f64; 6]; 6],
}

/// `geometry_msgs/msg/PoseWithCovarianceStamped`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovarianceStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose and its covariance.
    pub pose: PoseWithCovariance,
}
message!(
    PoseWithCovarianceStamped,
    "geometry_msgs/msg/PoseWithCovarianceStamped"
);

/// `geometry_msgs/msg/Vector3Stamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3Stamped {
    /// Stamp and frame.
    pub header: Header,
    /// The vector.
    pub vector: Vector3,
}
message!(Vector3Stamped, "geometry_msgs/msg/Vector3Stamped");

/// `std_msgs/msg/Float64`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64 {
    /// The value.
    pub data: f64,
}
message!(Float64, "std_msgs/msg/Float64");

/// `rcl_interfaces/msg/Log` (`/rosout`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Log {
    /// When.
    pub stamp: Time,
    /// [`Log::INFO`], [`Log::WARN`], [`Log::ERROR`], ….
    pub level: u8,
    /// The logger's name.
    pub name: String,
    /// The message.
    pub msg: String,
    /// Source file.
    pub file: String,
    /// Function.
    pub function: String,
    /// Line.
    pub line: u32,
}
message!(Log, "rcl_interfaces/msg/Log");

impl Log {
    /// Information.
    pub const INFO: u8 = 20;
    /// A warning.
    pub const WARN: u8 = 30;
    /// An error.
    pub const ERROR: u8 = 40;
}

/// `sensor_msgs/msg/CompressedImage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Stamp and frame.
    pub header: Header,
    /// `png` or `jpeg`.
    pub format: String,
    /// The encoded image.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}
message!(CompressedImage, "sensor_msgs/msg/CompressedImage");
