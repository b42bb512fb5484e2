//! The image front end in a simulated run: the estimator crate's `FeatureTracker` fed with the
//! rendered images and gyro-predicted rotations, and its tracks checked against ground truth.
//!
//! Ground truth for a track: the scene point that the ray through its *first* observation hits
//! (the renderer draws exactly these surfaces); in every later frame that point is projected with
//! the true pose and compared with the tracked pixel, so drift accumulates into the error. Stereo
//! matches are checked the same way within one frame (left ray → right projection).

use std::collections::BTreeMap;
use std::sync::Arc;

use estimator::EstimatorConfig;
use estimator::frontend::{
    CameraImageView, FeatureFrame, FeatureTracker, ImageError, ImageView, TrackStatistics,
    TrackSummary, TrackerCamera, TrackerConfig, TrackerError,
};
use estimator::geometry::{Pose, so3_exp};
use estimator::imu::ImuSample;
use nalgebra::{UnitQuaternion, Vector2, Vector3};
use serde::Serialize;
use sim::render::ImageFrame;
use sim::scene::Scene;

mod tracker_error;
use tracker_error::AgedError;
pub use tracker_error::TrackerErrorFit;

/// Tracks farther than this from ground truth (px) count as wrong.
pub const WRONG_TRACK_PX: f64 = 2.0;

/// The tracker with its gyro integration and its ground-truth bookkeeping.
#[derive(Debug)]
pub struct ImageFrontend {
    tracker: FeatureTracker,
    /// The estimator's cameras: a rig's further cameras (a mono suite on a stereo rig) are
    /// not tracked.
    cameras: usize,
    gyro: GyroIntegrator,
    eval: TrackEvaluation,
    counts: TrackStatistics,
}

impl ImageFrontend {
    /// A front end for `cameras` (the estimator's view of the rig) in `scene`; `true_cameras`
    /// are the simulator's (ground truth: intrinsics, extrinsics, readout), camera by camera.
    pub fn new(
        config: TrackerConfig,
        cameras: Vec<TrackerCamera>,
        scene: Arc<Scene>,
        true_cameras: &[sim::camera::CameraConfig],
    ) -> Result<Self, TrackerError> {
        Ok(Self {
            cameras: cameras.len(),
            tracker: FeatureTracker::new(config, cameras)?,
            gyro: GyroIntegrator::default(),
            eval: TrackEvaluation::new(scene, true_cameras),
            counts: TrackStatistics::default(),
        })
    }

    /// The tracker.
    pub fn tracker(&self) -> &FeatureTracker {
        &self.tracker
    }

    /// Accumulates a gyroscope sample for the next frame's rotation prediction.
    pub fn push_imu(&mut self, s: &ImuSample) {
        self.gyro.push(s);
    }

    /// Tracks one capture; `truth` (the true body poses over the capture's readout) feeds the
    /// ground-truth statistics when given. Returns the frame and the tracker's time (s).
    pub fn process(
        &mut self,
        images: &ImageFrame,
        truth: Option<&CapturePoses>,
    ) -> Result<(FeatureFrame, f64), TrackerError> {
        let mut views = image_views(images).map_err(|e| TrackerError::Config {
            field: "image",
            message: e.to_string(),
        })?;
        views.retain(|v| v.cam_id < self.cameras);
        let rotation = self.gyro.take();
        let frame = self.tracker.track(&views, images.t_ns, rotation)?;
        let seconds = self.tracker.report().times.total_s;
        self.counts.add(self.tracker.report(), &frame);
        if let Some(poses) = truth {
            self.eval.add(
                &frame,
                self.tracker.report().ransac_rejected.as_slice(),
                poses,
            );
        }
        Ok((frame, seconds))
    }

    /// The statistics so far.
    pub fn stats(&self) -> FrontendStats {
        self.eval.stats()
    }

    /// What the tracker did so far (no ground truth involved).
    pub fn track_summary(&self) -> TrackSummary {
        self.counts.summary()
    }
}

/// Borrowed views of a rendered frame's images, for [`FeatureTracker::track`].
pub fn image_views(frame: &ImageFrame) -> Result<Vec<CameraImageView<'_>>, ImageError> {
    frame
        .cameras
        .iter()
        .map(|c| {
            ImageView::packed(c.image.width, c.image.height, &c.image.data).map(|image| {
                CameraImageView {
                    cam_id: c.cam_id,
                    image,
                }
            })
        })
        .collect()
}

