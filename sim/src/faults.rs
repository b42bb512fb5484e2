//! A timeline of faults applied to the measurement stream.
//!
//! Each fault is active on `[start_ns, end_ns)` of *true* time (the time a sample or frame was
//! taken). Faults that need randomness draw from their own streams (`faults/frame_drops`,
//! `faults/imu_spikes`, `faults/jitter/imu`, `faults/jitter/camera`), so adding a fault never
//! changes sensor noise.

use crate::render::{CameraImage, ImageFrame};
use crate::rng::sensor_rng;
use estimator::frontend::{FeatureFrame, FeatureObservation};
use estimator::imu::ImuSample;
use estimator::{GnssSample, WheelSample};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// One fault.
#[derive(Clone, Debug, PartialEq)]
pub enum Fault {
    /// All cameras black out: no frames (`black_frames = false`) or frames whose cameras report
    /// no features (`black_frames = true`, an image with nothing to track).
    CameraBlackout {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
        /// Emit empty frames instead of none.
        black_frames: bool,
    },
    /// Camera `cam_id` (every camera when `None`) freezes on `[start_ns, end_ns)`: it keeps
    /// delivering, on time, the image (and the features) of its last capture before the
    /// freeze, as a stuck driver does; from the first capture when frozen from the start.
    CameraFreeze {
        /// The camera; `None`: all.
        cam_id: Option<usize>,
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
    },
    /// Camera `cam_id` dies permanently at `at_ns`: its entry disappears from every later frame.
    CameraDeath {
        /// The camera.
        cam_id: usize,
        /// Time of death (ns).
        at_ns: i64,
    },
    /// Each frame is dropped with `probability`.
    FrameDrops {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
        /// Drop probability per frame.
        probability: f64,
    },
    /// No IMU samples.
    ImuDropout {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
    },
    /// With `probability` per sample, a spike of ± the magnitudes is added to one random axis of
    /// the gyroscope and of the accelerometer.
    ImuSpikes {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
        /// Spike probability per sample.
        probability: f64,
        /// Gyroscope spike (rad/s).
        gyro: f64,
        /// Accelerometer spike (m/s²).
        accel: f64,
    },
    /// Readings are clamped per axis to the given ranges.
    ImuSaturation {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
        /// Gyroscope range (rad/s).
        gyro_range: f64,
        /// Accelerometer range (m/s²).
        accel_range: f64,
    },
    /// Gaussian timestamp jitter, clipped to ±0.4 of the sensor period so order is kept.
    TimestampJitter {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
        /// IMU stamp jitter σ (ns).
        imu_sigma_ns: f64,
        /// Camera stamp jitter σ (ns).
        camera_sigma_ns: f64,
    },
    /// No GNSS fixes on `[start_ns, end_ns)` (an end past the run: the receiver is removed).
    GnssOutage {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
    },
    /// From `at_ns` on every fix is off by `offset_m` (a multipath or reference-station
    /// change), while the receiver keeps reporting its usual accuracy.
    GnssBiasJump {
        /// Time of the jump (ns).
        at_ns: i64,
        /// The offset (m, receiver frame).
        offset_m: nalgebra::Vector3<f64>,
    },
    /// The wheels slip on `[start_ns, end_ns)`: they report `1 + slip_ratio` times the true
    /// forward speed.
    WheelSlip {
        /// Start (ns).
        start_ns: i64,
        /// End (ns).
        end_ns: i64,
        /// Relative excess speed of the wheels.
        slip_ratio: f64,
    },
    /// Frames captured from `start_ns` on are stamped `td_ns` earlier (`t_imu = t_cam + td`),
    /// on top of the rig's own offset.
    CameraTimeOffset {
        /// Start (ns).
        start_ns: i64,
        /// Offset (ns).
        td_ns: i64,
    },
}

/// Faults plus the random streams they draw from.
#[derive(Debug)]
pub struct FaultTimeline {
    faults: Vec<Fault>,
    /// Per camera, its last features and image before a freeze (kept only when the timeline
    /// has a freeze).
    frozen_features: Vec<Option<Vec<FeatureObservation>>>,
    frozen_images: Vec<Option<CameraImage>>,
    drops: ChaCha8Rng,
    spikes: ChaCha8Rng,
    jitter_imu: ChaCha8Rng,
    jitter_cam: ChaCha8Rng,
}

