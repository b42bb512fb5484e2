//! A recorded ROS 2 bag (MCAP) as a run's source (`vio bag`).
//!
//! The IMU comes from a `sensor_msgs/msg/Imu` topic, the images from one `sensor_msgs/msg/Image`
//! topic per used camera (`mono8`; stereo captures paired by equal header stamps), or the
//! feature tracks from a `sensor_msgs/msg/PointCloud2` topic as `vio export --format mcap`
//! writes them (fields `cam_id`, `feature_id`, `u`, `v`). Stamps are the messages' header
//! stamps (the sensors' clock), not the times the recorder logged them. The rig comes from
//! Kalibr files: `--camchain` / `--imu-yaml`, else the bag's attachments of those names (as
//! `vio export` attaches them), or with `--camera-info` the bag's own `CameraInfo` messages and
//! `/tf_static` (the noise densities still from `imu.yaml`). Ground truth, when the bag has it: a
//! `geometry_msgs/msg/PoseStamped` or `TransformStamped` topic (default `/groundtruth/pose`);
//! its velocity is the central difference of its positions and its biases are unknown, so the
//! report leaves the bias errors out. The run itself is [`super::recorded`]'s.

use std::path::{Path, PathBuf};

use estimator::frontend::{CameraFeatures, FeatureFrame, FeatureObservation};
use estimator::geometry::Pose;
use estimator::imu::ImuSample;
use nalgebra::{Quaternion, UnitQuaternion, Vector2, Vector3};

use super::recorded::{Frames, ImageRef, RecordedRun, Recording, Setup, camera_config, replay};
use super::{RunControl, RunError, RunOptions};
use crate::dataset::GroundTruthState;
use crate::dataset::kalibr::{camera_sensors, imu_sensor};
use crate::dataset::ros2::{
    BagContents, BagFile, Header, Imu, PointCloud2, PointField, PoseStamped, TransformStamped,
    camera_info_rig, decode_header,
};
use crate::spec::SuiteSpec;

/// How to run a bag (its seed and duration: [`RunOptions`]).
#[derive(Clone, Debug)]
pub struct BagOptions {
    /// The sensors the estimator fuses.
    pub suite: SuiteSpec,
    /// The IMU topic.
    pub imu_topic: String,
    /// The image topic of each camera, left first.
    pub image_topics: Vec<String>,
    /// Feed this feature-track topic instead of tracking the images.
    pub features_topic: Option<String>,
    /// The ground-truth topic (`None`: `/groundtruth/pose` when the bag has it).
    pub groundtruth_topic: Option<String>,
    /// Kalibr `camchain-imucam.yaml` (`None`: the bag's attachment, or its camera infos with
    /// `camera_info`).
    pub camchain: Option<PathBuf>,
    /// The cameras from the bag's own `CameraInfo` messages and `/tf_static` instead of Kalibr
    /// files ([`crate::dataset::ros2::camera_info_rig`]).
    pub camera_info: bool,
    /// Kalibr `imu.yaml` (`None`: the bag's attachment).
    pub imu_yaml: Option<PathBuf>,
    /// A TOML file whose `[estimator]` and `[camera.tracker]` tables are laid over the defaults.
    pub settings: Option<PathBuf>,
    /// Pixel noise σ (px) of every camera.
    pub pixel_sigma_px: f64,
}

/// The ground-truth topic `vio export` writes.
pub const GROUNDTRUTH_TOPIC: &str = "/groundtruth/pose";

impl BagOptions {
    /// `vio bag`'s defaults for `suite`: EuRoC's topic names (`/imu0`, `/cam0/image_raw`,
    /// `/cam1/image_raw`), the images tracked, the rig from the bag's attachments, 1 px.
    pub fn new(suite: SuiteSpec) -> Self {
        Self {
            suite,
            imu_topic: "/imu0".into(),
            image_topics: vec!["/cam0/image_raw".into(), "/cam1/image_raw".into()],
            features_topic: None,
            groundtruth_topic: None,
            camchain: None,
            camera_info: false,
            imu_yaml: None,
            settings: None,
            pixel_sigma_px: 1.0,
        }
    }
}

