//! A recorded EuRoC ASL folder as a run's source (`vio euroc`): the image front end and the
//! estimator on real data.
//!
//! The folder is read as the dataset ships it (`mav0/imu0/data.csv` with nanosecond stamps
//! around 1.4e18, `cam<i>/data.csv` + `data/<t_ns>.png`, every `sensor.yaml` with its `T_BS`,
//! optional `state_groundtruth_estimate0/data.csv`). The rig comes from the `sensor.yaml` files:
//! the body frame is the IMU's, so a camera's `T_b_c = T_BS(imu)⁻¹ · T_BS(cam)`; the estimator
//! assumes the IMU noise densities of `imu0/sensor.yaml`. Every stamp is shifted so that the
//! first measurement is at 0 (the run's clock; `estimate_source_time.tum` has the dataset's
//! own). Measurements go to the estimator in time order, IMU first at equal stamps, as in a
//! simulated run, up to the last frame (IMU samples past it and the time offset's range are
//! not read). With ground truth the run is evaluated exactly like `vio run` (the truth of an
//! estimate is the ground truth interpolated at its time; estimates outside the ground truth's
//! span are left out; a ground truth that stands still is scored from the first pose, see
//! `metrics::anchored`); without it the report has no error metrics, and only the expectations
//! that need none are checked. The report's `frontend_tracks` says what the image front end did
//! (features, track lengths, stereo matches, rejections).
//!
//! Instead of the images, `features.csv` (`vio export`'s feature tracks) can feed the estimator
//! directly: the feature-track path of the same run.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use estimator::frontend::{
    CameraImageView, FeatureFrame, FeatureTracker, ImageView, TrackStatistics, TrackerConfig,
};
use estimator::geometry::Pose;
use estimator::imu::ImuSample;
use estimator::{CameraConfig, Estimate, Estimator, EstimatorConfig};
use nalgebra::Vector3;
use sim::stream::GroundTruth;

use super::driver::{Input, Source, drive};
use super::{Recorder, RunControl, RunError, RunOptions, RunOutput};
use crate::dataset::{
    EurocDataset, GroundTruthState, read_euroc_cameras, read_features_csv_within,
};
use crate::frontend::GyroIntegrator;
use crate::spec::{SpecError, SuiteSpec};

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

/// The front end's RANSAC seed of a dataset run that names none.
pub const DEFAULT_SEED: u64 = 1;

/// The settings file's `[estimator]` and `[camera.tracker]` tables over the defaults.
fn settings(options: &EurocOptions) -> Result<(EstimatorConfig, TrackerConfig), RunError> {
    let Some(path) = &options.settings else {
        return Ok((
            EstimatorConfig::settings_default(),
            TrackerConfig::default(),
        ));
    };
    let file = path.display().to_string();
    let text = sim::input_file::read_to_string(path)
        .map_err(|e| RunError::input(path, format!("cannot read the settings: {e}")))?;
    let root: toml::Table = crate::spec::error::deserialize_toml(&text, &file)?;
    // An absent table keeps the defaults; anything but a table is refused with its key.
    let table = |v: Option<&toml::Value>, key: &str| match v {
        None => Ok(toml::Table::new()),
        Some(toml::Value::Table(t)) => Ok(t.clone()),
        Some(other) => Err(SpecError::at(
            &file,
            &text,
            key,
            format!("expected a table, got a {}", other.type_str()),
        )),
    };
    let est_table = table(root.get("estimator"), "estimator")?;
    let camera = table(root.get("camera"), "camera")?;
    let tracker_table = table(camera.get("tracker"), "camera.tracker")?;
    let (est, tracker) =
        crate::spec::overlay::estimator_and_tracker(&est_table, &tracker_table, &text, &file)?;
    est.validate_settings()
        .map_err(|e| SpecError::at(&file, &text, &format!("estimator.{}", e.field), e.message))?;
    Ok((est, tracker))
}

