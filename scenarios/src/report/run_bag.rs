//! `run.mcap`: a run as a ROS 2 bag for viewers (Foxglove, Rerun, rosbag2 tools), on the run's
//! clock, in message types they display without configuration. The estimate is drawn aligned to
//! the ground truth as the ATE aligns it, so the two overlay in frame `world`:
//!
//! | topic | type | what (and the panel that shows it) |
//! |---|---|---|
//! | `/tf` | `tf2_msgs/msg/TFMessage` | `world → body` (estimate) and `world → body_truth` at every estimate (3D) |
//! | `/tf_static` | `tf2_msgs/msg/TFMessage` | `body → cam<i>`, the estimator's extrinsics at its first estimate (3D) |
//! | `/estimate/pose`, `/groundtruth/pose` | `geometry_msgs/msg/PoseStamped` | every estimate (3D, Plot) |
//! | `/estimate/path`, `/groundtruth/path` | `nav_msgs/msg/Path` | the trajectory so far, at the first estimate of every second and at the end (3D) |
//! | `/estimate/trail`, `/groundtruth/trail` | `sensor_msgs/msg/PointCloud2` | the same trajectories as points (`x y z` float32), at the first estimate of every 0.2 s and at the end: for viewers that draw point clouds but not paths, such as Rerun (3D) |
//! | `/estimate/pose_with_covariance` | `geometry_msgs/msg/PoseWithCovarianceStamped` | with `--covariance`-style runs: the newest pose and its 6×6 covariance, rotation in `world` (3D ellipsoids, Plot) |
//! | `/window/poses` | `geometry_msgs/msg/PoseArray` | the sliding window's frames (3D) |
//! | `/window/points` | `sensor_msgs/msg/PointCloud2` | its persistent points, `x y z` float32 (3D) |
//! | `/estimate/position_error` | `geometry_msgs/msg/Vector3Stamped` | aligned estimate − truth (m) (Plot) |
//! | `/estimate/velocity`, `/estimate/gyro_bias`, `/estimate/accel_bias` | `geometry_msgs/msg/Vector3Stamped` | the state (Plot) |
//! | `/estimate/time_offset_ms`, `/estimate/landmarks`, `/timing/backend_ms` | `std_msgs/msg/Float64` | (Plot) |
//! | `/cam0/tracks` | `sensor_msgs/msg/CompressedImage` | the first camera's features as the estimator received them, each track's trail over its last 20 frames in a colour by age (red new → azure old): JPEG over the camera's image (dimmed) where the input is images (rendered scenarios, `vio euroc`, `vio bag`), PNG on a dark image of the camera's size for feature-level input (Image) |
//! | `/rosout` | `rcl_interfaces/msg/Log` | the report's events (status changes, suite switches, resets, …) and the scenario's faults (Log) |

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::path::Path;

use image::{Rgb, RgbImage};

use estimator::geometry::Pose;
use nalgebra::{Matrix3, Matrix6, Vector3};

use super::{Evaluation, Report, RunContext};
use crate::dataset::ros2::{
    BagWriter, CompressedImage, Float64, Header, Log, Path as RosPath, PointCloud2, PointField,
    PoseArray, PoseStamped, PoseWithCovariance, PoseWithCovarianceStamped, TfMessage, Time,
    TransformStamped, Vector3Stamped,
};
use crate::metrics::Sim3;
use crate::run::RunOutput;
use crate::track_drawing::{CIRCLE_PX, age_colour, circle, line};

/// How often the paths are published (ns of run time).
const PATH_PERIOD_NS: i64 = 1_000_000_000;
/// How often the trails (the paths as point clouds) are published (ns of run time).
const TRAIL_PERIOD_NS: i64 = 200_000_000;

/// Whether `t_ns` falls in another period of `period_ns` than the one in `current` (then
/// `current` becomes its period).
fn enters_period(current: &mut Option<i64>, t_ns: i64, period_ns: i64) -> bool {
    let period = t_ns.div_euclid(period_ns);
    let entered = *current != Some(period);
    *current = Some(period);
    entered
}

