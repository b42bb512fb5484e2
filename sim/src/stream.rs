//! One lazily generated, time-ordered stream of all sensors' measurements, with ground truth
//! queryable at any timestamp.
//!
//! Events are ordered by their stamps (IMU before a frame with the same stamp). Physics, IMU and
//! frames are generated on demand, and ground truth older than the retention window is dropped,
//! so memory stays bounded however long the scenario runs.

use crate::aiding_sensors::{GnssSim, WheelSim};
use crate::camera::RigSim;
use crate::faults::FaultTimeline;
use crate::imu::ImuBias;
use crate::imu_source::ImuSource;
use crate::motion::{Kinematics, TruthBuffer};
use crate::render::{CameraImage, DepthImage, GrayImage, ImageFrame, RenderError, Renderer};
use crate::render_worker::{RenderJob, RenderWorker};
use crate::scene::Landmark;
use estimator::frontend::FeatureFrame;
use estimator::geometry::Pose;
use estimator::imu::ImuSample;
use estimator::{GnssSample, WheelSample};
use nalgebra::Vector3;
use std::collections::VecDeque;

/// One measurement event.
#[derive(Clone, Debug, PartialEq)]
pub enum Measurement {
    /// An IMU sample.
    Imu(ImuSample),
    /// A (multi-camera) feature frame, stamped in the camera clock.
    Frame(FeatureFrame),
    /// The rendered images of the same capture (rendered streams only): emitted just before
    /// the feature frame with the same stamp, with the same live cameras.
    Images(ImageFrame),
    /// A GNSS position fix.
    Gnss(GnssSample),
    /// A wheel-odometry reading.
    Wheel(WheelSample),
}

impl Measurement {
    /// The event's stamp (ns).
    pub fn t_ns(&self) -> i64 {
        match self {
            Measurement::Imu(s) => s.t_ns,
            Measurement::Frame(f) => f.t_ns,
            Measurement::Images(f) => f.t_ns,
            Measurement::Gnss(s) => s.t_ns,
            Measurement::Wheel(s) => s.t_ns,
        }
    }
}

/// Ground truth at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundTruth {
    /// Time (ns, true time = IMU clock).
    pub t_ns: i64,
    /// Pose `T_w_b`.
    pub pose: Pose,
    /// Velocity in the world frame (m/s).
    pub v_w: Vector3<f64>,
    /// Acceleration in the world frame (m/s²).
    pub a_w: Vector3<f64>,
    /// Angular velocity in the body frame (rad/s).
    pub omega_b: Vector3<f64>,
    /// Gyroscope bias (rad/s).
    pub gyro_bias: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub accel_bias: Vector3<f64>,
}

/// Images of a pending frame.
#[derive(Debug)]
enum PendingImages {
    /// Made without rendering (black frames).
    Ready(ImageFrame),
    /// Submitted to the render thread.
    Rendering,
}

/// A frame waiting to be emitted.
#[derive(Debug)]
struct PendingFrame {
    frame: FeatureFrame,
    /// Images to emit first (rendered streams; `None` once emitted).
    images: Option<PendingImages>,
}

/// The aiding sensors of a stream (see [`crate::aiding_sensors`]).
#[derive(Debug, Default)]
pub(crate) struct AidingSims {
    pub gnss: Option<GnssSim>,
    pub wheel: Option<WheelSim>,
}

