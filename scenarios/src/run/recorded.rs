//! A recording as a run's source, whatever holds it (an EuRoC ASL folder: `vio euroc`,
//! [`super::euroc_folder`]; a ROS 2 bag: `vio bag`, [`super::ros2_bag`]): the image front end
//! (or the recording's feature tracks) and the estimator on recorded data.
//!
//! Every stamp is shifted so that the first measurement is at 0 (the run's clock;
//! `estimate_source_time.tum` has the recording's own). Measurements go to the estimator in
//! time order, IMU first at equal stamps, as in a simulated run, up to the last frame (IMU
//! samples past it and the time offset's range are not read). With ground truth the run is
//! evaluated exactly like `vio run` (the truth of an estimate is the ground truth interpolated
//! at its time; estimates outside the ground truth's span are left out; a ground truth that
//! stands still is scored from the first pose, see `metrics::anchored`); without it the report
//! has no error metrics, and only the expectations that need none are checked. The report's
//! `frontend_tracks` says what the image front end did (features, track lengths, stereo
//! matches, rejections).

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use estimator::frontend::{
    CameraImageView, FeatureFrame, FeatureTracker, ImageView, TrackStatistics, TrackerConfig,
};
use estimator::geometry::Pose;
use estimator::imu::{ImuNoise, ImuSample};
use estimator::{CameraConfig, Estimate, Estimator, EstimatorConfig};
use nalgebra::Vector3;
use sim::stream::GroundTruth;

use super::driver::{Input, Source, drive};
use super::lookahead::{Lookahead, Slot};
use super::stage::Stage;
use super::{Recorder, RunControl, RunError, RunOptions, RunOutput};
use crate::dataset::GroundTruthState;
use crate::frontend::GyroIntegrator;
use crate::spec::{SpecError, SuiteSpec};

/// How a recorded run is set up, whatever holds the recording.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Setup<'o> {
    /// The sensors the estimator fuses.
    pub suite: SuiteSpec,
    /// A TOML file whose `[estimator]` and `[camera.tracker]` tables (a scenario file works)
    /// are laid over the defaults.
    pub settings: Option<&'o Path>,
}

/// A recording, read: what the run needs of it.
pub(crate) struct Recording<'a> {
    /// The IMU log, in time order (recording clock).
    pub imu: Vec<ImuSample>,
    /// The IMU's noise densities.
    pub imu_noise: ImuNoise,
    /// The cameras the suite uses: models, `T_b_c` in the IMU frame, pixel noise.
    pub cameras: Vec<CameraConfig>,
    /// Ground truth, in time order (empty: none).
    pub groundtruth: Vec<GroundTruthState>,
    /// Whether the ground truth knows the IMU biases (else the report leaves their errors out).
    pub truth_biases: bool,
    /// The frames: images to track or feature tracks.
    pub frames: Frames<'a>,
    /// The run's name.
    pub name: String,
    /// What errors of the estimator and the front end name.
    pub label: String,
}

/// Where a frame's features come from.
pub(crate) enum Frames<'a> {
    /// Images to track: per capture, its stamp and each used camera's image.
    Images(Vec<(i64, Vec<ImageRef<'a>>)>),
    /// Feature tracks as recorded.
    Features(Vec<FeatureFrame>),
}

impl Frames<'_> {
    fn stamps(&self) -> Vec<i64> {
        match self {
            Frames::Images(v) => v.iter().map(|f| f.0).collect(),
            Frames::Features(v) => v.iter().map(|f| f.t_ns).collect(),
        }
    }
}

/// One camera's image of a capture, read when its frame comes.
pub(crate) enum ImageRef<'a> {
    /// An image file.
    File(PathBuf),
    /// A `sensor_msgs/msg/Image` of a bag: its CDR bytes, the bag and which message it is.
    Message {
        /// The message's bytes.
        data: Cow<'a, [u8]>,
        /// The bag.
        bag: &'a Path,
        /// `topic message k`.
        what: String,
    },
}