fn header(t_ns: i64, frame: &str) -> Header {
    Header {
        stamp: Time::from_ns(t_ns).unwrap_or_default(),
        frame_id: frame.into(),
    }
}

fn transform(parent: &str, child: &str, t_ns: i64, p: &Pose) -> TransformStamped {
    TransformStamped {
        header: header(t_ns, parent),
        child_frame_id: child.into(),
        transform: p.into(),
    }
}

fn stamped(t_ns: i64, p: &Pose) -> PoseStamped {
    PoseStamped {
        header: header(t_ns, "world"),
        pose: p.into(),
    }
}

/// The 6×6 pose covariance in ROS's convention (`x y z` then rotations about the world axes)
/// of the estimator's `[δp (world), δθ (body)]` block: the rotation part turned into `world`.
fn pose_covariance(cov: &nalgebra::DMatrix<f64>, pose: &Pose, align: &Sim3) -> [[f64; 6]; 6] {
    let r_w_b: Matrix3<f64> = align.rotation.matrix() * pose.q.to_rotation_matrix().matrix();
    let a = align.rotation.matrix() * align.scale;
    let mut j = Matrix6::<f64>::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&a);
    j.fixed_view_mut::<3, 3>(3, 3).copy_from(&r_w_b);
    let c = cov.fixed_view::<6, 6>(0, 0).into_owned();
    let c = j * c * j.transpose();
    let mut out = [[0.0; 6]; 6];
    for (i, row) in out.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = c[(i, k)];
        }
    }
    out
}

fn points_cloud(t_ns: i64, points: &[Vector3<f64>]) -> PointCloud2 {
    let field = |name: &str, offset: u32| PointField {
        name: name.into(),
        offset,
        datatype: PointField::FLOAT32,
        count: 1,
    };
    let mut data = Vec::with_capacity(points.len() * 12);
    for p in points {
        for v in [p.x, p.y, p.z] {
            data.extend((v as f32).to_le_bytes());
        }
    }
    PointCloud2 {
        header: header(t_ns, "world"),
        height: 1,
        width: points.len() as u32,
        fields: vec![field("x", 0), field("y", 4), field("z", 8)],
        is_bigendian: false,
        point_step: 12,
        row_step: 12 * points.len() as u32,
        data,
        is_dense: true,
    }
}

fn log(t_ns: i64, level: u8, name: &str, msg: String) -> Log {
    Log {
        stamp: Time::from_ns(t_ns).unwrap_or_default(),
        level,
        name: name.into(),
        msg,
        ..Log::default()
    }
}