/// The merged measurement stream of a [`crate::World`] (see [`crate::World::stream`]).
#[derive(Debug)]
pub struct Stream {
    truth: TruthBuffer,
    /// The simulated IMU or a recorded log.
    imu: ImuSource,
    rig: Option<RigSim>,
    faults: FaultTimeline,
    end_ns: i64,
    retention_ns: i64,
    /// IMU samples generated but not yet emitted (after faults).
    imu_queue: VecDeque<ImuSample>,
    /// True biases of generated samples (trimmed to the retention window).
    biases: VecDeque<ImuBias>,
    /// Frames to emit (after faults), oldest first; a rendered stream keeps
    /// [`RenderWorker::STAGES`] more than it emits, their images already rendering.
    pending: VecDeque<PendingFrame>,
    /// The renderer of a rendered stream, on its own threads.
    worker: Option<RenderWorker>,
    /// Time spent rendering the last emitted images (s).
    render_s: f64,
    /// The first rendering error; the stream ends there.
    error: Option<RenderError>,
    imu_done: bool,
    rig_done: bool,
    last_emitted_ns: i64,
    aiding: AidingSims,
    /// The next GNSS fix and wheel reading to emit (after faults).
    gnss_next: Option<GnssSample>,
    wheel_next: Option<WheelSample>,
}

impl Stream {
    pub(crate) fn new(
        truth: TruthBuffer,
        imu: ImuSource,
        rig: Option<RigSim>,
        faults: FaultTimeline,
        end_ns: i64,
        retention_ns: i64,
    ) -> Self {
        let rig_done = rig.is_none();
        Self {
            truth,
            imu,
            rig,
            faults,
            end_ns,
            retention_ns,
            imu_queue: VecDeque::new(),
            biases: VecDeque::new(),
            pending: VecDeque::new(),
            worker: None,
            render_s: 0.0,
            error: None,
            imu_done: false,
            rig_done,
            last_emitted_ns: i64::MIN,
            aiding: AidingSims::default(),
            gnss_next: None,
            wheel_next: None,
        }
    }

    /// Adds the aiding sensors.
    pub(crate) fn with_aiding(mut self, aiding: AidingSims) -> Self {
        self.aiding = aiding;
        self
    }

    /// Generates the next GNSS fix and wheel reading if none is waiting (fixes lost to a fault
    /// are skipped; nothing after the end).
    fn fill_aiding(&mut self) {
        while self.gnss_next.is_none() {
            let Some(g) = self.aiding.gnss.as_mut() else {
                break;
            };
            if g.next_time_ns() > self.end_ns {
                self.aiding.gnss = None;
                break;
            }
            let fix = g.next_sample(&mut self.truth);
            self.gnss_next = self.faults.apply_gnss(fix);
        }
        if self.wheel_next.is_none()
            && let Some(w) = self.aiding.wheel.as_mut()
        {
            if w.next_time_ns() > self.end_ns {
                self.aiding.wheel = None;
            } else {
                let reading = w.next_sample(&mut self.truth);
                self.wheel_next = Some(self.faults.apply_wheel(reading));
            }
        }
    }

    /// Makes this a rendered stream: every delivered frame is preceded by its images. The
    /// renderer moves to its own thread and renders each capture one frame ahead.
    pub(crate) fn with_renderer(mut self, renderer: Renderer) -> Self {
        let cameras = self.rig.as_ref().map_or(0, |r| r.config().cameras.len());
        self.worker = Some(RenderWorker::spawn(renderer, cameras));
        self
    }

    /// Wall-clock time spent rendering the most recently emitted images (s; for timing
    /// reports only, never for decisions).
    pub fn last_render_s(&self) -> f64 {
        self.render_s
    }

    /// The rendering error that ended the stream early, if any.
    pub fn error(&self) -> Option<&RenderError> {
        self.error.as_ref()
    }

    /// End of the scenario (ns): no sample or frame is taken after it.
    pub fn end_ns(&self) -> i64 {
        self.end_ns
    }

    /// Generates one more IMU sample into the queue (possibly lost to a fault); `false` once the
    /// IMU has passed the end.
    fn generate_imu(&mut self) -> bool {
        if self.imu.next_time_ns() > self.end_ns {
            self.imu_done = true;
            return false;
        }
        let period = self.imu.period_ns();
        let (s, b) = self.imu.next_sample(&mut self.truth);
        self.biases.push_back(b);
        if let Some(s) = self.faults.apply_imu(s, period) {
            self.imu_queue.push_back(s);
        }
        true
    }

