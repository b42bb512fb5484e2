//! `vio export`: a scenario's simulated measurements written in the community's formats, so
//! other estimators can consume exactly what ours does.
//!
//! Writes `OUT/mav0/` in the EuRoC ASL layout (`imu0/data.csv` + `sensor.yaml` with the Kalibr
//! noise values, `state_groundtruth_estimate0/data.csv` at every IMU sample with the true biases,
//! `cam<i>/data.csv` + `sensor.yaml` with each camera's calibration) and `OUT/features.csv`
//! (`t_ns,cam_id,feature_id,u,v`, distorted pixels). Rendered scenarios (`camera.mode =
//! "rendered"`) also write every image as `mav0/cam<i>/data/<t_ns>.png` (depth images are not
//! exported; `vio render` writes them), and each camera's `data.csv` lists exactly the images
//! written; feature-level scenarios have no images, so their `data.csv` holds the header only
//! and `features.csv` holds what the cameras measured and when. Feature ids in `features.csv`
//! are renumbered densely from 0 keeping their order (they fit in 31 bits): one id is
//! one track (`rig.track_ids = "realistic"`, the default: a re-acquired landmark is a new track)
//! or one landmark (`"landmark"`), shared by the cameras that see it.

use std::path::Path;

use estimator::frontend::FeatureFrame;
use estimator::geometry::Pose;
use estimator::imu::ImuNoise;
use sim::World;
use sim::stream::Measurement;

use crate::dataset::{
    CameraFrame, CameraSensor, DatasetError, EurocCamera, EurocDataset, GroundTruthState,
    ImuSensor, write_euroc, write_features_csv,
};
use crate::run::{RunError, RunOptions, measurement_stream, stream_result};
use crate::spec::{ModelSpec, Scenario};

/// What an export wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportSummary {
    /// IMU samples written.
    pub imu_samples: usize,
    /// Camera frames written.
    pub frames: usize,
    /// Feature observations written.
    pub observations: usize,
    /// Ground-truth rows written.
    pub groundtruth: usize,
    /// Rendered images written (rendered scenarios).
    pub images: usize,
}

/// Errors from [`export`].
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The scenario could not be simulated.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A file could not be written.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// An image could not be written.
    #[error("{0}")]
    Image(String),
}

/// Kalibr's `camera_model`, `intrinsics`, `distortion_model`, `distortion_coefficients` for a
/// scenario camera.
fn kalibr_camera(
    model: ModelSpec,
    intr: [f64; 4],
    dist: &[f64],
    xi: Option<f64>,
    alpha: Option<f64>,
) -> (String, Vec<f64>, String, Vec<f64>) {
    let [fu, fv, cu, cv] = intr;
    match model {
        ModelSpec::PinholeRadtan => (
            "pinhole".into(),
            vec![fu, fv, cu, cv],
            "radial-tangential".into(),
            dist.to_vec(),
        ),
        ModelSpec::KannalaBrandt => (
            "pinhole".into(),
            vec![fu, fv, cu, cv],
            "equidistant".into(),
            dist.to_vec(),
        ),
        ModelSpec::Mei => (
            "omni".into(),
            vec![xi.unwrap_or(0.0), fu, fv, cu, cv],
            "radial-tangential".into(),
            dist.to_vec(),
        ),
        ModelSpec::DoubleSphere => (
            "ds".into(),
            vec![xi.unwrap_or(0.0), alpha.unwrap_or(0.0), fu, fv, cu, cv],
            "none".into(),
            Vec::new(),
        ),
    }
}

/// Simulates `scenario` and writes its measurements and ground truth under `out`.
/// Renumbers feature ids densely from 0, keeping their order (an id's new value is its rank
/// among all ids of the export), so they fit in 31 bits: many tools read them as `int`, and the
/// simulator's realistic track ids carry the landmark id in their low bits and a track counter
/// above. Keeping the order keeps every id-ordered choice of the estimator (which tracks become
/// persistent points, the order of factors), so the exported tracks reproduce the run exactly.
/// One id still means one track (or one landmark with `track_ids = "landmark"`), shared by the
/// cameras that see it.
fn compact_feature_ids(frames: &mut [FeatureFrame]) {
    let all: std::collections::BTreeSet<u64> = frames
        .iter()
        .flat_map(|f| f.cameras.iter())
        .flat_map(|c| c.features.iter().map(|o| o.feature_id))
        .collect();
    let rank: std::collections::BTreeMap<u64, u64> = all.into_iter().zip(0u64..).collect();
    for f in frames {
        for c in &mut f.cameras {
            for o in &mut c.features {
                o.feature_id = rank[&o.feature_id];
            }
        }
    }
}

