//! The ROS 2 bag (MCAP) an export writes, on the simulation's clock (header stamps = log times,
//! ns from the run's start), frames `world` (gravity-aligned, z up), `imu0` (the body) and
//! `cam<i>`:
//!
//! | topic | type | what |
//! |---|---|---|
//! | `/imu0` | `sensor_msgs/msg/Imu` | every IMU sample; covariances are the discrete white-noise variances (σ_c² · rate), orientation unknown (`orientation_covariance[0] = −1`) |
//! | `/cam<i>/image_raw` | `sensor_msgs/msg/Image` | rendered scenarios: every image, `mono8` |
//! | `/cam<i>/camera_info` | `sensor_msgs/msg/CameraInfo` | with every image (feature-level scenarios: every frame); `plumb_bob` (radial-tangential, k3 = 0) or `equidistant`; Mei and double-sphere cameras name Kalibr's model and list its extra intrinsics first in `d` (no ROS model holds them) |
//! | `/features` | `sensor_msgs/msg/PointCloud2` | every frame's feature observations: fields `cam_id` (uint32), `feature_id` (uint32, the ids of `features.csv`), `u`, `v` (float64, distorted pixels) |
//! | `/groundtruth/pose` | `geometry_msgs/msg/PoseStamped` | the body's true pose in `world` at every IMU sample |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | the same as `world → imu0` |
//! | `/tf_static` | `tf2_msgs/msg/TFMessage` | `imu0 → cam<i>` (each camera's `T_b_c`), once, latched |
//! | `/gnss/fix` | `sensor_msgs/msg/NavSatFix` | GNSS fixes: the local ENU position about the reference [`GNSS_ORIGIN`], WGS-84, covariance diagonal |
//! | `/wheel/twist` | `geometry_msgs/msg/TwistStamped` | wheel odometry: the forward speed as `linear.x` in `imu0` |
//!
//! Attachments: `camchain-imucam.yaml` and `imu.yaml` (the rig as Kalibr files, as in the ASL
//! export). Feature tracks come last in the file (their ids are numbered once the run is over);
//! readers that go by log time, as rosbag2 and Foxglove do, see them in place.

use std::path::Path;

use estimator::frontend::FeatureFrame;
use estimator::imu::ImuSample;
use estimator::{GnssSample, WheelSample};
use sim::render::ImageFrame;

use super::rig::{ExportRig, IMU_TOPIC, image_topic};
use super::sink::{ExportError, ExportSink};
use crate::dataset::ros2::{
    BagWriter, CameraInfo, Header, Image, Imu, NavSatFix, NavSatStatus, PointCloud2, PointField,
    PoseStamped, Quaternion, RegionOfInterest, TfMessage, Time, TransformStamped, TwistStamped,
};
use crate::dataset::{CameraSensor, GroundTruthState, ImuSensor};

/// Where a simulated GNSS receiver's local ENU frame is anchored on the WGS-84 ellipsoid
/// (latitude °, longitude °, altitude m): a point in Zürich, chosen once; only the NavSatFix
/// messages depend on it.
pub const GNSS_ORIGIN: (f64, f64, f64) = (47.3769, 8.5417, 408.0);

/// The camera-info topic of camera `i`.
fn info_topic(i: usize) -> String {
    format!("/cam{i}/camera_info")
}

fn header(t_ns: i64, frame: &str) -> Result<Header, ExportError> {
    Ok(Header {
        stamp: Time::from_ns(t_ns).ok_or_else(|| {
            ExportError::Write(format!(
                "stamp {t_ns} ns does not fit a ROS 2 time (int32 seconds)"
            ))
        })?,
        frame_id: frame.into(),
    })
}

fn diagonal(v: [f64; 3]) -> [f64; 9] {
    [v[0], 0.0, 0.0, 0.0, v[1], 0.0, 0.0, 0.0, v[2]]
}