    /// Makes sure a frame is pending unless the rig has passed the end; a rendered stream also
    /// keeps the next [`RenderWorker::STAGES`] frames pending with their render jobs submitted.
    fn fill_frame(&mut self) {
        let want = if self.worker.is_some() {
            1 + RenderWorker::STAGES
        } else {
            1
        };
        while self.pending.len() < want && !self.rig_done {
            let Some(rig) = self.rig.as_mut() else {
                self.rig_done = true;
                return;
            };
            if rig.next_capture_ns() > self.end_ns {
                self.rig_done = true;
                return;
            }
            let period = rig.config().period_ns();
            let frame_index = rig.next_index();
            let (t_cap, f) = rig.next_frame(&mut self.truth);
            let Some(frame) = self.faults.apply_frame(f, t_cap, period) else {
                continue;
            };
            let images = self.worker.is_some().then(|| {
                let live: Vec<usize> = frame.cameras.iter().map(|c| c.cam_id).collect();
                self.submit_render(t_cap, frame.t_ns, frame_index, live)
            });
            self.pending.push_back(PendingFrame { frame, images });
        }
    }

    /// Starts rendering the cameras `live` for the capture at true time `t_cap` (black images
    /// during a blackout with black frames, made here).
    fn submit_render(
        &mut self,
        t_cap: i64,
        t_ns: i64,
        frame_index: u64,
        live: Vec<usize>,
    ) -> PendingImages {
        let worker = self.worker.as_ref().expect("rendered stream");
        if self.faults.black_frames_at(t_cap) {
            let cameras = live
                .iter()
                .map(|&c| {
                    let (w, h) = worker.image_sizes[c];
                    CameraImage {
                        cam_id: c,
                        image: GrayImage::black(w, h),
                        // Nothing seen.
                        depth: worker.depth.then(|| DepthImage {
                            width: w,
                            height: h,
                            data: vec![0.0; (w as usize) * (h as usize)],
                        }),
                    }
                })
                .collect();
            return PendingImages::Ready(ImageFrame {
                t_ns,
                t_capture_ns: t_cap,
                cameras,
            });
        }
        let offsets = worker.exposure_offsets_ns.clone();
        let poses_w_b = offsets
            .iter()
            .map(|o| {
                let k = self
                    .truth
                    .kinematics(t_cap + o)
                    .or_else(|| self.truth.kinematics(t_cap))
                    .expect("ground truth at a capture time");
                k.pose
            })
            .collect();
        let worker = self.worker.as_ref().expect("rendered stream");
        worker.submit(RenderJob {
            t_capture_ns: t_cap,
            stamp_ns: t_ns,
            frame_index,
            poses_w_b,
            live,
        });
        PendingImages::Rendering
    }

    /// The images of the oldest pending frame (waits for its render job); a render error ends
    /// the stream.
    fn take_images(&mut self, slot: PendingImages) -> Option<ImageFrame> {
        match slot {
            PendingImages::Ready(images) => {
                self.render_s = 0.0;
                Some(images)
            }
            PendingImages::Rendering => {
                let (out, seconds) = self.worker.as_ref()?.receive();
                self.render_s = seconds;
                match out {
                    Ok(images) => Some(images),
                    Err(e) => {
                        self.error = Some(e);
                        self.pending.clear();
                        self.rig_done = true;
                        self.imu_done = true;
                        self.imu_queue.clear();
                        None
                    }
                }
            }
        }
    }

    fn fill_imu(&mut self) {
        while self.imu_queue.is_empty() && !self.imu_done {
            self.generate_imu();
        }
    }

