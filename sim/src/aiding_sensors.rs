//! Aiding sensors: a GNSS-like position receiver and wheel odometry, each sampled from the
//! physics ground truth with its own noise stream (`sensor_rng(seed, name)`, so adding one
//! never changes another sensor's noise). Faults (outages, a bias jump, wheel slip) are applied
//! by the stream's [`crate::faults::FaultTimeline`].
//!
//! The receiver's frame is the simulator's world frame: the estimator, which starts in a frame
//! of its own, has to find the alignment between the two.

use estimator::{GnssSample, WheelSample};
use nalgebra::Vector3;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::motion::{Kinematics, TruthBuffer};
use crate::rng::sensor_rng;

/// A GNSS-like position receiver.
#[derive(Clone, Debug, PartialEq)]
pub struct GnssConfig {
    /// Noise stream name.
    pub name: String,
    /// Fix rate (Hz; the period must be a whole number of nanoseconds).
    pub rate_hz: f64,
    /// White noise σ per axis, east / north / up (m); also what the receiver reports.
    pub sigma_m: Vector3<f64>,
    /// Antenna position in the body frame (m).
    pub lever_arm_b: Vector3<f64>,
}

impl Default for GnssConfig {
    /// 10 Hz, 0.3 m horizontal and 0.5 m vertical (a good single-frequency receiver with
    /// augmentation), antenna 0.2 m above the IMU.
    fn default() -> Self {
        Self {
            name: "gnss".into(),
            rate_hz: 10.0,
            sigma_m: Vector3::new(0.3, 0.3, 0.5),
            lever_arm_b: Vector3::new(0.0, 0.0, 0.2),
        }
    }
}

impl GnssConfig {
    /// Fix period (ns).
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round() as i64
    }
}

/// Wheel odometry: the vehicle's forward speed (body x) at the body origin.
#[derive(Clone, Debug, PartialEq)]
pub struct WheelConfig {
    /// Noise stream name.
    pub name: String,
    /// Reading rate (Hz; the period must be a whole number of nanoseconds).
    pub rate_hz: f64,
    /// White noise σ of the speed (m/s).
    pub sigma_m_s: f64,
}

impl Default for WheelConfig {
    /// 50 Hz, 2 cm/s.
    fn default() -> Self {
        Self {
            name: "wheel".into(),
            rate_hz: 50.0,
            sigma_m_s: 0.02,
        }
    }
}

impl WheelConfig {
    /// Reading period (ns).
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round() as i64
    }
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// What both sensors share: a sample every `period_ns` from `t = 0`, the ground truth at it and
/// the sensor's own noise stream.
#[derive(Debug)]
struct Sampling {
    period_ns: i64,
    next_k: i64,
    rng: ChaCha8Rng,
}

impl Sampling {
    fn new(name: &str, period_ns: i64, seed: u64) -> Self {
        Self {
            period_ns,
            next_k: 0,
            rng: sensor_rng(seed, name),
        }
    }

    fn next_time_ns(&self) -> i64 {
        self.next_k * self.period_ns
    }

    /// The next sample's time and ground truth.
    fn take(&mut self, truth: &mut TruthBuffer) -> (i64, Kinematics) {
        let t_ns = self.next_time_ns();
        self.next_k += 1;
        let k = truth
            .kinematics(t_ns)
            .expect("ground truth is kept for the next sample");
        (t_ns, k)
    }
}

/// Generates GNSS fixes one by one from the ground truth (the first at `t = 0`).
#[derive(Debug)]
pub struct GnssSim {
    cfg: GnssConfig,
    sampling: Sampling,
}

impl GnssSim {
    /// A receiver drawing noise from the stream of `cfg.name`.
    pub fn new(cfg: GnssConfig, seed: u64) -> Self {
        let sampling = Sampling::new(&cfg.name, cfg.period_ns(), seed);
        Self { cfg, sampling }
    }

    /// Time of the next fix (ns).
    pub fn next_time_ns(&self) -> i64 {
        self.sampling.next_time_ns()
    }

    /// The next fix: the antenna's true position plus white noise.
    pub fn next_sample(&mut self, truth: &mut TruthBuffer) -> GnssSample {
        let (t_ns, k) = self.sampling.take(truth);
        let antenna = k.pose.transform(&self.cfg.lever_arm_b);
        let rng = &mut self.sampling.rng;
        let noise = Vector3::from_fn(|i, _| normal(rng) * self.cfg.sigma_m[i]);
        GnssSample {
            t_ns,
            p_g: antenna + noise,
            sigma_m: self.cfg.sigma_m,
        }
    }
}

/// Generates wheel readings one by one from the ground truth (the first at `t = 0`).
#[derive(Debug)]
pub struct WheelSim {
    cfg: WheelConfig,
    sampling: Sampling,
}

impl WheelSim {
    /// Wheel odometry drawing noise from the stream of `cfg.name`.
    pub fn new(cfg: WheelConfig, seed: u64) -> Self {
        let sampling = Sampling::new(&cfg.name, cfg.period_ns(), seed);
        Self { cfg, sampling }
    }

    /// Time of the next reading (ns).
    pub fn next_time_ns(&self) -> i64 {
        self.sampling.next_time_ns()
    }

    /// The next reading: the true forward body velocity plus white noise.
    pub fn next_sample(&mut self, truth: &mut TruthBuffer) -> WheelSample {
        let (t_ns, k) = self.sampling.take(truth);
        let forward = (k.pose.q.inverse() * k.v_w).x;
        WheelSample {
            t_ns,
            speed_m_s: forward + normal(&mut self.sampling.rng) * self.cfg.sigma_m_s,
        }
    }
}
