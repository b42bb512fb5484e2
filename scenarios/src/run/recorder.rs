//! The recorder: turns the estimator's answers into a run's output, whatever fed it.

use std::collections::VecDeque;

use estimator::frontend::FeatureFrame;
use estimator::{Estimate, Estimator, EstimatorError, EventKind as EstimatorEventKind, Status};
use nalgebra::Vector2;
use sim::stream::GroundTruth;

use super::{Event, EventKind, FrameRecord, FrameTiming, RunError, RunOutput, WindowScene};

/// A frame pushed and not yet estimated: camera stamp, front-end s, render s, and its
/// features when the run records its window.
type Pending = (i64, f64, f64, Vec<(usize, u64, Vector2<f64>)>);

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
    /// (camera stamp, front-end s, render s, features when [`Recorder::scene`]) of frames
    /// pushed and not yet estimated.
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
    /// front-end and `render_s` of rendering time.
    pub fn frame_pushed(&mut self, frame: &FeatureFrame, frontend_s: f64, render_s: f64) {
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
        self.pending
            .push_back((frame.t_ns, frontend_s, render_s, features));
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
            let mut features = Vec::new();
            while self.pending.front().is_some_and(|p| p.0 <= camera_t) {
                if let Some((_, f, r, obs)) = self.pending.pop_front() {
                    (frame_frontend_s, frame_render_s, features) = (f, r, obs);
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