fn active(t: i64, start: i64, end: i64) -> bool {
    t >= start && t < end
}

/// True if a freeze covers camera `cam` at capture time `t`.
fn frozen_at(faults: &[Fault], cam: usize, t: i64) -> bool {
    faults.iter().any(|f| {
        matches!(*f, Fault::CameraFreeze { cam_id, start_ns, end_ns }
            if cam_id.is_none_or(|c| c == cam) && active(t, start_ns, end_ns))
    })
}

/// Camera `cam`'s entry of a per-camera store, grown as needed.
fn slot<T>(store: &mut Vec<Option<T>>, cam: usize) -> &mut Option<T> {
    if store.len() <= cam {
        store.resize_with(cam + 1, || None);
    }
    &mut store[cam]
}

fn jitter(rng: &mut ChaCha8Rng, sigma: f64, period_ns: i64) -> i64 {
    let n: f64 = StandardNormal.sample(rng);
    let lim = 0.4 * period_ns as f64;
    (n * sigma).clamp(-lim, lim).round() as i64
}

impl FaultTimeline {
    /// A timeline of `faults` with random streams from `seed`.
    pub fn new(faults: Vec<Fault>, seed: u64) -> Self {
        Self {
            faults,
            frozen_features: Vec::new(),
            frozen_images: Vec::new(),
            drops: sensor_rng(seed, "faults/frame_drops"),
            spikes: sensor_rng(seed, "faults/imu_spikes"),
            jitter_imu: sensor_rng(seed, "faults/jitter/imu"),
            jitter_cam: sensor_rng(seed, "faults/jitter/camera"),
        }
    }

    /// The faults.
    pub fn faults(&self) -> &[Fault] {
        &self.faults
    }

    /// Applies the IMU faults to a sample taken at its own `t_ns` (period `period_ns`);
    /// `None` if the sample is lost.
    pub fn apply_imu(&mut self, mut s: ImuSample, period_ns: i64) -> Option<ImuSample> {
        let t = s.t_ns;
        let mut stamp = t;
        for f in &self.faults {
            match *f {
                Fault::ImuDropout { start_ns, end_ns } if active(t, start_ns, end_ns) => {
                    return None;
                }
                Fault::ImuSpikes {
                    start_ns,
                    end_ns,
                    probability,
                    gyro,
                    accel,
                } if active(t, start_ns, end_ns) && self.spikes.random::<f64>() < probability => {
                    let ag = self.spikes.random_range(0..3usize);
                    let aa = self.spikes.random_range(0..3usize);
                    let sg = if self.spikes.random::<bool>() {
                        1.0
                    } else {
                        -1.0
                    };
                    let sa = if self.spikes.random::<bool>() {
                        1.0
                    } else {
                        -1.0
                    };
                    s.gyro[ag] += sg * gyro;
                    s.accel[aa] += sa * accel;
                }
                Fault::ImuSaturation {
                    start_ns,
                    end_ns,
                    gyro_range,
                    accel_range,
                } if active(t, start_ns, end_ns) => {
                    s.gyro = s.gyro.map(|x| x.clamp(-gyro_range, gyro_range));
                    s.accel = s.accel.map(|x| x.clamp(-accel_range, accel_range));
                }
                Fault::TimestampJitter {
                    start_ns,
                    end_ns,
                    imu_sigma_ns,
                    ..
                } if active(t, start_ns, end_ns) && imu_sigma_ns > 0.0 => {
                    stamp += jitter(&mut self.jitter_imu, imu_sigma_ns, period_ns);
                }
                _ => {}
            }
        }
        s.t_ns = stamp;
        Some(s)
    }

    /// Applies the GNSS faults to a fix; `None` if it is lost.
    pub fn apply_gnss(&self, mut s: GnssSample) -> Option<GnssSample> {
        for f in &self.faults {
            match *f {
                Fault::GnssOutage { start_ns, end_ns } if active(s.t_ns, start_ns, end_ns) => {
                    return None;
                }
                Fault::GnssBiasJump { at_ns, offset_m } if s.t_ns >= at_ns => s.p_g += offset_m,
                _ => {}
            }
        }
        Some(s)
    }