/// Ground truth at `t_ns` (dataset clock), interpolated between the two rows around it
/// (positions, velocities and biases linearly, the attitude by slerp); `None` outside.
fn truth_at(gt: &[GroundTruthState], t_ns: i64) -> Option<GroundTruth> {
    let k = gt.partition_point(|g| g.t_ns < t_ns);
    let b = gt.get(k)?;
    let a = if b.t_ns == t_ns {
        b
    } else {
        gt.get(k.checked_sub(1)?)?
    };
    let span = (b.t_ns - a.t_ns) as f64;
    let s = if span > 0.0 {
        (t_ns - a.t_ns) as f64 / span
    } else {
        0.0
    };
    let lerp = |x: &Vector3<f64>, y: &Vector3<f64>| x + (y - x) * s;
    Some(GroundTruth {
        t_ns,
        pose: Pose::new(a.pose.q.slerp(&b.pose.q, s), lerp(&a.pose.p, &b.pose.p)),
        v_w: lerp(&a.velocity, &b.velocity),
        a_w: Vector3::zeros(),
        omega_b: Vector3::zeros(),
        gyro_bias: lerp(&a.gyro_bias, &b.gyro_bias),
        accel_bias: lerp(&a.accel_bias, &b.accel_bias),
    })
}

/// Where a frame's features come from.
enum Frames {
    /// Images to track: per capture, its stamp and each camera's PNG.
    Images(Vec<(i64, Vec<PathBuf>)>),
    /// Feature tracks as exported.
    Features(Vec<FeatureFrame>),
}

impl Frames {
    fn stamps(&self) -> Vec<i64> {
        match self {
            Frames::Images(v) => v.iter().map(|f| f.0).collect(),
            Frames::Features(v) => v.iter().map(|f| f.t_ns).collect(),
        }
    }
}

/// The captures every used camera has (stereo: the stamps of `cam0` also in `cam1`).
fn image_frames(data: &EurocDataset, mav0: &Path, cameras: usize) -> Vec<(i64, Vec<PathBuf>)> {
    let mut out = Vec::new();
    for f in &data.cameras[0].frames {
        let mut paths = vec![mav0.join("cam0/data").join(&f.filename)];
        for c in 1..cameras {
            let other = &data.cameras[c].frames;
            match other.binary_search_by_key(&f.t_ns, |g| g.t_ns) {
                Ok(j) => paths.push(mav0.join(format!("cam{c}/data")).join(&other[j].filename)),
                Err(_) => break,
            }
        }
        if paths.len() == cameras {
            out.push((f.t_ns, paths));
        }
    }
    out
}

/// A dataset run's output, and what its report needs to know of the dataset.
pub(crate) struct RecordedRun {
    /// The run, on the shifted clock.
    pub output: RunOutput,
    /// Estimates left out for want of ground truth: outside its span.
    pub without_truth: usize,
    /// The dataset's stamp of the run's 0 (ns).
    pub t0_ns: i64,
    /// Whether the dataset has ground truth.
    pub ground_truth: bool,
}