/// A header's stamp in ns, or an error naming the message.
fn stamp(h: &Header, topic: &str, i: usize) -> Result<i64, String> {
    h.stamp
        .to_ns()
        .ok_or_else(|| format!("topic {topic} message {}: nanosec ≥ 1e9", i + 1))
}

/// A Kalibr file's text: the given file, else the bag's attachment `name`.
fn kalibr_text(
    given: Option<&Path>,
    bag: &BagContents,
    name: &str,
    flag: &str,
) -> Result<(String, String), RunError> {
    if let Some(p) = given {
        let text = sim::input_file::read_to_string(p)
            .map_err(|e| RunError::input(p, format!("cannot read it: {e}")))?;
        return Ok((text, p.display().to_string()));
    }
    let data = bag.attachment(name).ok_or_else(|| {
        RunError::input(
            bag.path,
            format!("no rig: the bag has no `{name}` attachment; give the Kalibr file with {flag}"),
        )
    })?;
    let text = String::from_utf8(data.to_vec())
        .map_err(|_| RunError::input(bag.path, format!("attachment `{name}` is not UTF-8 text")))?;
    Ok((text, format!("{}: attachment {name}", bag.path.display())))
}

/// The IMU log, checked to come in increasing time.
fn imu_log(bag: &BagContents, topic: &str) -> Result<Vec<ImuSample>, String> {
    let mut out: Vec<ImuSample> = Vec::new();
    for (i, (_, m)) in bag.decode_all::<Imu>(topic)?.into_iter().enumerate() {
        let t = stamp(&m.header, topic, i)?;
        let v = |v: crate::dataset::ros2::Vector3| Vector3::new(v.x, v.y, v.z);
        let s = ImuSample::new(t, v(m.angular_velocity), v(m.linear_acceleration))
            .map_err(|e| format!("topic {topic} message {}: {e}", i + 1))?;
        if let Some(prev) = out.last().filter(|p| p.t_ns >= t) {
            return Err(format!(
                "topic {topic} message {}: stamp {t} ns does not follow {} ns",
                i + 1,
                prev.t_ns
            ));
        }
        out.push(s);
    }
    if out.is_empty() {
        return Err(format!("topic {topic} has no messages"));
    }
    Ok(out)
}

/// Each capture every used camera has, paired by header stamp.
fn image_frames<'a>(
    bag: &'a BagContents<'a>,
    topics: &[String],
) -> Result<Vec<(i64, Vec<ImageRef<'a>>)>, String> {
    let mut per_camera = Vec::new();
    for topic in topics {
        let t = bag.topic::<crate::dataset::ros2::Image>(topic)?;
        let mut stamped = Vec::with_capacity(t.messages.len());
        for (i, (_, data)) in t.messages.iter().enumerate() {
            let h =
                decode_header(data).map_err(|e| format!("topic {topic} message {}: {e}", i + 1))?;
            stamped.push((stamp(&h, topic, i)?, i, data));
        }
        stamped.sort_by_key(|(t, i, _)| (*t, *i));
        per_camera.push(stamped);
    }
    let mut out = Vec::new();
    for &(t, i, data) in &per_camera[0] {
        let mut refs = vec![ImageRef::Message {
            data: std::borrow::Cow::Borrowed(data.as_ref()),
            bag: bag.path,
            what: format!("topic {} message {}", topics[0], i + 1),
        }];
        for (c, other) in per_camera.iter().enumerate().skip(1) {
            if let Ok(k) = other.binary_search_by_key(&t, |(s, _, _)| *s) {
                let (_, j, d) = other[k];
                refs.push(ImageRef::Message {
                    data: std::borrow::Cow::Borrowed(d.as_ref()),
                    bag: bag.path,
                    what: format!("topic {} message {}", topics[c], j + 1),
                });
            }
        }
        if refs.len() == topics.len() {
            out.push((t, refs));
        }
    }
    Ok(out)
}