    /// Applies the wheel faults to a reading.
    pub fn apply_wheel(&self, mut s: WheelSample) -> WheelSample {
        for f in &self.faults {
            if let Fault::WheelSlip {
                start_ns,
                end_ns,
                slip_ratio,
            } = *f
                && active(s.t_ns, start_ns, end_ns)
            {
                s.speed_m_s *= 1.0 + slip_ratio;
            }
        }
        s
    }

    /// Applies the camera faults to a frame captured at true time `t_cap` (period `period_ns`);
    /// `None` if the frame is lost.
    pub fn apply_frame(
        &mut self,
        mut frame: FeatureFrame,
        t_cap: i64,
        period_ns: i64,
    ) -> Option<FeatureFrame> {
        let t = t_cap;
        for f in &self.faults {
            match *f {
                Fault::CameraBlackout {
                    start_ns,
                    end_ns,
                    black_frames,
                } if active(t, start_ns, end_ns) => {
                    if !black_frames {
                        return None;
                    }
                    for c in &mut frame.cameras {
                        c.features.clear();
                    }
                }
                Fault::CameraDeath { cam_id, at_ns } if t >= at_ns => {
                    frame.cameras.retain(|c| c.cam_id != cam_id);
                }
                Fault::FrameDrops {
                    start_ns,
                    end_ns,
                    probability,
                } if active(t, start_ns, end_ns) && self.drops.random::<f64>() < probability => {
                    return None;
                }
                Fault::TimestampJitter {
                    start_ns,
                    end_ns,
                    camera_sigma_ns,
                    ..
                } if active(t, start_ns, end_ns) && camera_sigma_ns > 0.0 => {
                    frame.t_ns += jitter(&mut self.jitter_cam, camera_sigma_ns, period_ns);
                }
                Fault::CameraTimeOffset { start_ns, td_ns } if t >= start_ns => {
                    frame.t_ns -= td_ns;
                }
                _ => {}
            }
        }
        if self.has_freeze() {
            for c in &mut frame.cameras {
                let slot = slot(&mut self.frozen_features, c.cam_id);
                match slot {
                    Some(last) if frozen_at(&self.faults, c.cam_id, t) => {
                        c.features.clone_from(last);
                    }
                    _ => *slot = Some(c.features.clone()),
                }
            }
        }
        Some(frame)
    }

    fn has_freeze(&self) -> bool {
        self.faults
            .iter()
            .any(|f| matches!(f, Fault::CameraFreeze { .. }))
    }

    /// Applies camera freezes to the images of a capture (frozen cameras repeat their last
    /// image before the freeze).
    pub fn apply_images(&mut self, images: &mut ImageFrame) {
        if !self.has_freeze() {
            return;
        }
        let t = images.t_capture_ns;
        for c in &mut images.cameras {
            let slot = slot(&mut self.frozen_images, c.cam_id);
            match slot {
                Some(last) if frozen_at(&self.faults, c.cam_id, t) => c.clone_from(last),
                _ => *slot = Some(c.clone()),
            }
        }
    }

    /// True if a blackout with black frames covers the capture time `t` (its frames carry black
    /// images and no features).
    pub fn black_frames_at(&self, t: i64) -> bool {
        self.faults.iter().any(|f| {
            matches!(*f, Fault::CameraBlackout { start_ns, end_ns, black_frames: true }
                if active(t, start_ns, end_ns))
        })
    }

    /// Largest stamp shift (ns, ≥ 0) the camera faults can apply in either direction: the
    /// stream looks this far ahead when merging.
    pub fn max_camera_shift_ns(&self, period_ns: i64) -> i64 {
        let mut m = 0;
        for f in &self.faults {
            match *f {
                Fault::TimestampJitter { .. } => m += (0.4 * period_ns as f64).ceil() as i64,
                Fault::CameraTimeOffset { td_ns, .. } => m += td_ns.abs(),
                _ => {}
            }
        }
        m
    }
}