/// The tracker's view of the estimator's cameras (the same models and extrinsics).
pub fn tracker_cameras(config: &EstimatorConfig) -> Vec<TrackerCamera> {
    config
        .cameras
        .iter()
        .map(|c| TrackerCamera {
            model: c.model.clone(),
            T_b_c: c.T_b_c,
        })
        .collect()
}

/// Body rotation since the last frame from raw gyroscope samples (midpoint of consecutive
/// samples; the bias is ignored: over 50 ms it moves a pixel by far less than the KLT basin).
#[derive(Debug, Default)]
pub(crate) struct GyroIntegrator {
    last: Option<ImuSample>,
    rotation: Option<UnitQuaternion<f64>>,
}

impl GyroIntegrator {
    pub(crate) fn push(&mut self, s: &ImuSample) {
        if let Some(prev) = self.last {
            let dt = (s.t_ns - prev.t_ns) as f64 * 1e-9;
            if dt > 0.0 && dt < 0.1 {
                let w = 0.5 * (prev.gyro + s.gyro);
                let r = self.rotation.unwrap_or_else(UnitQuaternion::identity);
                self.rotation = Some(r * so3_exp(&(w * dt)));
            }
        }
        self.last = Some(*s);
    }

    /// `R_bprev_bcur` since the last call (`None` before any rotation was integrated).
    pub(crate) fn take(&mut self) -> Option<UnitQuaternion<f64>> {
        self.rotation.take()
    }
}

/// Front-end statistics of a run against ground truth (`report.json` → `frontend`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct FrontendStats {
    /// Frames tracked.
    pub frames: usize,
    /// Features on the primary camera per frame: mean.
    pub features_mean: f64,
    /// Features on the primary camera per frame: fewest.
    pub features_min: usize,
    /// Observations per track (primary camera), averaged over tracks.
    pub mean_track_length: f64,
    /// Stereo matches per primary-camera feature.
    pub stereo_match_ratio: f64,
    /// Distance of tracked points from their first observation's scene point (px): median.
    pub track_error_median_px: f64,
    /// Same: 95th percentile.
    pub track_error_p95_px: f64,
    /// Fraction of tracked points more than 2 px off, before RANSAC.
    pub wrong_before_ransac: f64,
    /// Fraction of tracked points more than 2 px off, after RANSAC (what the estimator gets).
    pub wrong_after_ransac: f64,
    /// Stereo matches against the projection of the left ray's scene point (px): median.
    pub stereo_error_median_px: f64,
    /// Same: 95th percentile.
    pub stereo_error_p95_px: f64,
    /// The pixel σ an estimator should assume for this front end: the per-axis RMS of every
    /// kept track's and stereo match's error within [`WRONG_TRACK_PX`] (the tracks beyond it
    /// are outliers, left to the robust loss), `√(Σ e² / 2n)`. A track's error is taken
    /// against its first observation's scene point, as an estimator anchoring a landmark on
    /// its first observation sees it.
    pub pixel_sigma_px: f64,
    /// The tracker's error fitted to the feature-level camera's tracker error model.
    pub tracker_error: TrackerErrorFit,
    /// Observations with no scene point to compare with (the ray hit nothing).
    pub unverifiable: usize,
}

/// The true body poses over one capture: pose `k` at `k · step_s` after the capture time (one
/// pose for a global-shutter rig), linear in between (position lerp, attitude slerp) — finer than
/// the physics' own 1 ms steps, between which the ground truth is interpolated the same way.
#[derive(Clone, Debug)]
pub struct CapturePoses {
    step_s: f64,
    poses: Vec<Pose>,
}

impl CapturePoses {
    /// Poses `poses` spaced `step_s` apart from the capture time.
    pub fn new(step_s: f64, poses: Vec<Pose>) -> Self {
        assert!(!poses.is_empty(), "a capture has a pose");
        Self { step_s, poses }
    }

