//! Zero-velocity detection and its factor. A platform at rest is the one motion every sensor
//! can confirm: the gyroscope reads its bias, the accelerometer reads gravity plus its bias with
//! no more spread than its noise, and the features stand still but for their pixel noise.
//! When all of them agree over `ZeroVelocityConfig::window_s`, the newest frame gets a
//! [`ZeroVelocityFactor`](crate::factors::ZeroVelocityFactor): its velocity is zero and its gyroscope bias is the mean rate read,
//! so a stop costs no drift and calibrates the gyroscope.
//!
//! The decision, over the IMU samples of the last `window_s` and the features of the frame
//! about `window_s` old against the newest:
//! - gyroscope: `‖ω̄ − b_g‖ ≤ max_rate_rad_s`, and the spread `Σ‖ω_k − ω̄‖²/σ_g²` below the
//!   `χ²(3(N−1))` quantile at `chi2_z` (σ_g the discrete noise, density · √rate);
//! - accelerometer: the same spread test with σ_a;
//! - a vibrating platform (rotors, an idling engine) fails those spread tests at rest: a real
//!   MAV on the ground with its rotors spinning (EuRoC V1_01) shows 10–30× the datasheet's
//!   white noise, in lines around 20–30 Hz. Where a sensor's spread fails, the test is run
//!   again on the means of [`SEGMENTS`] consecutive segments of the window against the noise
//!   measured within them: `m Σ‖μ_s − μ‖²/σ̂²` below the `χ²(3(S−1))` quantile, with `σ̂²` the
//!   pooled within-segment variance (taken only when it exceeds the datasheet's: otherwise the
//!   spread came from motion, not noise). Vibration averages out within a segment, a change of
//!   acceleration or rate moves the segment means apart. The zero-velocity factor's gyroscope
//!   mean then carries `σ̂` instead of the datasheet's σ_g;
//! - images: the median displacement of the shared features of each live camera below
//!   `image_motion_sigmas` pixel σ (at rest the median of the displacement norm of two noisy
//!   measurements is 1.67 σ; 0.1 m/s at 3 m depth moves a 458 px focal image by 3.8 px over
//!   0.25 s);
//! - the window: the newest frame's predicted speed at most `max_speed_m_s` (the sensors alone
//!   cannot tell a slow creep from rest over `window_s`).
//!
//! An accelerometer and gyroscope without vibration cannot tell rest from a straight line at
//! constant speed: without a live camera the frame is only declared at rest when
//! `imu_only_when_blind` allows it (a platform known to stop, e.g. a pedestrian or a vehicle at
//! traffic lights; off by default).

use std::collections::{BTreeMap, VecDeque};

use nalgebra::{Vector2, Vector3};

use super::Estimator;
use super::chi2::chi2_quantile;
use super::config::ZeroVelocityConfig;
use super::frame::WindowFrame;
use crate::factors::ZeroVelocityFactor;
use crate::frontend::FeatureFrame;
use crate::imu::{ImuNoise, ImuSample};

/// Fewest features two frames of a camera must share for an image decision.
const MIN_SHARED: usize = 10;

/// Segments of the rest window whose means the vibration test compares.
pub const SEGMENTS: usize = 5;

/// What the IMU showed over a rest interval: the mean gyroscope reading and how many samples
/// it averages.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Rest {
    pub gyro_mean: Vector3<f64>,
    pub samples: usize,
    /// The IMU rate the samples came at (Hz).
    pub rate_hz: f64,
    /// Standard deviation of one gyroscope sample (rad/s): the datasheet's discrete noise, or
    /// the measured one on a vibrating platform.
    pub gyro_sample_sigma: f64,
}

