//! A scenario's rig as the exported files describe it: each camera's `sensor.yaml`
//! calibration, the IMU's, and the same rig as Kalibr files.

use estimator::EstimatorConfig;
use estimator::geometry::Pose;
use estimator::imu::ImuNoise;
use nalgebra::{Matrix3, Rotation3};

use crate::dataset::{
    CameraSensor, ImuSensor, KalibrCamera, KalibrImu, format_camchain, format_imu_yaml,
};
use crate::spec::{ModelSpec, Scenario};

/// The exported rig.
pub struct ExportRig {
    /// The IMU's `sensor.yaml` (body = IMU frame).
    pub imu: ImuSensor,
    /// Each camera's `sensor.yaml`.
    pub cameras: Vec<CameraSensor>,
    /// `camchain-imucam.yaml`.
    pub camchain: String,
    /// `imu.yaml`.
    pub imu_yaml: String,
}

/// The image topic of camera `i` in a bag (EuRoC's bag names).
pub fn image_topic(i: usize) -> String {
    format!("/cam{i}/image_raw")
}

/// The IMU topic in a bag.
pub const IMU_TOPIC: &str = "/imu0";

/// Kalibr's `camera_model`, `intrinsics`, `distortion_model` (camchain spelling),
/// `distortion_coeffs` for a scenario camera.
fn kalibr_camera(
    model: ModelSpec,
    intr: [f64; 4],
    dist: &[f64],
    xi: Option<f64>,
    alpha: Option<f64>,
) -> (&'static str, Vec<f64>, &'static str, Vec<f64>) {
    let [fu, fv, cu, cv] = intr;
    match model {
        ModelSpec::PinholeRadtan => ("pinhole", vec![fu, fv, cu, cv], "radtan", dist.to_vec()),
        ModelSpec::KannalaBrandt => (
            "pinhole",
            vec![fu, fv, cu, cv],
            "equidistant",
            dist.to_vec(),
        ),
        ModelSpec::Mei => (
            "omni",
            vec![xi.unwrap_or(0.0), fu, fv, cu, cv],
            "radtan",
            dist.to_vec(),
        ),
        ModelSpec::DoubleSphere => (
            "ds",
            vec![xi.unwrap_or(0.0), alpha.unwrap_or(0.0), fu, fv, cu, cv],
            "none",
            Vec::new(),
        ),
    }
}

/// `sensor.yaml` spells Kalibr's `radtan` out.
fn sensor_yaml_distortion(kalibr: &str) -> &str {
    match kalibr {
        "radtan" => "radial-tangential",
        other => other,
    }
}

/// The rig of `scenario` with the estimator's configuration `est`: the IMU noise the estimator
/// assumes (`[estimator.imu_noise]` over the sensor's; a bias instability folded into the
/// random walks, which is all a Kalibr file can say) and each camera's `T_b_c` as the
/// estimator starts from it (a camera's `calibration_error` and the seed's drawn calibration
/// error included, as a calibration tool would have reported it).
pub(crate) fn export_rig(scenario: &Scenario, est: &EstimatorConfig) -> ExportRig {
    let spec = &scenario.spec;
    let noise: ImuNoise = est.assumed_imu_noise_as_random_walks();
    let imu = ImuSensor {
        comment: format!("vio simulated IMU, scenario {}", scenario.name),
        t_bs: Pose::identity(),
        rate_hz: spec.rig.imu.rate_hz,
        noise,
    };
    let mut cameras = Vec::new();
    let mut kalibr = Vec::new();
    for (i, (c, cam)) in spec.rig.cameras.iter().zip(&est.cameras).enumerate() {
        let (camera_model, intrinsics, distortion_model, coeffs) =
            kalibr_camera(c.model, c.intrinsics, &c.distortion, c.xi, c.alpha);
        cameras.push(CameraSensor {
            comment: format!("vio simulated camera {i}, scenario {}", scenario.name),
            t_bs: cam.T_b_c,
            rate_hz: spec.rig.rate_hz,
            resolution: c.resolution,
            camera_model: camera_model.into(),
            intrinsics: intrinsics.clone(),
            distortion_model: sensor_yaml_distortion(distortion_model).into(),
            distortion_coefficients: coeffs.clone(),
        });
        // The rotation as the scenario wrote it when it wrote a matrix and the estimator uses
        // it unchanged (its transpose is then exact), else the estimator's quaternion's.
        let off_truth = c.calibration_error.is_some() || spec.rig.calibration_draw.is_some();
        let r_b_c: Matrix3<f64> = match (c.T_b_c.rotation, off_truth) {
            (Some(rows), false) => Matrix3::from_fn(|a, b| rows[a][b]),
            _ => Rotation3::from(cam.T_b_c.q).into_inner(),
        };
        // A quaternion as given (the scenario's, or the estimator's when it starts off the
        // truth): no matrix of doubles carries it bit for bit.
        let quaternion_xyzw = match (c.T_b_c.quaternion_xyzw, off_truth) {
            (Some(q), false) => Some(q),
            (_, true) => {
                let mut q = [0.0; 4];
                estimator::geometry::quat_to_xyzw(&cam.T_b_c.q, &mut q);
                Some(q)
            }
            (None, false) => None,
        };
        kalibr.push(KalibrCamera {
            name: format!("cam{i}"),
            camera_model: camera_model.into(),
            intrinsics,
            distortion_model: distortion_model.into(),
            distortion_coeffs: coeffs,
            resolution: c.resolution,
            r_b_c,
            t_b_c: cam.T_b_c.p,
            quaternion_xyzw,
            rostopic: image_topic(i),
            timeshift_cam_imu: spec.rig.time_offset_s,
            rolling_shutter: c.rolling_shutter.as_ref().map(|rs| {
                (
                    rs.readout_ms * 1e6 / f64::from(c.resolution[1]),
                    rs.readout_ms * 1e-3,
                    match rs.direction {
                        estimator::camera::ReadoutDirection::TopToBottom => "top_to_bottom",
                        estimator::camera::ReadoutDirection::BottomToTop => "bottom_to_top",
                    },
                )
            }),
            pixel_sigma_px: Some(cam.pixel_sigma),
        });
    }
    let header = format!(
        "Kalibr calibration of the rig of scenario {} (written by vio export).",
        scenario.name
    );
    let camchain = format_camchain(&kalibr, &header);
    let imu_yaml = format_imu_yaml(
        &KalibrImu {
            noise,
            rate_hz: spec.rig.imu.rate_hz,
            rostopic: IMU_TOPIC.into(),
        },
        &header,
    );
    ExportRig {
        imu,
        cameras,
        camchain,
        imu_yaml,
    }
}

/// The rig of `scenario` as Kalibr files, `(camchain-imucam.yaml, imu.yaml)`: what `vio export`
/// writes beside the data. Read back through `[rig] kalibr` they give the rig again: the same
/// models, intrinsics, distortion, resolutions, rotations and noise values, and the same
/// translations (exactly for axis-aligned cameras and for rigs read from Kalibr files; see
/// [`crate::dataset::camera_from_imu`]).
pub fn kalibr_files(scenario: &Scenario) -> Result<(String, String), crate::run::RunError> {
    let est = scenario.estimator_config_at(scenario.spec.world.seed)?;
    let rig = export_rig(scenario, &est);
    Ok((rig.camchain, rig.imu_yaml))
}