/// Writes `run.mcap` (see the module documentation) at `path`.
pub fn write_run_bag(
    path: &Path,
    ctx: &RunContext,
    run: &RunOutput,
    eval: &Evaluation,
    report: &Report,
) -> Result<(), String> {
    let align = eval
        .ate
        .as_ref()
        .map_or_else(|_| Sim3::identity(), |a| a.alignment);
    let mut bag = BagWriter::create(path)?;
    if let Some(first) = run.frames.first() {
        let transforms = first
            .estimate
            .T_b_c
            .iter()
            .enumerate()
            .map(|(i, t)| transform("body", &format!("cam{i}"), first.estimate.t_ns, t))
            .collect();
        bag.write("/tf_static", first.estimate.t_ns, &TfMessage { transforms })?;
    }
    let mut estimate_path = RosPath {
        header: header(0, "world"),
        poses: Vec::new(),
    };
    let mut truth_path = estimate_path.clone();
    let (mut estimate_trail, mut truth_trail) = (Vec::new(), Vec::new());
    // Published at the first estimate of each period of the run's clock, and at the end.
    let (mut path_period, mut trail_period) = (None, None);
    let n = run.frames.len();
    for (k, f) in run.frames.iter().enumerate() {
        let t = f.estimate.t_ns;
        let est = align.transform_pose(&f.estimate.T_w_b);
        let truth = f.truth.pose;
        bag.write(
            "/tf",
            t,
            &TfMessage {
                transforms: vec![
                    transform("world", "body", t, &est),
                    transform("world", "body_truth", t, &truth),
                ],
            },
        )?;
        bag.write("/estimate/pose", t, &stamped(t, &est))?;
        if ctx.ground_truth {
            bag.write("/groundtruth/pose", t, &stamped(t, &truth))?;
        }
        estimate_path.poses.push(stamped(t, &est));
        truth_path.poses.push(stamped(t, &truth));
        estimate_trail.push(est.p);
        truth_trail.push(truth.p);
        let last = k + 1 == n;
        if enters_period(&mut trail_period, t, TRAIL_PERIOD_NS) || last {
            bag.write("/estimate/trail", t, &points_cloud(t, &estimate_trail))?;
            if ctx.ground_truth {
                bag.write("/groundtruth/trail", t, &points_cloud(t, &truth_trail))?;
            }
        }
        if enters_period(&mut path_period, t, PATH_PERIOD_NS) || last {
            estimate_path.header.stamp = Time::from_ns(t).unwrap_or_default();
            truth_path.header.stamp = estimate_path.header.stamp;
            bag.write("/estimate/path", t, &estimate_path)?;
            if ctx.ground_truth {
                bag.write("/groundtruth/path", t, &truth_path)?;
            }
        }
        if let Some(cov) = f.estimate.covariance.as_ref().filter(|c| c.nrows() >= 6) {
            let msg = PoseWithCovarianceStamped {
                header: header(t, "world"),
                pose: PoseWithCovariance {
                    pose: (&est).into(),
                    covariance: pose_covariance(cov, &f.estimate.T_w_b, &align),
                },
            };
            bag.write("/estimate/pose_with_covariance", t, &msg)?;
        }
        if let Some(scene) = &f.scene {
            let poses = PoseArray {
                header: header(t, "world"),
                poses: scene
                    .poses
                    .iter()
                    .map(|p| (&align.transform_pose(p)).into())
                    .collect(),
            };
            bag.write("/window/poses", t, &poses)?;
            let points: Vec<Vector3<f64>> = scene
                .points
                .iter()
                .map(|p| align.transform_point(p))
                .collect();
            bag.write("/window/points", t, &points_cloud(t, &points))?;
        }
        let v3 = |v: &Vector3<f64>, frame: &str| Vector3Stamped {
            header: header(t, frame),
            vector: v.into(),
        };
        if ctx.ground_truth {
            bag.write(
                "/estimate/position_error",
                t,
                &v3(&(est.p - truth.p), "world"),
            )?;
        }
        bag.write("/estimate/velocity", t, &v3(&f.estimate.v_w, "world"))?;
        bag.write("/estimate/gyro_bias", t, &v3(&f.estimate.bg, "body"))?;
        bag.write("/estimate/accel_bias", t, &v3(&f.estimate.ba, "body"))?;
        for (topic, data) in [
            ("/estimate/time_offset_ms", f.estimate.td_s * 1e3),
            ("/estimate/landmarks", f.estimate.landmarks as f64),
            ("/timing/backend_ms", f.timing.backend_s * 1e3),
        ] {
            bag.write(topic, t, &Float64 { data })?;
        }
    }
    // Events and faults, in time order (stable: the report's order at equal times).
    let mut logs: Vec<(i64, Log)> = report
        .events
        .iter()
        .map(|e| {
            let t = (e.t_s * 1e9).round() as i64;
            let level = match e.kind {
                "reset" | "input_rejected" => Log::ERROR,
                "suite_switch" | "prior_dropped" | "gnss_alignment_dropped" => Log::WARN,
                _ => Log::INFO,
            };
            let text = if e.detail.is_empty() {
                e.kind.to_string()
            } else {
                format!("{}: {}", e.kind, e.detail)
            };
            (t, log(t, level, "vio.estimator", text))
        })
        .collect();
    for (name, start, end) in &ctx.faults {
        let t = (start * 1e9).round() as i64;
        logs.push((
            t,
            log(
                t,
                Log::WARN,
                "vio.faults",
                format!("fault {name}: {start} s to {end} s"),
            ),
        ));
    }
    logs.sort_by_key(|(t, _)| *t);
    for (t, l) in logs {
        bag.write("/rosout", t.max(0), &l)?;
    }
    write_tracks(&mut bag, run)?;
    bag.finish()
}