/// Whether one sensor's samples `x` (mean `m`) stand still: their spread within the white-noise
/// χ² quantile (`3(n−1)` degrees of freedom) at σ `s`, or, where that fails, the segment means
/// within theirs against the noise measured inside the segments (see the module
/// documentation). Returns the per-sample σ that explains the samples.
fn sensor_at_rest(
    x: &[Vector3<f64>],
    m: &Vector3<f64>,
    s: f64,
    config: &ZeroVelocityConfig,
) -> Option<f64> {
    let n = x.len();
    let spread = x.iter().map(|v| (v - m).norm_squared()).sum::<f64>() / (s * s);
    if spread <= chi2_quantile(3 * (n - 1), config.chi2_z) {
        return Some(s);
    }
    let len = n / SEGMENTS;
    if len < 2 {
        return None;
    }
    // The newest `SEGMENTS · len` samples.
    let segments: Vec<&[Vector3<f64>]> = x[n - SEGMENTS * len..].chunks(len).collect();
    let means: Vec<Vector3<f64>> = segments
        .iter()
        .map(|seg| seg.iter().sum::<Vector3<f64>>() / len as f64)
        .collect();
    let within = segments
        .iter()
        .zip(&means)
        .map(|(seg, mu)| seg.iter().map(|v| (v - mu).norm_squared()).sum::<f64>())
        .sum::<f64>()
        / (3 * SEGMENTS * (len - 1)) as f64;
    // Within-segment noise no larger than the datasheet's: the spread was motion.
    if within <= s * s {
        return None;
    }
    let mean = means.iter().sum::<Vector3<f64>>() / SEGMENTS as f64;
    let between = len as f64
        * means
            .iter()
            .map(|mu| (mu - mean).norm_squared())
            .sum::<f64>()
        / within;
    (between <= chi2_quantile(3 * (SEGMENTS - 1), config.chi2_z)).then(|| within.sqrt())
}

/// Whether `samples` (≥ 3) show rest: mean rate within `max_rate_rad_s` of the bias `bg` and
/// both spreads within their χ² quantiles. Returns the rest statistics when they do.
pub(super) fn imu_at_rest(
    samples: &[ImuSample],
    bg: &Vector3<f64>,
    noise: &ImuNoise,
    rate_hz: f64,
    config: &ZeroVelocityConfig,
) -> Option<Rest> {
    let n = samples.len();
    if n < 3 {
        return None;
    }
    let mean = |f: &dyn Fn(&ImuSample) -> Vector3<f64>| -> Vector3<f64> {
        samples.iter().map(f).sum::<Vector3<f64>>() / n as f64
    };
    let (w, a) = (mean(&|s| s.gyro), mean(&|s| s.accel));
    if (w - bg).norm() > config.max_rate_rad_s {
        return None;
    }
    let sqrt_rate = rate_hz.sqrt();
    let (sg, sa) = (
        noise.gyroscope_noise_density * sqrt_rate,
        noise.accelerometer_noise_density * sqrt_rate,
    );
    let gyro: Vec<Vector3<f64>> = samples.iter().map(|s| s.gyro).collect();
    let accel: Vec<Vector3<f64>> = samples.iter().map(|s| s.accel).collect();
    let gyro_sample_sigma = sensor_at_rest(&gyro, &w, sg, config)?;
    sensor_at_rest(&accel, &a, sa, config)?;
    Some(Rest {
        gyro_mean: w,
        samples: n,
        rate_hz,
        gyro_sample_sigma,
    })
}

/// Median displacement (px) of the features two frames share; `None` below [`MIN_SHARED`].
fn median_motion(
    then: &BTreeMap<u64, Vector2<f64>>,
    now: &BTreeMap<u64, Vector2<f64>>,
) -> Option<f64> {
    let mut moved: Vec<f64> = now
        .iter()
        .filter_map(|(id, uv)| then.get(id).map(|p| (uv - p).norm()))
        .collect();
    if moved.len() < MIN_SHARED {
        return None;
    }
    moved.sort_by(f64::total_cmp);
    Some(moved[moved.len() / 2])
}

/// The features of each camera of one frame, by id (px).
type CameraFeatures = [BTreeMap<u64, Vector2<f64>>; 2];

/// Recent frames' features per camera, for the image test.
#[derive(Clone, Debug, Default)]
pub(super) struct RestMonitor {
    /// `(IMU time, features by id of each camera)`, oldest first, about `window_s` deep.
    frames: VecDeque<(i64, CameraFeatures)>,
}

impl RestMonitor {
    /// Records a frame's features at IMU time `t_ns`, keeping what the test needs.
    fn record(&mut self, t_ns: i64, frame: &FeatureFrame, window_ns: i64) {
        let mut features: CameraFeatures = Default::default();
        for cf in frame.cameras.iter().filter(|c| c.cam_id < 2) {
            features[cf.cam_id] = cf.features.iter().map(|f| (f.feature_id, f.uv)).collect();
        }
        self.frames.push_back((t_ns, features));
        // Keep the newest frame at least `window_ns` old, drop older ones.
        while self.frames.len() > 2 && self.frames[1].0 <= t_ns - window_ns {
            self.frames.pop_front();
        }
    }