    fn trim(&mut self) {
        let keep_from = self
            .last_emitted_ns
            .saturating_sub(self.retention_ns)
            .min(self.imu.needs_from_ns())
            .min(
                self.pending
                    .front()
                    .map(|p| p.frame.t_ns - self.truth.step_ns())
                    .into_iter()
                    .chain(
                        self.rig
                            .as_ref()
                            .map(|r| r.next_capture_ns() - self.truth.step_ns()),
                    )
                    .min()
                    .unwrap_or(i64::MAX),
            )
            .min(
                [
                    self.aiding.gnss.as_ref().map(|g| g.next_time_ns()),
                    self.aiding.wheel.as_ref().map(|w| w.next_time_ns()),
                ]
                .into_iter()
                .flatten()
                .min()
                .map_or(i64::MAX, |t| t - self.truth.step_ns()),
            );
        self.truth.trim(keep_from);
        while self.biases.len() > 2 && self.biases[1].t_ns <= keep_from {
            self.biases.pop_front();
        }
    }

    /// The landmark a camera reported as `feature_id` (a scene landmark, or one the rig seeded);
    /// `None` for ids no camera has reported or without a rig.
    pub fn landmark(&self, feature_id: u64) -> Option<Landmark> {
        self.rig.as_ref()?.landmark(feature_id).copied()
    }

    /// Ground truth at `t_ns` (true time), generating ahead as needed. `None` before the start
    /// or older than the retention window behind the last emitted event.
    ///
    /// Pose, velocity and rates come from the physics (see [`TruthBuffer`]); biases are the
    /// simulated IMU's bias random walk (a recorded log's: the recording's biases, or zero),
    /// linear between IMU samples.
    pub fn truth(&mut self, t_ns: i64) -> Option<GroundTruth> {
        if t_ns < 0 {
            return None;
        }
        while self.biases.back().is_none_or(|b| b.t_ns < t_ns) && self.generate_imu() {}
        let k: Kinematics = self.truth.kinematics(t_ns)?;
        let (gyro_bias, accel_bias) = self.bias_at(t_ns)?;
        Some(GroundTruth {
            t_ns,
            pose: k.pose,
            v_w: k.v_w,
            a_w: k.a_w,
            omega_b: k.omega_b,
            gyro_bias,
            accel_bias,
        })
    }

    fn bias_at(&self, t_ns: i64) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let first = self.biases.front()?;
        if t_ns < first.t_ns {
            return None;
        }
        let i = self.biases.partition_point(|b| b.t_ns <= t_ns);
        let b0 = &self.biases[i - 1];
        match self.biases.get(i) {
            Some(b1) => {
                let f = (t_ns - b0.t_ns) as f64 / (b1.t_ns - b0.t_ns) as f64;
                Some((
                    b0.gyro + (b1.gyro - b0.gyro) * f,
                    b0.accel + (b1.accel - b0.accel) * f,
                ))
            }
            None => Some((b0.gyro, b0.accel)),
        }
    }
}

impl Iterator for Stream {
    type Item = Measurement;

    fn next(&mut self) -> Option<Measurement> {
        self.fill_imu();
        self.fill_frame();
        self.fill_aiding();
        // The earliest event; on equal stamps IMU, wheel, GNSS, then the frame.
        let candidates = [
            self.imu_queue.front().map(|s| s.t_ns),
            self.wheel_next.map(|s| s.t_ns),
            self.gnss_next.map(|s| s.t_ns),
            self.pending.front().map(|p| p.frame.t_ns),
        ];
        let (first, _) = candidates
            .iter()
            .enumerate()
            .filter_map(|(i, t)| t.map(|t| (i, t)))
            .min_by_key(|&(i, t)| (t, i))?;
        let out = if first == 0 {
            Measurement::Imu(self.imu_queue.pop_front()?)
        } else if first == 1 {
            Measurement::Wheel(self.wheel_next.take()?)
        } else if first == 2 {
            Measurement::Gnss(self.gnss_next.take()?)
        } else if let Some(slot) = self.pending.front_mut()?.images.take() {
            let mut images = self.take_images(slot)?;
            self.faults.apply_images(&mut images);
            Measurement::Images(images)
        } else {
            Measurement::Frame(self.pending.pop_front()?.frame)
        };
        self.last_emitted_ns = self.last_emitted_ns.max(out.t_ns());
        self.trim();
        Some(out)
    }
}
