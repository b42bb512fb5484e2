//! The recorder: turns the estimator's answers into a run's output, whatever fed it.

use std::collections::VecDeque;

use estimator::frontend::{FeatureFrame, ImageView};
use estimator::{Estimate, Estimator, EstimatorError, EventKind as EstimatorEventKind, Status};
use nalgebra::Vector2;
use sim::stream::GroundTruth;

use super::{Event, EventKind, FrameRecord, FrameTiming, RunError, RunOutput, WindowScene};

/// A frame pushed and not yet estimated.
#[derive(Debug)]
struct Pending {
    /// Camera stamp (ns).
    t_ns: i64,
    /// Front-end time (s).
    frontend_s: f64,
    /// Render time (s).
    render_s: f64,
    /// `(camera, feature id, pixel)` when the run records its window.
    features: Vec<(usize, u64, Vector2<f64>)>,
    /// The first camera's image as JPEG, when the run records its window and the input is
    /// images.
    image_jpeg: Option<Vec<u8>>,
}

/// JPEG quality of the images kept for the window's scene: the tracks picture's background.
const SCENE_JPEG_QUALITY: u8 = 85;

/// `image` as a greyscale JPEG; `None` if it cannot be encoded (the scene then has no
/// background image).
fn grey_jpeg(image: &ImageView<'_>) -> Option<Vec<u8>> {
    let packed = image.to_owned_image();
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, SCENE_JPEG_QUALITY)
        .encode(
            &packed.data,
            packed.width,
            packed.height,
            image::ExtendedColorType::L8,
        )
        .ok()?;
    Some(out)
}

/// Collects a run's output from the estimator's calls: estimates with their ground truth and
/// timing, status changes and the estimator's events.
#[derive(Debug)]
pub(crate) struct Recorder {
    /// The output so far.
    pub out: RunOutput,
    /// Leave estimates without ground truth out of the frames (counted in `without_truth`)
    /// instead of failing with [`RunError::NoTruth`].
    pub skip_without_truth: bool,
    /// Estimates left out for want of ground truth.
    pub without_truth: usize,
    /// Record the window with every estimate ([`super::RunOptions::scene`]).
    pub scene: bool,
    status: Status,
    /// Frames pushed and not yet estimated.
    pending: VecDeque<Pending>,
}

impl Recorder {
    /// A recorder filling `out`, the estimator starting in `status`.
    pub fn new(out: RunOutput, status: Status) -> Self {
        Self {
            out,
            skip_without_truth: false,
            without_truth: 0,
            scene: false,
            status,
            pending: VecDeque::new(),
        }
    }

    /// A frame stamped `t_ns` (camera clock) went to the estimator after `frontend_s` of
    /// front-end and `render_s` of rendering time; `image`: its first camera's image, when the
    /// input is images and the run records its window.
    pub fn frame_pushed(
        &mut self,
        frame: &FeatureFrame,
        frontend_s: f64,
        render_s: f64,
        image: Option<ImageView<'_>>,
    ) {
        self.out.frames_in += 1;
        let features = if self.scene {
            frame
                .cameras
                .iter()
                .flat_map(|c| c.features.iter().map(|o| (c.cam_id, o.feature_id, o.uv)))
                .collect()
        } else {
            Vec::new()
        };
        let image_jpeg = image.filter(|_| self.scene).and_then(|i| grey_jpeg(&i));
        self.pending.push_back(Pending {
            t_ns: frame.t_ns,
            frontend_s,
            render_s,
            features,
            image_jpeg,
        });
    }

    /// Records one estimator call made at `t_ns` that took `call_s`: its events, and its
    /// estimates with their `truth` (an estimate without: see
    /// [`Recorder::skip_without_truth`]).
    pub fn absorb(
        &mut self,
        estimator: &mut Estimator,
        result: Result<Vec<Estimate>, EstimatorError>,
        t_ns: i64,
        call_s: f64,
        render_s: f64,
        mut truth: impl FnMut(&Estimate) -> Option<GroundTruth>,
    ) -> Result<(), RunError> {
        let out = &mut self.out;
        out.points_relinearized = estimator.points_relinearized();
        for e in estimator.take_events() {
            match &e.kind {
                EstimatorEventKind::ImuSamplesExcluded { t_ns } => {
                    out.imu_samples_excluded += t_ns.len();
                    continue;
                }
                EstimatorEventKind::ImuSamplesSaturated { count } => {
                    out.imu_samples_saturated += count;
                    continue;
                }
                EstimatorEventKind::SuiteSwitch { .. } => out.suite_switches += 1,
                EstimatorEventKind::Reset { .. } => out.resets += 1,
                _ => {}
            }
            out.events.push(Event {
                t_ns: e.t_ns,
                kind: EventKind::Estimator(e.kind),
            });
        }
        let estimates = match result {
            Ok(e) => e,
            Err(e) => {
                out.events.push(Event {
                    t_ns,
                    kind: EventKind::InputRejected(e.to_string()),
                });
                Vec::new()
            }
        };
        let n = estimates.len().max(1) as f64;
        for e in estimates {
            if e.status != self.status {
                out.events.push(Event {
                    t_ns: e.t_ns,
                    kind: EventKind::StatusChange {
                        from: self.status,
                        to: e.status,
                    },
                });
                self.status = e.status;
            }
            let Some(truth) = truth(&e) else {
                if self.skip_without_truth {
                    self.without_truth += 1;
                    continue;
                }
                return Err(RunError::NoTruth { t_ns: e.t_ns });
            };
            // An estimate often leaves the estimator in a later call than its frame entered
            // (the frame waits for the IMU that covers it): its front-end and render times are
            // those recorded when its frame was pushed.
            let camera_t = e.stamp_ns;
            let (mut frame_frontend_s, mut frame_render_s) = (0.0, render_s);
            let (mut features, mut image_jpeg) = (Vec::new(), None);
            while self.pending.front().is_some_and(|p| p.t_ns <= camera_t) {
                if let Some(p) = self.pending.pop_front() {
                    (frame_frontend_s, frame_render_s) = (p.frontend_s, p.render_s);
                    (features, image_jpeg) = (p.features, p.image_jpeg);
                }
            }
            let timing = FrameTiming {
                frontend_s: frame_frontend_s,
                backend_s: e.backend_s,
                total_s: frame_frontend_s + call_s / n,
                render_s: frame_render_s,
            };
            let scene = self.scene.then(|| WindowScene {
                poses: estimator.window_poses(),
                points: estimator.window_points(),
                features,
                image_jpeg,
                image_sizes: estimator
                    .config()
                    .cameras
                    .iter()
                    .map(|c| [c.model.width(), c.model.height()])
                    .collect(),
            });
            out.frames.push(FrameRecord {
                estimate: e,
                truth,
                timing,
                scene,
            });
        }
        Ok(())
    }
}