    /// The body pose `dt_s` after the capture time (clamped to the poses held).
    pub fn at(&self, dt_s: f64) -> Pose {
        let last = self.poses.len() - 1;
        if last == 0 || self.step_s <= 0.0 || dt_s <= 0.0 {
            return self.poses[0];
        }
        let x = (dt_s / self.step_s).min(last as f64);
        let k = (x.floor() as usize).min(last - 1);
        let f = x - k as f64;
        let (a, b) = (&self.poses[k], &self.poses[k + 1]);
        Pose::new(a.q.slerp(&b.q, f), a.p + (b.p - a.p) * f)
    }
}

/// Ground-truth bookkeeping of the tracks.
#[derive(Debug)]
struct TrackEvaluation {
    scene: Arc<Scene>,
    /// The simulator's cameras: true intrinsics, extrinsics and readouts.
    cameras: Vec<sim::camera::CameraConfig>,
    /// Scene point of each track's first observation (`None`: the ray hit nothing), and the
    /// frame it was made in.
    anchors: BTreeMap<u64, (Option<Vector3<f64>>, usize)>,
    track_errors: Vec<f64>,
    aged_errors: Vec<AgedError>,
    stereo_vectors: Vec<(f64, f64)>,
    rejected_errors: Vec<f64>,
    stereo_errors: Vec<f64>,
    features: Vec<usize>,
    stereo_matches: usize,
    unverifiable: usize,
}

impl TrackEvaluation {
    fn new(scene: Arc<Scene>, cameras: &[sim::camera::CameraConfig]) -> Self {
        Self {
            scene,
            cameras: cameras.to_vec(),
            anchors: BTreeMap::new(),
            track_errors: Vec::new(),
            aged_errors: Vec::new(),
            stereo_vectors: Vec::new(),
            rejected_errors: Vec::new(),
            stereo_errors: Vec::new(),
            features: Vec::new(),
            stereo_matches: 0,
            unverifiable: 0,
        }
    }

    /// The body pose when camera `cam` exposed the row of pixel `uv`.
    fn pose_at_row(&self, cam: usize, uv: &Vector2<f64>, poses: &CapturePoses) -> Pose {
        let c = &self.cameras[cam];
        poses.at(c.rolling_shutter.row_time_s(uv, c.model.height()))
    }

    /// The scene point seen at pixel `uv` of camera `cam` (at its row's time).
    #[allow(non_snake_case)]
    fn ray_point(
        &self,
        cam: usize,
        uv: &Vector2<f64>,
        poses: &CapturePoses,
    ) -> Option<Vector3<f64>> {
        let T_w_c = self
            .pose_at_row(cam, uv, poses)
            .compose(&self.cameras[cam].t_b_c);
        let d = (T_w_c.q * self.cameras[cam].model.unproject(uv)?).normalize();
        let (t, _) = self.scene.ray_cast(&T_w_c.p, &d, 1e-3, 1e4)?;
        Some(T_w_c.p + d * t)
    }

    /// Pixel error of `uv` in camera `cam` against scene point `x_w`, seen at the time of
    /// `uv`'s row (a track near its truth is on nearly the same row): `uv` less the point's
    /// projection.
    #[allow(non_snake_case)]
    fn error(
        &self,
        cam: usize,
        uv: &Vector2<f64>,
        x_w: &Vector3<f64>,
        poses: &CapturePoses,
    ) -> Option<Vector2<f64>> {
        let T_w_c = self
            .pose_at_row(cam, uv, poses)
            .compose(&self.cameras[cam].t_b_c);
        let p_c = T_w_c.inverse().transform(x_w);
        Some(uv - self.cameras[cam].model.project(&p_c)?)
    }