/// Runs the image front end (or the given feature tracks) and the estimator over the `mav0`
/// folder.
pub(crate) fn replay_euroc(
    mav0: &Path,
    options: &EurocOptions,
    run: &RunOptions,
    control: &mut RunControl,
) -> Result<RecordedRun, RunError> {
    let suite = options.suite.suite();
    let n_cams = suite.cameras();
    let seed = run.seed.unwrap_or(DEFAULT_SEED);
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
    let (mut settings, tracker_settings) = settings(options)?;
    let mut cameras = Vec::new();
    for (i, cam) in data.cameras.iter().take(n_cams).enumerate() {
        let yaml = mav0.join(format!("cam{i}/sensor.yaml"));
        let sensor = cam.sensor.as_ref().ok_or_else(|| {
            RunError::input(&yaml, "missing: the camera's calibration comes from it")
        })?;
        cameras.push(CameraConfig {
            model: Arc::new(sensor.camera().map_err(|e| RunError::input(&yaml, e))?),
            T_b_c: imu_sensor.t_bs.inverse().compose(&sensor.t_bs),
            pixel_sigma: options.pixel_sigma_px,
            rolling_shutter: estimator::camera::RollingShutter::GLOBAL,
        });
    }
    settings.suite = suite;
    settings.cameras = cameras;
    settings.imu_noise = imu_sensor.noise;
    settings.record_history |= run.batch_reference;
    settings.compute_covariance |= run.covariance;
    let label = mav0.display().to_string();
    let tracker = match &options.features {
        Some(_) => None,
        None => {
            let cams = crate::frontend::tracker_cameras(&settings);
            let cfg = TrackerConfig {
                seed,
                ..tracker_settings
            };
            Some(
                FeatureTracker::new(cfg, cams).map_err(|e| RunError::Frontend {
                    file: label.clone(),
                    message: e.to_string(),
                })?,
            )
        }
    };
    // How far past a frame's stamp its IMU time may lie (the time offset and how far its
    // estimate may move): the IMU is read that far past the last frame.
    let frame_to_imu_ns =
        ((settings.td_s.abs() + settings.health.max_time_offset_deviation_s) * 1e9).ceil() as i64;
    let sizes: Vec<[u32; 2]> = settings
        .cameras
        .iter()
        .map(|c| [c.model.width(), c.model.height()])
        .collect();
    let estimator = Estimator::new(settings).map_err(|e| RunError::Estimator {
        file: label.clone(),
        message: e.to_string(),
    })?;

    let frames = match &options.features {
        Some(p) => {
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
    let stamps = frames.stamps();
    if stamps.is_empty() {
        return Err(RunError::input(mav0, "no camera frames to run on"));
    }
    // The run's clock starts at the first measurement.
    let t0 = data.imu[0].t_ns.min(stamps[0]);
    // The run ends with the IMU sample that closes the last frame's interval, wherever the time
    // offset puts it: estimates come with frames, and an IMU log that goes on (a recording's
    // excerpt of images, the flight's whole log) would only propagate.
    let last_frame = *stamps.last().unwrap_or(&t0);
    let k = data
        .imu
        .partition_point(|s| s.t_ns < last_frame.saturating_add(frame_to_imu_ns));
    let last = data
        .imu
        .get(k)
        .map_or(last_frame, |s| s.t_ns.max(last_frame));
    let end = match run.duration_s {
        Some(d) => (t0 + (d * 1e9).round() as i64).min(last),
        None => last,
    };
    let name = mav0
        .parent()
        .and_then(|p| p.file_name())
        .or(mav0.file_name())
        .map_or("euroc".into(), |n| n.to_string_lossy().into_owned());
    let out = RunOutput::new(name, seed, (end - t0) as f64 * 1e-9, None);
    let mut recorder = Recorder::new(out, estimator.status());
    recorder.skip_without_truth = true;
    let has_truth = !data.groundtruth.is_empty();
    let source = Recorded {
        data: &data,
        frames,
        stamps,
        tracker,
        uses_imu: suite.uses_imu(),
        gyro: GyroIntegrator::default(),
        counts: TrackStatistics::default(),
        t0,
        end,
        imu_i: 0,
        frame_i: 0,
    };
    let (output, without_truth) = drive(source, estimator, recorder, run, control)?;
    Ok(RecordedRun {
        output,
        without_truth,
        t0_ns: t0,
        ground_truth: has_truth,
    })
}

/// The dataset as a run's source: IMU samples and frames merged in time order (IMU first at
/// equal stamps), every stamp shifted by `t0`.
struct Recorded<'a> {
    data: &'a EurocDataset,
    frames: Frames,
    /// Each frame's stamp (dataset clock), in order.
    stamps: Vec<i64>,
    /// The image front end (`None`: feature tracks are fed as they are).
    tracker: Option<FeatureTracker>,
    /// Whether the front end predicts rotations from the gyroscope.
    uses_imu: bool,
    gyro: GyroIntegrator,
    counts: TrackStatistics,
    /// The dataset's stamp of the run's 0.
    t0: i64,
    /// The last stamp read (dataset clock).
    end: i64,
    imu_i: usize,
    frame_i: usize,
}

impl Recorded<'_> {
    /// The next frame: the feature tracks as exported, or the images tracked.
    fn next_frame(&mut self) -> Result<FeatureFrame, RunError> {
        let t0 = self.t0;
        let frame = match &self.frames {
            Frames::Features(f) => {
                let mut frame = f[self.frame_i].clone();
                frame.t_ns -= t0;
                frame
            }
            Frames::Images(list) => {
                let (t, paths) = &list[self.frame_i];
                let images = paths
                    .iter()
                    .map(|p| crate::dataset::read_gray_image(p).map_err(|e| RunError::input(p, e)))
                    .collect::<Result<Vec<_>, _>>()?;
                let views = images
                    .iter()
                    .enumerate()
                    .map(|(cam_id, im)| {
                        ImageView::packed(im.width(), im.height(), im.as_raw())
                            .map(|image| CameraImageView { cam_id, image })
                            .map_err(|e| RunError::input(&paths[cam_id], e.to_string()))
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                let tracker = self.tracker.as_mut().expect("images need the tracker");
                let frame = tracker
                    .track(&views, t - t0, self.gyro.take())
                    .map_err(|e| RunError::input(&paths[0], format!("front end: {e}")))?;
                self.counts.add(tracker.report(), &frame);
                frame
            }
        };
        self.frame_i += 1;
        Ok(frame)
    }
}

impl Source for Recorded<'_> {
    fn end_ns(&self) -> i64 {
        self.end - self.t0
    }

    fn next_input(&mut self) -> Result<Option<Input>, RunError> {
        let data = self.data;
        let end = self.end;
        let imu_t = data
            .imu
            .get(self.imu_i)
            .map(|s| s.t_ns)
            .filter(|&t| t <= end);
        let frame_t = self.stamps.get(self.frame_i).copied().filter(|&t| t <= end);
        Ok(Some(match (imu_t, frame_t) {
            (None, None) => return Ok(None),
            (Some(a), b) if b.is_none_or(|b| a <= b) => {
                let s = ImuSample {
                    t_ns: a - self.t0,
                    ..data.imu[self.imu_i]
                };
                self.imu_i += 1;
                if self.uses_imu {
                    self.gyro.push(&s);
                }
                Input::Imu(s)
            }
            _ => {
                let frame = self.next_frame()?;
                let frontend_s = self
                    .tracker
                    .as_ref()
                    .map_or(0.0, |t| t.report().times.total_s);
                Input::Frame { frame, frontend_s }
            }
        }))
    }

    fn truth(&mut self, e: &Estimate) -> Option<GroundTruth> {
        // Ground truth on the run's clock (dataset clock − t0); without any, the estimate stands
        // in (the context then drops every error metric).
        if self.data.groundtruth.is_empty() {
            return Some(GroundTruth {
                t_ns: e.t_ns,
                pose: e.T_w_b,
                v_w: e.v_w,
                a_w: Vector3::zeros(),
                omega_b: Vector3::zeros(),
                gyro_bias: e.bg,
                accel_bias: e.ba,
            });
        }
        truth_at(&self.data.groundtruth, e.t_ns + self.t0)
            .map(|g| GroundTruth { t_ns: e.t_ns, ..g })
    }

    fn finish(self, out: &mut RunOutput, _interrupted: bool) -> Result<(), RunError> {
        if self.tracker.is_some() {
            out.frontend_tracks = Some(self.counts.summary());
        }
        Ok(())
    }
}