/// The feature tracks of a `PointCloud2` topic (see the module documentation).
fn feature_frames(
    bag: &BagContents,
    topic: &str,
    cameras: usize,
) -> Result<Vec<FeatureFrame>, String> {
    let mut out = Vec::new();
    for (i, (_, m)) in bag
        .decode_all::<PointCloud2>(topic)?
        .into_iter()
        .enumerate()
    {
        let at = |what: String| format!("topic {topic} message {}: {what}", i + 1);
        let field = |name: &str, datatype: u8| {
            m.fields
                .iter()
                .find(|f| f.name == name && f.datatype == datatype && f.count == 1)
                .map(|f| f.offset as usize)
                .ok_or_else(|| at(format!("no {name} field of datatype {datatype}")))
        };
        let cam = field("cam_id", PointField::UINT32)?;
        let id = field("feature_id", PointField::UINT32)?;
        let u = field("u", PointField::FLOAT64)?;
        let v = field("v", PointField::FLOAT64)?;
        let step = m.point_step as usize;
        let n = m.width as usize * m.height as usize;
        if m.is_bigendian || [cam + 4, id + 4, u + 8, v + 8].iter().any(|&e| e > step) {
            return Err(at("fields outside the point, or big-endian".into()));
        }
        if m.data.len() < n * step {
            return Err(at(format!(
                "{n} points of {step} bytes need {} bytes",
                n * step
            )));
        }
        let mut frame = FeatureFrame {
            t_ns: stamp(&m.header, topic, i)?,
            cameras: (0..cameras)
                .map(|cam_id| CameraFeatures {
                    cam_id,
                    features: Vec::new(),
                })
                .collect(),
        };
        for p in m.data.chunks_exact(step).take(n) {
            let u32_at = |o: usize| u32::from_le_bytes([p[o], p[o + 1], p[o + 2], p[o + 3]]);
            let f64_at = |o: usize| f64::from_le_bytes(p[o..o + 8].try_into().unwrap_or([0; 8]));
            let c = u32_at(cam) as usize;
            let uv = Vector2::new(f64_at(u), f64_at(v));
            if !(uv.x.is_finite() && uv.y.is_finite()) {
                return Err(at("a non-finite pixel".into()));
            }
            if let Some(cf) = frame.cameras.get_mut(c) {
                cf.features.push(FeatureObservation {
                    feature_id: u64::from(u32_at(id)),
                    uv,
                });
            }
        }
        out.push(frame);
    }
    Ok(out)
}

/// Ground truth from a pose topic; velocities by central differences, biases unknown (zero).
fn ground_truth(bag: &BagContents, topic: &str) -> Result<Vec<GroundTruthState>, String> {
    if !bag.topics.contains_key(topic) {
        return Ok(Vec::new());
    }
    let pose = |p: Vector3<f64>, q: &crate::dataset::ros2::Quaternion| {
        let q = Quaternion::new(q.w, q.x, q.y, q.z);
        (q.norm() > 0.5).then(|| Pose::new(UnitQuaternion::new_normalize(q), p))
    };
    let mut poses: Vec<(i64, Option<Pose>)> = Vec::new();
    if bag.topic::<PoseStamped>(topic).is_ok() {
        for (i, (_, m)) in bag
            .decode_all::<PoseStamped>(topic)?
            .into_iter()
            .enumerate()
        {
            let p = m.pose.position;
            poses.push((
                stamp(&m.header, topic, i)?,
                pose(Vector3::new(p.x, p.y, p.z), &m.pose.orientation),
            ));
        }
    } else {
        for (i, (_, m)) in bag
            .decode_all::<TransformStamped>(topic)?
            .into_iter()
            .enumerate()
        {
            let p = m.transform.translation;
            poses.push((
                stamp(&m.header, topic, i)?,
                pose(Vector3::new(p.x, p.y, p.z), &m.transform.rotation),
            ));
        }
    }
    let mut out: Vec<GroundTruthState> = Vec::with_capacity(poses.len());
    for (i, (t, p)) in poses.iter().enumerate() {
        let p = p.ok_or_else(|| format!("topic {topic} message {}: a zero quaternion", i + 1))?;
        if out.last().is_some_and(|g| g.t_ns >= *t) {
            return Err(format!(
                "topic {topic} message {}: stamp {t} ns does not follow the previous one",
                i + 1
            ));
        }
        out.push(GroundTruthState {
            t_ns: *t,
            pose: p,
            velocity: Vector3::zeros(),
            gyro_bias: Vector3::zeros(),
            accel_bias: Vector3::zeros(),
        });
    }
    let n = out.len();
    for i in 0..n {
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let dt = (out[b].t_ns - out[a].t_ns) as f64 * 1e-9;
        if dt > 0.0 {
            out[i].velocity = (out[b].pose.p - out[a].pose.p) / dt;
        }
    }
    Ok(out)
}