impl ImageRef<'_> {
    /// The error `message` about this image.
    fn error(&self, message: String) -> RunError {
        match self {
            ImageRef::File(path) => RunError::input(path, message),
            ImageRef::Message { bag, what, .. } => {
                RunError::input(bag, format!("{what}: {message}"))
            }
        }
    }

    /// The image's grey levels.
    fn load(&self) -> Result<image::GrayImage, RunError> {
        match self {
            ImageRef::File(path) => {
                crate::dataset::read_gray_image(path).map_err(|e| RunError::input(path, e))
            }
            ImageRef::Message { data, .. } => {
                crate::dataset::ros2::gray_image(data).map_err(|e| self.error(e))
            }
        }
    }
}

/// Each camera's estimator configuration from its calibration `(model, T_BS)` and the IMU's
/// `T_BS` (the body frame is the IMU's: `T_b_c = T_BS(imu)⁻¹ · T_BS(cam)`).
pub(crate) fn camera_config(
    model: estimator::camera::Camera,
    imu_t_bs: &Pose,
    cam_t_bs: &Pose,
    pixel_sigma_px: f64,
) -> CameraConfig {
    CameraConfig {
        model: std::sync::Arc::new(model),
        T_b_c: imu_t_bs.inverse().compose(cam_t_bs),
        pixel_sigma: pixel_sigma_px,
        rolling_shutter: estimator::camera::RollingShutter::GLOBAL,
    }
}

/// The front end's RANSAC seed of a dataset run that names none.
pub const DEFAULT_SEED: u64 = 1;