    fn add(
        &mut self,
        frame: &FeatureFrame,
        rejected: &[(u64, Vector2<f64>)],
        poses: &CapturePoses,
    ) {
        let Some(primary) = frame.cameras.first() else {
            self.features.push(0);
            return;
        };
        let p = primary.cam_id;
        let frame_index = self.features.len();
        self.features.push(primary.features.len());
        let mut left: BTreeMap<u64, Vector2<f64>> = BTreeMap::new();
        for f in &primary.features {
            left.insert(f.feature_id, f.uv);
            match self.anchors.get(&f.feature_id) {
                None => {
                    let x = self.ray_point(p, &f.uv, poses);
                    self.anchors.insert(f.feature_id, (x, frame_index));
                }
                Some((Some(x), first)) => {
                    let e = self.error(p, &f.uv, x, poses);
                    self.track_errors
                        .push(e.map_or(f64::INFINITY, |e| e.norm()));
                    if let Some(e) = e {
                        self.aged_errors.push(AgedError {
                            track: f.feature_id,
                            age: frame_index - first,
                            dx: e.x,
                            dy: e.y,
                        });
                    }
                }
                Some((None, _)) => self.unverifiable += 1,
            }
        }
        for (id, uv) in rejected {
            if let Some((Some(x), _)) = self.anchors.get(id) {
                let e = self
                    .error(p, uv, x, poses)
                    .map_or(f64::INFINITY, |e| e.norm());
                self.rejected_errors.push(e);
            }
        }
        for cam in frame.cameras.iter().skip(1) {
            for f in &cam.features {
                self.stereo_matches += 1;
                let Some(uv0) = left.get(&f.feature_id) else {
                    continue;
                };
                match self.ray_point(p, uv0, poses) {
                    Some(x) => {
                        let e = self.error(cam.cam_id, &f.uv, &x, poses);
                        self.stereo_errors
                            .push(e.map_or(f64::INFINITY, |e| e.norm()));
                        if let Some(e) = e {
                            self.stereo_vectors.push((e.x, e.y));
                        }
                    }
                    None => self.unverifiable += 1,
                }
            }
        }
    }

    fn stats(&self) -> FrontendStats {
        let total: usize = self.features.iter().sum();
        let wrong = |v: &[f64]| v.iter().filter(|&&e| e > WRONG_TRACK_PX).count();
        let (kept, rej) = (self.track_errors.len(), self.rejected_errors.len());
        let frac = |n: usize, d: usize| if d == 0 { 0.0 } else { n as f64 / d as f64 };
        FrontendStats {
            frames: self.features.len(),
            features_mean: frac(total, self.features.len()),
            features_min: self.features.iter().copied().min().unwrap_or(0),
            mean_track_length: frac(total, self.anchors.len()),
            stereo_match_ratio: frac(self.stereo_matches, total),
            track_error_median_px: percentile(&self.track_errors, 0.5),
            track_error_p95_px: percentile(&self.track_errors, 0.95),
            wrong_before_ransac: frac(
                wrong(&self.track_errors) + wrong(&self.rejected_errors),
                kept + rej,
            ),
            wrong_after_ransac: frac(wrong(&self.track_errors), kept),
            stereo_error_median_px: percentile(&self.stereo_errors, 0.5),
            stereo_error_p95_px: percentile(&self.stereo_errors, 0.95),
            pixel_sigma_px: per_axis_rms_within(
                self.track_errors.iter().chain(&self.stereo_errors),
                WRONG_TRACK_PX,
            ),
            tracker_error: tracker_error::fit(
                &self.aged_errors,
                &self.stereo_vectors,
                WRONG_TRACK_PX,
            ),
            unverifiable: self.unverifiable,
        }
    }
}

/// Per-axis RMS `√(Σ e² / 2n)` of the 2-D error norms `e` at most `limit`; 0 when none.
fn per_axis_rms_within<'a>(errors: impl Iterator<Item = &'a f64>, limit: f64) -> f64 {
    let (sum, n) = errors
        .filter(|e| **e <= limit)
        .fold((0.0, 0usize), |(s, n), e| (s + e * e, n + 1));
    if n == 0 {
        0.0
    } else {
        (sum / (2 * n) as f64).sqrt()
    }
}

/// Nearest-rank percentile (`p` in 0..=1); 0 when empty.
pub(crate) fn percentile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((p * s.len() as f64).ceil() as usize).clamp(1, s.len()) - 1]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2-D Gaussian error of σ per axis has `E|e|² = 2σ²`; outliers past the limit are left
    /// out.
    #[test]
    fn pixel_sigma_is_the_per_axis_rms_within_the_limit() {
        let errors = [0.3f64, 0.4, 0.5, 50.0];
        let want = ((0.09 + 0.16 + 0.25) / 6.0f64).sqrt();
        let got = per_axis_rms_within(errors.iter(), WRONG_TRACK_PX);
        assert!((got - want).abs() < 1e-12, "{got}");
        assert_eq!(per_axis_rms_within([9.0f64].iter(), WRONG_TRACK_PX), 0.0);
    }
}