    /// The image verdict between the oldest kept frame (if at least `window_ns` old) and the
    /// newest: `Some(true)` when every camera with enough shared features stands still,
    /// `Some(false)` when one moves, `None` when no camera can tell.
    fn images_at_rest(&self, window_ns: i64, max_px: &[f64]) -> Option<bool> {
        let (first, last) = (self.frames.front()?, self.frames.back()?);
        if last.0 - first.0 < window_ns {
            return None;
        }
        let mut verdict = None;
        for (cam, limit) in max_px.iter().enumerate().take(2) {
            if let Some(m) = median_motion(&first.1[cam], &last.1[cam]) {
                if m > *limit {
                    return Some(false);
                }
                verdict = Some(true);
            }
        }
        verdict
    }
}

impl Estimator {
    /// Whether the platform is at rest at the frame `frame` whose predicted state is `newest`
    /// (not yet in the window; see the module documentation); the rest statistics when it is.
    pub(super) fn detect_rest(
        &mut self,
        frame: &FeatureFrame,
        newest: &WindowFrame,
    ) -> Option<Rest> {
        let t_ns = newest.t_ns;
        let config = self.config.zero_velocity;
        let window_ns = (config.window_s * 1e9).round() as i64;
        self.rest_monitor.record(t_ns, frame, window_ns);
        self.rest_test(newest, window_ns)
    }

    fn rest_test(&self, newest: &WindowFrame, window_ns: i64) -> Option<Rest> {
        let config = self.config.zero_velocity;
        let (t_ns, bg) = (newest.t_ns, &newest.bg);
        if !(config.enabled && self.config.suite.uses_imu()) {
            return None;
        }
        // Only a tracking window's velocity means anything (before initialization it is 0).
        if self.status != super::Status::Tracking || newest.v.norm() > config.max_speed_m_s {
            return None;
        }
        // The samples of the last `window_s`, from the IMU intervals of the newest frames (the
        // buffer keeps only what the next interval needs), and their rate.
        let mut samples: Vec<ImuSample> = Vec::new();
        for f in std::iter::once(newest).chain(self.window.frames.iter().rev()) {
            let Some(p) = &f.preint else { break };
            samples.extend(p.samples().iter().filter(|s| s.t_ns >= t_ns - window_ns));
            if p.start_ns() <= t_ns - window_ns {
                break;
            }
        }
        samples.sort_by_key(|s| s.t_ns);
        samples.dedup_by_key(|s| s.t_ns);
        let span_ns = samples.last()?.t_ns - samples.first()?.t_ns;
        if samples.len() < 3 || span_ns < window_ns - window_ns / 10 {
            return None;
        }
        let rate_hz = (samples.len() - 1) as f64 / (span_ns as f64 * 1e-9);
        let rest = imu_at_rest(&samples, bg, &self.config.imu_noise, rate_hz, &config)?;
        let max_px: Vec<f64> = self
            .config
            .cameras
            .iter()
            .map(|c| config.image_motion_sigmas * c.pixel_sigma)
            .collect();
        let at_rest = match self.rest_monitor.images_at_rest(window_ns, &max_px) {
            Some(verdict) => verdict,
            None => config.imu_only_when_blind,
        };
        at_rest.then_some(rest)
    }
}