/// Writes the scenario's measurements (see the module documentation).
pub fn export(
    scenario: &Scenario,
    options: &RunOptions,
    out: &Path,
) -> Result<ExportSummary, ExportError> {
    let world_cfg = scenario
        .world_config(options.seed, options.duration_s)
        .map_err(RunError::from)?;
    let est_cfg = scenario.estimator_config().map_err(RunError::from)?;
    let spec = &scenario.spec;
    let imu_rate = spec.rig.imu.rate_hz;
    let noise: ImuNoise = est_cfg.imu_noise;
    let world = World::new(world_cfg).map_err(|e| RunError::sim(scenario, e))?;
    let (mut stream, _) = measurement_stream(scenario, &world)?;
    let mut images = 0;
    let mut data = EurocDataset {
        imu_sensor: Some(ImuSensor {
            comment: format!("vio simulated IMU, scenario {}", scenario.name),
            t_bs: Pose::identity(),
            rate_hz: imu_rate,
            noise,
        }),
        ..EurocDataset::default()
    };
    for (i, (c, cam)) in spec.rig.cameras.iter().zip(&est_cfg.cameras).enumerate() {
        let (camera_model, intrinsics, distortion_model, distortion_coefficients) =
            kalibr_camera(c.model, c.intrinsics, &c.distortion, c.xi, c.alpha);
        data.cameras.push(EurocCamera {
            sensor: Some(CameraSensor {
                comment: format!("vio simulated camera {i}, scenario {}", scenario.name),
                t_bs: cam.T_b_c,
                rate_hz: spec.rig.rate_hz,
                resolution: c.resolution,
                camera_model,
                intrinsics,
                distortion_model,
                distortion_coefficients,
            }),
            frames: Vec::new(),
        });
    }
    let mut frames: Vec<FeatureFrame> = Vec::new();
    while let Some(m) = stream.next() {
        match m {
            Measurement::Imu(s) => {
                data.imu.push(s);
                if let Some(gt) = stream.truth(s.t_ns) {
                    data.groundtruth.push(GroundTruthState {
                        t_ns: gt.t_ns,
                        pose: gt.pose,
                        velocity: gt.v_w,
                        gyro_bias: gt.gyro_bias,
                        accel_bias: gt.accel_bias,
                    });
                }
            }
            Measurement::Images(frame) => {
                for c in &frame.cameras {
                    let dir = out.join(format!("mav0/cam{}/data", c.cam_id));
                    std::fs::create_dir_all(&dir)
                        .map_err(|e| ExportError::Image(format!("{}: {e}", dir.display())))?;
                    let path = dir.join(format!("{}.png", frame.t_ns));
                    crate::images::write_gray_png(&path, &c.image).map_err(ExportError::Image)?;
                    images += 1;
                    // `data.csv` lists only the images that exist (an EuRoC reader opens them).
                    if let Some(cam) = data.cameras.get_mut(c.cam_id) {
                        cam.frames.push(CameraFrame::at(frame.t_ns));
                    }
                }
            }
            Measurement::Frame(f) => frames.push(f),
            // The EuRoC layout has no place for them.
            Measurement::Gnss(_) | Measurement::Wheel(_) => {}
        }
    }
    stream_result(scenario, &stream)?;
    write_euroc(out.join("mav0"), &data)?;
    compact_feature_ids(&mut frames);
    write_features_csv(out.join("features.csv"), &frames)?;
    Ok(ExportSummary {
        imu_samples: data.imu.len(),
        frames: frames.len(),
        observations: frames
            .iter()
            .flat_map(|f| f.cameras.iter())
            .map(|c| c.features.len())
            .sum(),
        groundtruth: data.groundtruth.len(),
        images,
    })
}
