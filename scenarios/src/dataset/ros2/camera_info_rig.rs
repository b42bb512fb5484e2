//! The cameras a bag describes itself, without Kalibr files: each camera's first
//! `sensor_msgs/msg/CameraInfo` (on the `camera_info` topic beside its image topic) for the
//! model, and `/tf_static` for where it sits relative to the IMU (the IMU's frame is its
//! messages' `frame_id`, a camera's its camera info's). `plumb_bob` is read as radial-tangential
//! (`k3` must be 0), `equidistant` as Kannala-Brandt; the transforms may chain through a common
//! parent (`base_link → imu`, `base_link → camera`).

use std::collections::BTreeMap;

use estimator::geometry::Pose;
use nalgebra::Vector3;

use super::bag_reader::BagContents;
use super::messages::{CameraInfo, Imu, TfMessage};
use crate::dataset::CameraSensor;

/// The `camera_info` topic beside an image topic (`/cam0/image_raw` → `/cam0/camera_info`).
pub fn camera_info_topic(image_topic: &str) -> String {
    match image_topic.rsplit_once('/') {
        Some((dir, _)) => format!("{dir}/camera_info"),
        None => "camera_info".into(),
    }
}

/// Every static transform of the bag: child frame → (parent frame, `T_parent_child`).
fn static_transforms(bag: &BagContents) -> Result<BTreeMap<String, (String, Pose)>, String> {
    let mut out = BTreeMap::new();
    if !bag.topics.contains_key("/tf_static") {
        return Ok(out);
    }
    for (_, m) in bag.decode_all::<TfMessage>("/tf_static")? {
        for t in m.transforms {
            let r = t.transform.rotation;
            // Kept bit for bit when unit to 1e-12 (as every reader here keeps a quaternion).
            let q = crate::dataset::unit_quaternion(r.w, r.x, r.y, r.z).map_err(|e| {
                format!(
                    "/tf_static {} → {}: {e}",
                    t.header.frame_id, t.child_frame_id
                )
            })?;
            let p = t.transform.translation;
            let pose = Pose::new(q, Vector3::new(p.x, p.y, p.z));
            out.insert(t.child_frame_id, (t.header.frame_id, pose));
        }
    }
    Ok(out)
}

/// `(root frame, T_root_frame)` by walking `frame`'s parents.
fn to_root(tf: &BTreeMap<String, (String, Pose)>, frame: &str) -> (String, Pose) {
    let mut pose = Pose::identity();
    let mut at = frame.to_string();
    // A tree has at most as many edges as frames; a loop in a broken bag stops there.
    for _ in 0..=tf.len() {
        let Some((parent, t)) = tf.get(&at) else {
            break;
        };
        pose = t.compose(&pose);
        at = parent.clone();
    }
    (at, pose)
}

/// The pose of frame `child` in frame `parent` from the static transforms.
fn relative(
    tf: &BTreeMap<String, (String, Pose)>,
    parent: &str,
    child: &str,
) -> Result<Pose, String> {
    let (root_p, t_root_parent) = to_root(tf, parent);
    let (root_c, t_root_child) = to_root(tf, child);
    if root_p != root_c {
        return Err(format!(
            "/tf_static does not connect `{parent}` (root `{root_p}`) and `{child}` (root `{root_c}`)"
        ));
    }
    Ok(t_root_parent.inverse().compose(&t_root_child))
}

/// One camera's calibration from its first camera info, placed in the IMU frame.
fn camera(
    bag: &BagContents,
    image_topic: &str,
    imu_frame: &str,
    tf: &BTreeMap<String, (String, Pose)>,
) -> Result<CameraSensor, String> {
    let topic = camera_info_topic(image_topic);
    let infos = bag.decode_all::<CameraInfo>(&topic)?;
    let (_, info) = infos
        .into_iter()
        .next()
        .ok_or_else(|| format!("topic {topic} has no messages"))?;
    let k = info.k;
    let (distortion_model, coefficients) = match info.distortion_model.as_str() {
        "plumb_bob" | "radial-tangential" => {
            if info.d.len() > 4 && info.d[4..].iter().any(|&v| v != 0.0) {
                return Err(format!(
                    "{topic}: plumb_bob with k3 = {}: the estimator's radial-tangential model has k1 k2 p1 p2 only",
                    info.d[4]
                ));
            }
            let mut d = info.d.clone();
            d.resize(4, 0.0);
            d.truncate(4);
            ("radial-tangential", d)
        }
        "equidistant" => {
            if info.d.len() != 4 {
                return Err(format!(
                    "{topic}: equidistant needs 4 coefficients, got {}",
                    info.d.len()
                ));
            }
            ("equidistant", info.d.clone())
        }
        other => {
            return Err(format!(
                "{topic}: distortion model `{other}`: plumb_bob or equidistant are read (or give Kalibr files with --camchain)"
            ));
        }
    };
    let t_imu_cam =
        relative(tf, imu_frame, &info.header.frame_id).map_err(|e| format!("{topic}: {e}"))?;
    Ok(CameraSensor {
        comment: format!("{topic} in a bag"),
        t_bs: t_imu_cam,
        rate_hz: 0.0,
        resolution: [info.width, info.height],
        camera_model: "pinhole".into(),
        intrinsics: vec![k[0], k[4], k[2], k[5]],
        distortion_model: distortion_model.into(),
        distortion_coefficients: coefficients,
    })
}

/// The cameras of `image_topics` as the bag describes them (see the module documentation), in
/// the frame of the IMU on `imu_topic` (so each `t_bs` is `T_imu_cam`).
pub fn camera_info_rig(
    bag: &BagContents,
    image_topics: &[String],
    imu_topic: &str,
) -> Result<Vec<CameraSensor>, String> {
    let imu_frame = {
        let t = bag.topic::<Imu>(imu_topic)?;
        let (_, data) = t
            .messages
            .first()
            .ok_or_else(|| format!("topic {imu_topic} has no messages"))?;
        super::cdr::decode_header(data)
            .map_err(|e| format!("topic {imu_topic} message 1: {e}"))?
            .frame_id
    };
    let tf = static_transforms(bag)?;
    image_topics
        .iter()
        .map(|topic| camera(bag, topic, &imu_frame, &tf))
        .collect()
}