/// The settings file's `[estimator]` and `[camera.tracker]` tables over the defaults.
fn settings(path: Option<&Path>) -> Result<(EstimatorConfig, TrackerConfig), RunError> {
    let Some(path) = path else {
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
    let origin = crate::spec::Origin::File(path.to_path_buf());
    let (est, tracker) = crate::spec::overlay::estimator_and_tracker(
        &est_table,
        &tracker_table,
        &origin,
        &text,
        &file,
    )?;
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

/// A recorded run's output, and what its report needs to know of the recording.
pub(crate) struct RecordedRun {
    /// The run, on the shifted clock.
    pub output: RunOutput,
    /// Estimates left out for want of ground truth: outside its span.
    pub without_truth: usize,
    /// The recording's stamp of the run's 0 (ns).
    pub t0_ns: i64,
    /// Whether the recording has ground truth.
    pub ground_truth: bool,
    /// Whether its ground truth knows the IMU biases.
    pub truth_biases: bool,
}

/// Runs the image front end (or the recording's feature tracks) and the estimator over
/// `recording`.
pub(crate) fn replay(
    recording: Recording<'_>,
    setup: Setup<'_>,
    run: &RunOptions,
    control: &mut RunControl,
) -> Result<RecordedRun, RunError> {
    let suite = setup.suite.suite();
    let seed = run.seed.unwrap_or(DEFAULT_SEED);
    let (mut settings, tracker_settings) = settings(setup.settings)?;
    settings.suite = suite;
    settings.cameras = recording.cameras;
    settings.imu_noise = recording.imu_noise;
    settings.record_history |= run.batch_reference;
    settings.compute_covariance |= run.covariance;
    let label = recording.label;
    let tracker = match &recording.frames {
        Frames::Features(_) => None,
        Frames::Images(_) => {
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
    let estimator = Estimator::new(settings).map_err(|e| RunError::Estimator {
        file: label.clone(),
        message: e.to_string(),
    })?;
    let imu = &recording.imu;
    let stamps = recording.frames.stamps();
    let (Some(&first_frame), Some(first_imu)) = (stamps.first(), imu.first()) else {
        return Err(RunError::input(
            &label,
            "no camera frames or no IMU samples to run on",
        ));
    };
    // The run's clock starts at the first measurement.
    let t0 = first_imu.t_ns.min(first_frame);
    // The run ends with the IMU sample that closes the last frame's interval, wherever the time
    // offset puts it: estimates come with frames, and an IMU log that goes on (a recording's
    // excerpt of images, the flight's whole log) would only propagate.
    let last_frame = *stamps.last().unwrap_or(&t0);
    let k = imu.partition_point(|s| s.t_ns < last_frame.saturating_add(frame_to_imu_ns));
    let last = imu.get(k).map_or(last_frame, |s| s.t_ns.max(last_frame));
    let end = match run.duration_s {
        Some(d) => (t0 + (d * 1e9).round() as i64).min(last),
        None => last,
    };
    let out = RunOutput::new(recording.name, seed, (end - t0) as f64 * 1e-9, None);
    let mut recorder = Recorder::new(out, estimator.status());
    recorder.skip_without_truth = true;
    let has_truth = !recording.groundtruth.is_empty();
    let frames = &recording.frames;
    let (output, without_truth) = std::thread::scope(|scope| {
        let frontend = tracker.map(|tracker| RecordedFrontend {
            tracker,
            gyro: GyroIntegrator::default(),
            counts: TrackStatistics::default(),
        });
        let source = Recorded {
            imu,
            groundtruth: &recording.groundtruth,
            frames,
            stamps,
            tracking: frontend.map(|f| Stage::spawn(scope, "vio-track", f, RecordedFrontend::run)),
            uses_imu: suite.uses_imu(),
            t0,
            end,
            imu_i: 0,
            frame_i: 0,
            ahead: Lookahead::default(),
            latest: Vec::new(),
        };
        drive(source, estimator, recorder, run, control)
    })?;
    Ok(RecordedRun {
        output,
        without_truth,
        t0_ns: t0,
        ground_truth: has_truth,
        truth_biases: recording.truth_biases,
    })
}

/// The image front end of a recorded run, as a pipeline stage: the tracker with its gyro
/// integration and statistics.
struct RecordedFrontend {
    tracker: FeatureTracker,
    gyro: GyroIntegrator,
    counts: TrackStatistics,
}

/// A job of the front end's stage.
enum TrackJob<'r, 'a> {
    /// A gyroscope sample for the rotation prediction.
    Imu(ImuSample),
    /// A capture to read and track: its stamp (run clock) and each camera's image.
    Capture(i64, &'r [ImageRef<'a>]),
}

/// The stage's answer to a capture: the frame, the tracker's time (s) and the images read.
type Tracked = Result<(FeatureFrame, f64, Vec<image::GrayImage>), RunError>;

impl RecordedFrontend {
    /// Runs one job.
    fn run(&mut self, job: TrackJob) -> Option<Tracked> {
        match job {
            TrackJob::Imu(s) => {
                self.gyro.push(&s);
                None
            }
            TrackJob::Capture(t_ns, refs) => Some(self.track(t_ns, refs)),
        }
    }

    /// Reads and tracks a capture.
    fn track(&mut self, t_ns: i64, refs: &[ImageRef]) -> Tracked {
        let images = refs
            .iter()
            .map(ImageRef::load)
            .collect::<Result<Vec<_>, _>>()?;
        let views = images
            .iter()
            .zip(refs)
            .enumerate()
            .map(|(cam_id, (im, r))| {
                ImageView::packed(im.width(), im.height(), im.as_raw())
                    .map(|image| CameraImageView { cam_id, image })
                    .map_err(|e| r.error(e.to_string()))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let frame = self
            .tracker
            .track(&views, t_ns, self.gyro.take())
            .map_err(|e| refs[0].error(format!("front end: {e}")))?;
        self.counts.add(self.tracker.report(), &frame);
        drop(views);
        Ok((frame, self.tracker.report().times.total_s, images))
    }
}

/// The recording as a run's source: IMU samples and frames merged in time order (IMU first at
/// equal stamps), every stamp shifted by `t0`. Images are read and tracked by the front end's
/// stage (`vio-track`), one capture ahead of the estimator (see [`Lookahead`]).
struct Recorded<'r, 'a, 's> {
    imu: &'r [ImuSample],
    groundtruth: &'r [GroundTruthState],
    frames: &'r Frames<'a>,
    /// Each frame's stamp (dataset clock), in order.
    stamps: Vec<i64>,
    /// The image front end's stage (`None`: feature tracks are fed as they are).
    tracking: Option<Stage<'s, RecordedFrontend, TrackJob<'r, 'a>, Tracked>>,
    /// Whether the front end predicts rotations from the gyroscope.
    uses_imu: bool,
    /// The dataset's stamp of the run's 0.
    t0: i64,
    /// The last stamp read (dataset clock).
    end: i64,
    imu_i: usize,
    frame_i: usize,
    /// Inputs read and not yet given to the estimator.
    ahead: Lookahead<()>,
    /// The latest frame's images (input that is images), by camera.
    latest: Vec<image::GrayImage>,
}

impl Recorded<'_, '_, '_> {
    /// Reads the recording as far as [`Lookahead`] wants.
    fn read_ahead(&mut self) {
        while self.ahead.wants_more(self.tracking.is_some()) {
            match self.read() {
                Some(slot) => self.ahead.push(slot),
                None => self.ahead.end(),
            }
        }
    }

    /// The next measurement in time order as an input (a capture goes to the front end);
    /// `None` past the end.
    fn read(&mut self) -> Option<Slot<()>> {
        let end = self.end;
        let imu_t = self
            .imu
            .get(self.imu_i)
            .map(|s| s.t_ns)
            .filter(|&t| t <= end);
        let frame_t = self.stamps.get(self.frame_i).copied().filter(|&t| t <= end);
        Some(match (imu_t, frame_t) {
            (None, None) => return None,
            (Some(a), b) if b.is_none_or(|b| a <= b) => {
                let s = ImuSample {
                    t_ns: a - self.t0,
                    ..self.imu[self.imu_i]
                };
                self.imu_i += 1;
                if let Some(stage) = self.tracking.as_ref().filter(|_| self.uses_imu) {
                    stage.submit(TrackJob::Imu(s));
                }
                Slot::Ready(Input::Imu(s))
            }
            _ => {
                let i = self.frame_i;
                self.frame_i += 1;
                match (self.frames, &self.tracking) {
                    (Frames::Features(f), _) => {
                        let mut frame = f[i].clone();
                        frame.t_ns -= self.t0;
                        Slot::Ready(Input::Frame {
                            frame,
                            frontend_s: 0.0,
                        })
                    }
                    (Frames::Images(list), Some(stage)) => {
                        let (t, refs) = &list[i];
                        stage.submit(TrackJob::Capture(t - self.t0, refs));
                        Slot::Tracking(())
                    }
                    (Frames::Images(_), None) => unreachable!("images come with the tracker"),
                }
            }
        })
    }
}

impl Source for Recorded<'_, '_, '_> {
    fn end_ns(&self) -> i64 {
        self.end - self.t0
    }

    fn next_input(&mut self) -> Result<Option<Input>, RunError> {
        self.read_ahead();
        Ok(Some(match self.ahead.pop() {
            None => return Ok(None),
            Some(Slot::Ready(input)) => input,
            Some(Slot::Tracking(())) => {
                let stage = self
                    .tracking
                    .as_mut()
                    .expect("captures go to the front end");
                let (frame, frontend_s, images) = stage.next_result()?;
                self.latest = images;
                Input::Frame { frame, frontend_s }
            }
        }))
    }

    fn latest_image(&self) -> Option<ImageView<'_>> {
        let image = self.latest.first()?;
        ImageView::packed(image.width(), image.height(), image.as_raw()).ok()
    }

    fn truth(&mut self, e: &Estimate) -> Option<GroundTruth> {
        // Ground truth on the run's clock (dataset clock − t0); without any, the estimate stands
        // in (the context then drops every error metric).
        if self.groundtruth.is_empty() {
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
        truth_at(self.groundtruth, e.t_ns + self.t0).map(|g| GroundTruth { t_ns: e.t_ns, ..g })
    }

    fn finish(self, out: &mut RunOutput, _interrupted: bool) -> Result<(), RunError> {
        // A stopped run's front end may have tracked the capture after the last one the
        // estimator took; its statistics then count that capture too.
        if let Some(stage) = self.tracking {
            out.frontend_tracks = Some(stage.finish().counts.summary());
        }
        Ok(())
    }
}