/// Runs the image front end (or the bag's feature tracks) and the estimator over the bag.
pub(crate) fn replay_bag(
    path: &Path,
    options: &BagOptions,
    run: &RunOptions,
    control: &mut RunControl,
) -> Result<RecordedRun, RunError> {
    let n_cams = options.suite.suite().cameras();
    let file = BagFile::open(path).map_err(|e| RunError::input(path, e))?;
    let bag = file.contents().map_err(|e| RunError::input(path, e))?;
    let bad = |e: String| RunError::input(path, e);
    let (imu_text, imu_name) =
        kalibr_text(options.imu_yaml.as_deref(), &bag, "imu.yaml", "--imu-yaml")?;
    let imu = imu_sensor(&imu_text, &imu_name).map_err(|e| RunError::input(path, e.to_string()))?;
    let (sensors, camchain_name) = if options.camera_info {
        let topics = options.image_topics.get(..n_cams).ok_or_else(|| {
            bad(format!(
                "the {} suite needs {n_cams} image topic(s) (their camera_info topics give the rig)",
                options.suite.as_str()
            ))
        })?;
        let sensors = camera_info_rig(&bag, topics, &options.imu_topic).map_err(bad)?;
        (sensors, "the bag's camera infos".to_string())
    } else {
        let (camchain, camchain_name) = kalibr_text(
            options.camchain.as_deref(),
            &bag,
            "camchain-imucam.yaml",
            "--camchain",
        )?;
        let sensors = camera_sensors(&camchain, &camchain_name)
            .map_err(|e| RunError::input(path, e.to_string()))?;
        (sensors, camchain_name)
    };
    if sensors.len() < n_cams {
        return Err(bad(format!(
            "the {} suite needs {n_cams} camera(s); {camchain_name} has {}",
            options.suite.as_str(),
            sensors.len()
        )));
    }
    let mut cameras = Vec::new();
    for (i, s) in sensors.iter().take(n_cams).enumerate() {
        let model = s
            .camera()
            .map_err(|e| bad(format!("{camchain_name}: cam{i}: {e}")))?;
        cameras.push(camera_config(
            model,
            &imu.t_bs,
            &s.t_bs,
            options.pixel_sigma_px,
        ));
    }
    let frames = match &options.features_topic {
        Some(topic) => Frames::Features(feature_frames(&bag, topic, n_cams).map_err(bad)?),
        None => {
            if options.image_topics.len() < n_cams {
                return Err(bad(format!(
                    "the {} suite needs {n_cams} image topic(s), {} given",
                    options.suite.as_str(),
                    options.image_topics.len()
                )));
            }
            Frames::Images(image_frames(&bag, &options.image_topics[..n_cams]).map_err(bad)?)
        }
    };
    let empty = match &frames {
        Frames::Images(v) => v.is_empty(),
        Frames::Features(v) => v.is_empty(),
    };
    if empty {
        return Err(bad("no camera frames to run on".into()));
    }
    let gt_topic = options
        .groundtruth_topic
        .as_deref()
        .unwrap_or(GROUNDTRUTH_TOPIC);
    if options.groundtruth_topic.is_some() && !bag.topics.contains_key(gt_topic) {
        return Err(bad(format!("no ground-truth topic {gt_topic}")));
    }
    let recording = Recording {
        imu: imu_log(&bag, &options.imu_topic).map_err(bad)?,
        imu_noise: imu.noise,
        cameras,
        groundtruth: ground_truth(&bag, gt_topic).map_err(bad)?,
        truth_biases: false,
        frames,
        name: path
            .file_stem()
            .map_or("bag".into(), |n| n.to_string_lossy().into_owned()),
        label: path.display().to_string(),
    };
    let setup = Setup {
        suite: options.suite,
        settings: options.settings.as_deref(),
    };
    replay(recording, setup, run, control)
}