impl Rest {
    /// The zero-velocity factor of this rest interval, its velocity held to
    /// `velocity_sigma` (m/s).
    pub(super) fn factor(&self, velocity_sigma: f64) -> ZeroVelocityFactor {
        ZeroVelocityFactor {
            velocity_sigma,
            gyro_mean: self.gyro_mean,
            gyro_mean_sigma: self.gyro_sample_sigma / (self.samples.max(1) as f64).sqrt(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic standard normal samples (Box–Muller on an LCG).
    fn normals(seed: &mut u64, n: usize) -> Vec<f64> {
        let mut u = || {
            *seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((*seed >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n)
            .map(|_| {
                let (a, b) = (u(), u());
                (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
            })
            .collect()
    }

    fn samples(rate: Vector3<f64>, accel: Vector3<f64>, n: usize, seed: u64) -> Vec<ImuSample> {
        let noise = ImuNoise::euroc();
        let (sg, sa) = (
            noise.gyroscope_noise_density * 200f64.sqrt(),
            noise.accelerometer_noise_density * 200f64.sqrt(),
        );
        let mut s = seed;
        (0..n)
            .map(|k| {
                let e = normals(&mut s, 6);
                ImuSample::new(
                    k as i64 * 5_000_000,
                    rate + Vector3::new(e[0], e[1], e[2]) * sg,
                    accel + Vector3::new(e[3], e[4], e[5]) * sa,
                )
                .unwrap()
            })
            .collect()
    }

    #[test]
    fn imu_rest_test_passes_rest_and_vibration_and_refuses_turns_and_acceleration() {
        let (noise, config) = (ImuNoise::euroc(), ZeroVelocityConfig::default());
        let bg = Vector3::new(0.003, -0.002, 0.0015);
        let g = Vector3::new(0.05, -0.04, 9.89);
        // At rest: 100 seeds of 50 samples, all pass (χ² at 3 σ: about 1 in 700 fails).
        let passed = (0..100)
            .filter(|s| imu_at_rest(&samples(bg, g, 50, *s), &bg, &noise, 200.0, &config).is_some())
            .count();
        assert!(passed >= 98, "{passed} of 100");
        // Turning at 0.02 rad/s about z.
        let turning = samples(bg + Vector3::new(0.0, 0.0, 0.02), g, 50, 1);
        assert!(imu_at_rest(&turning, &bg, &noise, 200.0, &config).is_none());
        // Vibrating at rest (±0.3 m/s² at 100 Hz, ±0.03 rad/s at 25 Hz: ten times the
        // datasheet's noise): rest, and the gyroscope mean carries the measured noise.
        let vibrating = |ramp: f64, seed| {
            let mut v = samples(bg, g, 50, seed);
            for (k, s) in v.iter_mut().enumerate() {
                s.accel.x += if k % 2 == 0 { 0.3 } else { -0.3 } + ramp * k as f64 / 50.0;
                s.gyro.y += 0.03 * (std::f64::consts::FRAC_PI_4 * k as f64).sin();
            }
            v
        };
        let passed = (0..100)
            .filter(|&s| imu_at_rest(&vibrating(0.0, s), &bg, &noise, 200.0, &config).is_some())
            .count();
        assert!(passed >= 98, "{passed} of 100");
        let rest = imu_at_rest(&vibrating(0.0, 2), &bg, &noise, 200.0, &config).unwrap();
        assert!(rest.gyro_sample_sigma > 0.01, "{}", rest.gyro_sample_sigma);
        // The same vibration while the acceleration changes by 1 m/s² over the window.
        let accelerating = (0..100)
            .filter(|&s| imu_at_rest(&vibrating(1.0, s), &bg, &noise, 200.0, &config).is_some())
            .count();
        assert!(accelerating <= 2, "{accelerating} of 100");
        // Without vibration an acceleration change fails the white-noise spread and is not
        // mistaken for vibration.
        let mut ramp = samples(bg, g, 50, 4);
        for (k, s) in ramp.iter_mut().enumerate() {
            s.accel.x += 0.2 * k as f64 / 50.0;
        }
        assert!(imu_at_rest(&ramp, &bg, &noise, 200.0, &config).is_none());
        // The mean rate it reports averages the noise down.
        let rest = imu_at_rest(&samples(bg, g, 50, 3), &bg, &noise, 200.0, &config).unwrap();
        assert_eq!(rest.samples, 50);
        assert!((rest.gyro_mean - bg).norm() < 4.0 * 2.4e-3 / 50f64.sqrt());
    }

    #[test]
    fn image_rest_test_sees_pixel_noise_as_rest_and_a_slow_drift_as_motion() {
        let mut seed = 9;
        let frame = |shift: f64, seed: &mut u64| {
            let e = normals(seed, 200);
            let features = (0..100)
                .map(|i| crate::frontend::FeatureObservation {
                    feature_id: i as u64,
                    uv: Vector2::new(
                        100.0 + 5.0 * i as f64 + shift + e[2 * i],
                        200.0 + e[2 * i + 1],
                    ),
                })
                .collect();
            FeatureFrame {
                t_ns: 0,
                cameras: vec![crate::frontend::CameraFeatures {
                    cam_id: 0,
                    features,
                }],
            }
        };
        let window = 250_000_000;
        let mut m = RestMonitor::default();
        for k in 0..6 {
            m.record(k * 50_000_000, &frame(0.0, &mut seed), window);
        }
        assert_eq!(m.images_at_rest(window, &[2.5]), Some(true));
        // 3 px over the window (e.g. 0.08 m/s at 3 m): moving.
        let mut m = RestMonitor::default();
        for k in 0..6 {
            m.record(k * 50_000_000, &frame(0.6 * k as f64, &mut seed), window);
        }
        assert_eq!(m.images_at_rest(window, &[2.5]), Some(false));
        // Too short a history: no verdict.
        let mut m = RestMonitor::default();
        m.record(0, &frame(0.0, &mut seed), window);
        assert_eq!(m.images_at_rest(window, &[2.5]), None);
    }
}