/// A camera's `CameraInfo` (see the module documentation for the models).
fn camera_info(c: &CameraSensor, header: Header) -> CameraInfo {
    let [w, h] = c.resolution;
    // Kalibr order: pinhole [fu, fv, cu, cv]; omni [xi, …]; ds [xi, alpha, …].
    let extra = c.intrinsics.len().saturating_sub(4);
    let (fx, fy, cx, cy) = match c.intrinsics[extra..] {
        [fx, fy, cx, cy] => (fx, fy, cx, cy),
        _ => (0.0, 0.0, 0.0, 0.0),
    };
    let (model, d) = match (c.camera_model.as_str(), c.distortion_model.as_str()) {
        ("pinhole", "radial-tangential") => {
            let mut d = c.distortion_coefficients.clone();
            d.resize(5, 0.0);
            ("plumb_bob".to_string(), d)
        }
        ("pinhole", "equidistant") => ("equidistant".into(), c.distortion_coefficients.clone()),
        (m, dist) => {
            let mut d = c.intrinsics[..extra].to_vec();
            d.extend(&c.distortion_coefficients);
            (format!("kalibr:{m}:{dist}"), d)
        }
    };
    CameraInfo {
        header,
        height: h,
        width: w,
        distortion_model: model,
        d,
        k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        binning_x: 0,
        binning_y: 0,
        roi: RegionOfInterest::default(),
    }
}

/// `/features` for one frame (see the module documentation).
fn features_cloud(frame: &FeatureFrame) -> Result<PointCloud2, ExportError> {
    let field = |name: &str, offset: u32, datatype: u8| PointField {
        name: name.into(),
        offset,
        datatype,
        count: 1,
    };
    let mut data = Vec::new();
    let mut n = 0u32;
    for c in &frame.cameras {
        for o in &c.features {
            let id = u32::try_from(o.feature_id).map_err(|_| {
                ExportError::Write(format!("feature id {} beyond 32 bits", o.feature_id))
            })?;
            data.extend((c.cam_id as u32).to_le_bytes());
            data.extend(id.to_le_bytes());
            data.extend(o.uv.x.to_le_bytes());
            data.extend(o.uv.y.to_le_bytes());
            n += 1;
        }
    }
    Ok(PointCloud2 {
        header: header(frame.t_ns, "cam0")?,
        height: 1,
        width: n,
        fields: vec![
            field("cam_id", 0, PointField::UINT32),
            field("feature_id", 4, PointField::UINT32),
            field("u", 8, PointField::FLOAT64),
            field("v", 16, PointField::FLOAT64),
        ],
        is_bigendian: false,
        point_step: 24,
        row_step: 24 * n,
        data,
        is_dense: true,
    })
}

/// Writes a bag.
pub(super) struct Ros2Bag {
    bag: BagWriter,
    imu: ImuSensor,
    cameras: Vec<CameraSensor>,
    /// Whether images came (then camera infos go with them, else with the feature frames).
    had_images: bool,
}

impl Ros2Bag {
    pub(super) fn create(path: &Path, rig: ExportRig) -> Result<Self, ExportError> {
        let mut bag = BagWriter::create(path).map_err(ExportError::Write)?;
        bag.attach(
            "camchain-imucam.yaml",
            "application/yaml",
            rig.camchain.as_bytes(),
        )
        .map_err(ExportError::Write)?;
        bag.attach("imu.yaml", "application/yaml", rig.imu_yaml.as_bytes())
            .map_err(ExportError::Write)?;
        let mut transforms = Vec::new();
        for (i, c) in rig.cameras.iter().enumerate() {
            transforms.push(TransformStamped {
                header: header(0, "imu0")?,
                child_frame_id: format!("cam{i}"),
                transform: (&c.t_bs).into(),
            });
        }
        bag.write("/tf_static", 0, &TfMessage { transforms })
            .map_err(ExportError::Write)?;
        Ok(Self {
            bag,
            imu: rig.imu,
            cameras: rig.cameras,
            had_images: false,
        })
    }

    fn write<T: crate::dataset::ros2::RosMessage>(
        &mut self,
        topic: &str,
        t_ns: i64,
        msg: &T,
    ) -> Result<(), ExportError> {
        self.bag.write(topic, t_ns, msg).map_err(ExportError::Write)
    }

