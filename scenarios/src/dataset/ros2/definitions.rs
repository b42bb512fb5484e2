//! The `.msg` definitions of the message types in [`super::messages`], and their complete
//! `ros2msg` form as rosbag2 stores it in a bag's schema: the type's own text first, then each
//! type it uses (recursively, each once) after a line of 80 `=` and a `MSG: package/Name` line
//! (the name as fields spell it, as rosbag2 writes it; readers that look the name up as written,
//! Rerun's among them, need that spelling). Readers that know no ROS (Foxglove, the Python `mcap-ros2-support`) decode the bag with
//! these texts alone. Field lines only: the comments of the ROS sources are not repeated.

/// A type's name (`package/msg/Name`) and its `.msg` text.
pub type Definition = (&'static str, &'static str);

/// Every type a bag here uses.
pub const ALL: &[Definition] = &[
    ("builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec\n"),
    (
        "std_msgs/msg/Header",
        "builtin_interfaces/Time stamp\nstring frame_id\n",
    ),
    (
        "geometry_msgs/msg/Vector3",
        "float64 x\nfloat64 y\nfloat64 z\n",
    ),
    (
        "geometry_msgs/msg/Point",
        "float64 x\nfloat64 y\nfloat64 z\n",
    ),
    (
        "geometry_msgs/msg/Quaternion",
        "float64 x\nfloat64 y\nfloat64 z\nfloat64 w\n",
    ),
    (
        "geometry_msgs/msg/Pose",
        "Point position\nQuaternion orientation\n",
    ),
    (
        "geometry_msgs/msg/PoseStamped",
        "std_msgs/Header header\nPose pose\n",
    ),
    (
        "geometry_msgs/msg/Transform",
        "Vector3 translation\nQuaternion rotation\n",
    ),
    (
        "geometry_msgs/msg/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
    ),
    (
        "tf2_msgs/msg/TFMessage",
        "geometry_msgs/TransformStamped[] transforms\n",
    ),
    (
        "geometry_msgs/msg/Twist",
        "Vector3 linear\nVector3 angular\n",
    ),
    (
        "geometry_msgs/msg/TwistStamped",
        "std_msgs/Header header\nTwist twist\n",
    ),
    (
        "sensor_msgs/msg/Imu",
        "std_msgs/Header header\n\
         geometry_msgs/Quaternion orientation\n\
         float64[9] orientation_covariance\n\
         geometry_msgs/Vector3 angular_velocity\n\
         float64[9] angular_velocity_covariance\n\
         geometry_msgs/Vector3 linear_acceleration\n\
         float64[9] linear_acceleration_covariance\n",
    ),
    (
        "sensor_msgs/msg/Image",
        "std_msgs/Header header\n\
         uint32 height\n\
         uint32 width\n\
         string encoding\n\
         uint8 is_bigendian\n\
         uint32 step\n\
         uint8[] data\n",
    ),
    (
        "sensor_msgs/msg/RegionOfInterest",
        "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n",
    ),
    (
        "sensor_msgs/msg/CameraInfo",
        "std_msgs/Header header\n\
         uint32 height\n\
         uint32 width\n\
         string distortion_model\n\
         float64[] d\n\
         float64[9] k\n\
         float64[9] r\n\
         float64[12] p\n\
         uint32 binning_x\n\
         uint32 binning_y\n\
         RegionOfInterest roi\n",
    ),
    (
        "sensor_msgs/msg/NavSatStatus",
        "int8 STATUS_NO_FIX = -1\n\
         int8 STATUS_FIX = 0\n\
         int8 STATUS_SBAS_FIX = 1\n\
         int8 STATUS_GBAS_FIX = 2\n\
         int8 status\n\
         uint16 SERVICE_GPS = 1\n\
         uint16 SERVICE_GLONASS = 2\n\
         uint16 SERVICE_COMPASS = 4\n\
         uint16 SERVICE_GALILEO = 8\n\
         uint16 service\n",
    ),
    (
        "sensor_msgs/msg/NavSatFix",
        "std_msgs/Header header\n\
         NavSatStatus status\n\
         float64 latitude\n\
         float64 longitude\n\
         float64 altitude\n\
         float64[9] position_covariance\n\
         uint8 COVARIANCE_TYPE_UNKNOWN = 0\n\
         uint8 COVARIANCE_TYPE_APPROXIMATED = 1\n\
         uint8 COVARIANCE_TYPE_DIAGONAL_KNOWN = 2\n\
         uint8 COVARIANCE_TYPE_KNOWN = 3\n\
         uint8 position_covariance_type\n",
    ),
    (
        "sensor_msgs/msg/PointField",
        "uint8 INT8 = 1\n\
         uint8 UINT8 = 2\n\
         uint8 INT16 = 3\n\
         uint8 UINT16 = 4\n\
         uint8 INT32 = 5\n\
         uint8 UINT32 = 6\n\
         uint8 FLOAT32 = 7\n\
         uint8 FLOAT64 = 8\n\
         string name\n\
         uint32 offset\n\
         uint8 datatype\n\
         uint32 count\n",
    ),
    (
        "sensor_msgs/msg/PointCloud2",
        "std_msgs/Header header\n\
         uint32 height\n\
         uint32 width\n\
         PointField[] fields\n\
         bool is_bigendian\n\
         uint32 point_step\n\
         uint32 row_step\n\
         uint8[] data\n\
         bool is_dense\n",
    ),
    (
        "geometry_msgs/msg/PoseArray",
        "std_msgs/Header header\nPose[] poses\n",
    ),
    (
        "nav_msgs/msg/Path",
        "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses\n",
    ),
    (
        "geometry_msgs/msg/PoseWithCovariance",
        "Pose pose\nfloat64[36] covariance\n",
    ),
    (
        "geometry_msgs/msg/PoseWithCovarianceStamped",
        "std_msgs/Header header\nPoseWithCovariance pose\n",
    ),
    (
        "geometry_msgs/msg/Vector3Stamped",
        "std_msgs/Header header\nVector3 vector\n",
    ),
    ("std_msgs/msg/Float64", "float64 data\n"),
    (
        "sensor_msgs/msg/CompressedImage",
        "std_msgs/Header header\nstring format\nuint8[] data\n",
    ),
    (
        "rcl_interfaces/msg/Log",
        "byte DEBUG=10\n\
         byte INFO=20\n\
         byte WARN=30\n\
         byte ERROR=40\n\
         byte FATAL=50\n\
         builtin_interfaces/Time stamp\n\
         uint8 level\n\
         string name\n\
         string msg\n\
         string file\n\
         string function\n\
         uint32 line\n",
    ),
];

