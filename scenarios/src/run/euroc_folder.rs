//! A recorded EuRoC ASL folder as a run's source (`vio euroc`).
//!
//! The folder is read as the dataset ships it (`mav0/imu0/data.csv` with nanosecond stamps
//! around 1.4e18, `cam<i>/data.csv` + `data/<t_ns>.png`, every `sensor.yaml` with its `T_BS`,
//! optional `state_groundtruth_estimate0/data.csv`). The rig comes from the `sensor.yaml` files:
//! the body frame is the IMU's, so a camera's `T_b_c = T_BS(imu)⁻¹ · T_BS(cam)`; the estimator
//! assumes the IMU noise densities of `imu0/sensor.yaml`. Instead of the images, `features.csv`
//! (`vio export`'s feature tracks) can feed the estimator directly: the feature-track path of the
//! same run. The run itself is [`super::recorded`]'s.

use std::path::{Path, PathBuf};

use super::recorded::{Frames, ImageRef, RecordedRun, Recording, Setup, camera_config, replay};
use super::{RunControl, RunError, RunOptions};
use crate::dataset::{EurocDataset, read_euroc_cameras, read_features_csv_within};
use crate::spec::SuiteSpec;

/// How to run a dataset (its seed and duration: [`RunOptions`]).
#[derive(Clone, Debug)]
pub struct EurocOptions {
    /// The sensors the estimator fuses (`stereo_imu`, `stereo`: `cam0` and `cam1`; `mono_imu`:
    /// `cam0`).
    pub suite: SuiteSpec,
    /// Feed this `features.csv` instead of tracking the images.
    pub features: Option<PathBuf>,
    /// A TOML file whose `[estimator]` and `[camera.tracker]` tables (a scenario file works)
    /// are laid over the defaults.
    pub settings: Option<PathBuf>,
    /// Pixel noise σ (px) of every camera (`estimator.pixel_sigma_px` in the settings wins).
    pub pixel_sigma_px: f64,
}

impl EurocOptions {
    /// `vio euroc`'s defaults for `suite`: the images tracked, default settings, 1 px of pixel
    /// noise.
    pub fn new(suite: SuiteSpec) -> Self {
        Self {
            suite,
            features: None,
            settings: None,
            pixel_sigma_px: 1.0,
        }
    }
}

/// The captures every used camera has (stereo: the stamps of `cam0` also in `cam1`).
fn image_frames(
    data: &EurocDataset,
    mav0: &Path,
    cameras: usize,
) -> Vec<(i64, Vec<ImageRef<'static>>)> {
    let mut out = Vec::new();
    for f in &data.cameras[0].frames {
        let mut paths = vec![ImageRef::File(mav0.join("cam0/data").join(&f.filename))];
        for c in 1..cameras {
            let other = &data.cameras[c].frames;
            match other.binary_search_by_key(&f.t_ns, |g| g.t_ns) {
                Ok(j) => paths.push(ImageRef::File(
                    mav0.join(format!("cam{c}/data")).join(&other[j].filename),
                )),
                Err(_) => break,
            }
        }
        if paths.len() == cameras {
            out.push((f.t_ns, paths));
        }
    }
    out
}

/// Runs the image front end (or the given feature tracks) and the estimator over the `mav0`
/// folder.
pub(crate) fn replay_euroc(
    mav0: &Path,
    options: &EurocOptions,
    run: &RunOptions,
    control: &mut RunControl,
) -> Result<RecordedRun, RunError> {
    let n_cams = options.suite.suite().cameras();
    let data = read_euroc_cameras(mav0, n_cams)?;
    let imu_yaml = mav0.join("imu0/sensor.yaml");
    let imu_sensor = data.imu_sensor.as_ref().ok_or_else(|| {
        RunError::input(
            &imu_yaml,
            "missing: the IMU's noise densities and T_BS come from it",
        )
    })?;
    if data.imu.is_empty() {
        return Err(RunError::input(
            mav0.join("imu0/data.csv"),
            "no IMU samples",
        ));
    }
    if data.cameras.len() < n_cams {
        return Err(RunError::input(
            mav0,
            format!(
                "the {} suite needs {n_cams} camera folder(s) (cam0…), found {}",
                options.suite.as_str(),
                data.cameras.len()
            ),
        ));
    }
    let mut cameras = Vec::new();
    for (i, cam) in data.cameras.iter().take(n_cams).enumerate() {
        let yaml = mav0.join(format!("cam{i}/sensor.yaml"));
        let sensor = cam.sensor.as_ref().ok_or_else(|| {
            RunError::input(&yaml, "missing: the camera's calibration comes from it")
        })?;
        let model = sensor.camera().map_err(|e| RunError::input(&yaml, e))?;
        cameras.push(camera_config(
            model,
            &imu_sensor.t_bs,
            &sensor.t_bs,
            options.pixel_sigma_px,
        ));
    }
    let frames = match &options.features {
        Some(p) => {
            let sizes: Vec<[u32; 2]> = cameras
                .iter()
                .map(|c| [c.model.width(), c.model.height()])
                .collect();
            let mut f = read_features_csv_within(p, &sizes)?;
            for frame in &mut f {
                frame.cameras.retain(|c| c.cam_id < n_cams);
            }
            Frames::Features(f)
        }
        None => {
            if let Some(c) = data.cameras[..n_cams]
                .iter()
                .position(|c| c.frames.is_empty())
            {
                return Err(RunError::input(
                    mav0.join(format!("cam{c}/data.csv")),
                    "lists no images (0 bytes or a header only): the run needs them, or `--features`",
                ));
            }
            Frames::Images(image_frames(&data, mav0, n_cams))
        }
    };
    let empty = match &frames {
        Frames::Images(v) => v.is_empty(),
        Frames::Features(v) => v.is_empty(),
    };
    if empty {
        return Err(RunError::input(mav0, "no camera frames to run on"));
    }
    let name = mav0
        .parent()
        .and_then(|p| p.file_name())
        .or(mav0.file_name())
        .map_or("euroc".into(), |n| n.to_string_lossy().into_owned());
    let recording = Recording {
        imu_noise: imu_sensor.noise,
        imu: data.imu,
        cameras,
        groundtruth: data.groundtruth,
        truth_biases: true,
        frames,
        name,
        label: mav0.display().to_string(),
    };
    let setup = Setup {
        suite: options.suite,
        settings: options.settings.as_deref(),
    };
    replay(recording, setup, run, control)
}