    fn camera_infos(
        &mut self,
        t_ns: i64,
        cams: impl Iterator<Item = usize>,
    ) -> Result<(), ExportError> {
        for i in cams {
            let Some(c) = self.cameras.get(i) else {
                continue;
            };
            let msg = camera_info(c, header(t_ns, &format!("cam{i}"))?);
            self.write(&info_topic(i), t_ns, &msg)?;
        }
        Ok(())
    }
}

impl ExportSink for Ros2Bag {
    fn imu(&mut self, s: &ImuSample, truth: Option<&GroundTruthState>) -> Result<(), ExportError> {
        let n = &self.imu.noise;
        let rate = self.imu.rate_hz;
        let g = n.gyroscope_noise_density.powi(2) * rate;
        let a = n.accelerometer_noise_density.powi(2) * rate;
        let mut orientation_covariance = [0.0; 9];
        orientation_covariance[0] = -1.0;
        let msg = Imu {
            header: header(s.t_ns, "imu0")?,
            orientation: Quaternion::default(),
            orientation_covariance,
            angular_velocity: (&s.gyro).into(),
            angular_velocity_covariance: diagonal([g; 3]),
            linear_acceleration: (&s.accel).into(),
            linear_acceleration_covariance: diagonal([a; 3]),
        };
        self.write(IMU_TOPIC, s.t_ns, &msg)?;
        if let Some(gt) = truth {
            let pose = PoseStamped {
                header: header(gt.t_ns, "world")?,
                pose: (&gt.pose).into(),
            };
            self.write("/groundtruth/pose", gt.t_ns, &pose)?;
            let tf = TfMessage {
                transforms: vec![TransformStamped {
                    header: header(gt.t_ns, "world")?,
                    child_frame_id: "imu0".into(),
                    transform: (&gt.pose).into(),
                }],
            };
            self.write("/tf", gt.t_ns, &tf)?;
        }
        Ok(())
    }

    fn images(&mut self, frame: &ImageFrame) -> Result<(), ExportError> {
        self.had_images = true;
        for c in &frame.cameras {
            let msg = Image {
                header: header(frame.t_ns, &format!("cam{}", c.cam_id))?,
                height: c.image.height,
                width: c.image.width,
                encoding: "mono8".into(),
                is_bigendian: 0,
                step: c.image.width,
                data: c.image.data.clone(),
            };
            self.write(&image_topic(c.cam_id), frame.t_ns, &msg)?;
        }
        self.camera_infos(frame.t_ns, frame.cameras.iter().map(|c| c.cam_id))
    }

    fn gnss(&mut self, fix: &GnssSample) -> Result<(), ExportError> {
        let (lat0, lon0, alt0) = GNSS_ORIGIN;
        let (lat, lon, alt) = map_3d::enu2geodetic(
            fix.p_g.x,
            fix.p_g.y,
            fix.p_g.z,
            lat0.to_radians(),
            lon0.to_radians(),
            alt0,
            map_3d::Ellipsoid::WGS84,
        );
        let s = fix.sigma_m;
        let msg = NavSatFix {
            header: header(fix.t_ns, "imu0")?,
            status: NavSatStatus {
                status: 0,
                service: 1,
            },
            latitude: lat.to_degrees(),
            longitude: lon.to_degrees(),
            altitude: alt,
            position_covariance: diagonal([s.x * s.x, s.y * s.y, s.z * s.z]),
            position_covariance_type: 2,
        };
        self.write("/gnss/fix", fix.t_ns, &msg)
    }

    fn wheel(&mut self, reading: &WheelSample) -> Result<(), ExportError> {
        let mut msg = TwistStamped {
            header: header(reading.t_ns, "imu0")?,
            ..TwistStamped::default()
        };
        msg.twist.linear.x = reading.speed_m_s;
        self.write("/wheel/twist", reading.t_ns, &msg)
    }

    fn finish(mut self: Box<Self>, frames: &[FeatureFrame]) -> Result<(), ExportError> {
        for f in frames {
            self.write("/features", f.t_ns, &features_cloud(f)?)?;
            if !self.had_images {
                let cams: Vec<usize> = (0..self.cameras.len()).collect();
                self.camera_infos(f.t_ns, cams.into_iter())?;
            }
        }
        self.bag.finish().map_err(ExportError::Write)
    }
}