/// JPEG quality of the tracks pictures drawn over camera images.
const TRACKS_JPEG_QUALITY: u8 = 70;
/// Brightness kept of the camera image under the tracks (the strokes stand out).
const BACKGROUND_GAIN: f32 = 0.6;

/// The scene's camera image (greyscale JPEG) as a dimmed RGB picture; `None` if it does not
/// decode.
fn dimmed_background(jpeg: &[u8]) -> Option<RgbImage> {
    let grey = image::load_from_memory_with_format(jpeg, image::ImageFormat::Jpeg)
        .ok()?
        .into_luma8();
    Some(RgbImage::from_fn(grey.width(), grey.height(), |x, y| {
        let g = (f32::from(grey.get_pixel(x, y).0[0]) * BACKGROUND_GAIN).round() as u8;
        Rgb([g, g, g])
    }))
}

/// Positions kept per trail (the newest included).
const TRAIL_FRAMES: usize = 20;

/// A live track: frames seen and its last [`TRAIL_FRAMES`] pixels.
type Trail = (u32, VecDeque<(i64, i64)>);

/// `/cam0/tracks`: each recorded frame's first-camera features with their trails (see the
/// module documentation).
fn write_tracks(bag: &mut BagWriter, run: &RunOutput) -> Result<(), String> {
    let mut trails: BTreeMap<u64, Trail> = BTreeMap::new();
    for f in &run.frames {
        let Some(scene) = &f.scene else {
            continue;
        };
        let Some(&[w, h]) = scene.image_sizes.first() else {
            continue;
        };
        let t = f.estimate.t_ns;
        let seen: Vec<(u64, (i64, i64))> = scene
            .features
            .iter()
            .filter(|(cam, _, _)| *cam == 0)
            .map(|(_, id, uv)| (*id, (uv.x.round() as i64, uv.y.round() as i64)))
            .collect();
        let live: BTreeSet<u64> = seen.iter().map(|(id, _)| *id).collect();
        trails.retain(|id, _| live.contains(id));
        for (id, p) in &seen {
            let (age, trail) = trails.entry(*id).or_default();
            *age += 1;
            trail.push_back(*p);
            if trail.len() > TRAIL_FRAMES {
                trail.pop_front();
            }
        }
        let background = scene.image_jpeg.as_deref().and_then(dimmed_background);
        let over_image = background.is_some();
        let mut img = background.unwrap_or_else(|| RgbImage::from_pixel(w, h, Rgb([24, 24, 24])));
        // Oldest last, so that the long trails stay on top.
        let mut order: Vec<(&u64, &Trail)> = trails.iter().collect();
        order.sort_by_key(|(id, (age, _))| (*age, **id));
        for (_, (age, trail)) in order {
            let colour = age_colour(*age);
            let points: Vec<(i64, i64)> = trail.iter().copied().collect();
            for pair in points.windows(2) {
                line(&mut img, pair[0], pair[1], colour, 1.0);
            }
            if let Some(&p) = points.last() {
                circle(&mut img, p, CIRCLE_PX, colour);
            }
        }
        // Over a camera image JPEG keeps the file small; over the flat background PNG is
        // smaller and sharp.
        let (format, encoded) = if over_image {
            let mut jpeg = Vec::new();
            image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, TRACKS_JPEG_QUALITY)
                .encode_image(&img)
                .map_err(|e| format!("tracks image: {e}"))?;
            ("jpeg", jpeg)
        } else {
            let mut png = Vec::new();
            image::DynamicImage::ImageRgb8(img)
                .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .map_err(|e| format!("tracks image: {e}"))?;
            ("png", png)
        };
        let msg = CompressedImage {
            header: header(t, "cam0"),
            format: format.into(),
            data: encoded,
        };
        bag.write("/cam0/tracks", t, &msg)?;
    }
    Ok(())
}