const PRIMITIVES: &[&str] = &[
    "bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64",
    "uint64", "float32", "float64", "string", "wstring",
];

fn text_of(name: &str) -> &'static str {
    ALL.iter()
        .find(|(n, _)| *n == name)
        .map(|(_, t)| *t)
        .unwrap_or_else(|| panic!("no definition of {name}"))
}

/// The full names of the non-primitive field types of `name`'s text, in order of appearance.
fn uses(name: &str) -> Vec<String> {
    let package = name.split('/').next().unwrap_or("");
    let mut out = Vec::new();
    for line in text_of(name).lines() {
        let Some(ty) = line.split_whitespace().next() else {
            continue;
        };
        // A constant (`uint8 FOO = 1`) has a primitive type; arrays end in `[]` or `[N]`.
        let ty = ty.split('[').next().unwrap_or(ty);
        if PRIMITIVES.contains(&ty) || ty.starts_with("string<") {
            continue;
        }
        let full = match ty.split_once('/') {
            Some((pkg, t)) => format!("{pkg}/msg/{t}"),
            None => format!("{package}/msg/{ty}"),
        };
        if !out.contains(&full) {
            out.push(full);
        }
    }
    out
}

/// `name`'s complete `ros2msg` definition (see the module documentation). Panics for a type not
/// in the table of this module: the table is this crate's own.
pub fn complete(name: &str) -> String {
    let mut order: Vec<String> = Vec::new();
    let mut stack = uses(name);
    stack.reverse();
    while let Some(t) = stack.pop() {
        if order.contains(&t) {
            continue;
        }
        let mut more = uses(&t);
        more.reverse();
        order.push(t);
        stack.extend(more);
    }
    let mut out = text_of(name).to_string();
    for t in order {
        out.push_str(&"=".repeat(80));
        out.push_str(&format!("\nMSG: {}\n", t.replacen("/msg/", "/", 1)));
        out.push_str(text_of(&t));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_used_has_a_definition_and_each_appears_once() {
        for (name, _) in ALL {
            let text = complete(name);
            for (t, _) in ALL {
                let header = format!("MSG: {}\n", t.replacen("/msg/", "/", 1));
                assert!(text.matches(&header).count() <= 1, "{name}: {t} twice");
            }
        }
        let imu = complete("sensor_msgs/msg/Imu");
        for t in [
            "std_msgs/Header",
            "builtin_interfaces/Time",
            "geometry_msgs/Quaternion",
            "geometry_msgs/Vector3",
        ] {
            assert!(imu.contains(&format!("MSG: {t}\n")), "{t}");
        }
        assert!(imu.starts_with("std_msgs/Header header\n"));
    }
}
