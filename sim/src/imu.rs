//! The IMU: ideal specific force and angular rate consistent with the rapier integrator, plus
//! scale/misalignment, Kalibr-density white noise, bias random walk from known initial biases,
//! and saturation.
//!
//! # Consistency with the integrator
//! Physics step `j` (from state `j` to `j + 1`, length `h`) has the exact ideal IMU
//! `f_j = R_jᵀ((v_{j+1} − v_j)/h − g)`, `ω_j = R_jᵀ ω_{j+1}` ([`crate::motion::ideal_imu`]);
//! re-integrating these with [`crate::motion::integrate_step`] reproduces rapier's trajectory to
//! rounding (≈1e-10 m over 60 s). These per-step values are piecewise constant over their step.
//!
//! # IMU rate vs physics rate
//! The physics runs at an integer multiple `N` of the IMU rate (default 200 Hz × 5 = 1 kHz).
//! IMU sample `k` at `t_k = k·Δ` is the exact average of the piecewise-constant per-step values
//! over a window of length `Δ` ([`ImuWindow`]):
//! - [`ImuWindow::Centered`] (default): `[t_k − Δ/2, t_k + Δ/2]` (steps cut by the window edges
//!   weigh by their overlap). A box filter centred on the timestamp, like a real IMU's
//!   anti-aliasing, so the sample equals the true point value at `t_k` up to `Δ²/24·f̈`: the
//!   estimator's midpoint preintegration between frames is accurate (not exact). A step's
//!   specific force is the acceleration at its start state (the positions' second difference
//!   there), so it is averaged over `[t_j − h/2, t_j + h/2]`; its angular rate over the step
//!   itself ([`ImuSim::ideal`]).
//! - [`ImuWindow::Forward`]: `[t_k, t_k + Δ]`. With `N = 1` each sample is exactly the step's
//!   ideal IMU, so integrating the samples with the rapier scheme is exact.
//!
//! # Measurement model
//! `ω̃ = sat(M_g·ω + b_g + n_g)`, `ã = sat(M_a·f + b_a + n_a)` with `n ~ N(0, σ_c²/Δ)` and the
//! biases stepping `b ← b + N(0, σ_w²·Δ)` after each sample, starting from the configured initial
//! biases. The bias of sample `k` is recorded with it as ground truth.
//!
//! Two optional error sources real hardware adds, each drawing from its own random stream so a
//! datasheet IMU's samples are the same with or without them in the build:
//! - [`crate::bias_instability`]: a Gauss–Markov wander added to the bias (and to its ground
//!   truth);
//! - [`crate::vibration`]: band noise and lines, blended between a rest and a motion profile by
//!   the ground-truth speed, added to the reading (not to the bias).

use crate::bias_instability::{BiasInstability, BiasWander};
use crate::motion::{TruthBuffer, ideal_imu};
use crate::rng::sensor_rng;
use crate::vibration::{Vibration, VibrationSource};
use estimator::imu::{ImuNoise, ImuSample};
use nalgebra::{Matrix3, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Where the averaging window of an IMU sample lies relative to its timestamp.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ImuWindow {
    /// `[t − Δ/2, t + Δ/2]`: point value at `t` to second order (default).
    #[default]
    Centered,
    /// `[t, t + Δ]`: the increment over the following period (exact for the rapier scheme when
    /// the IMU runs at the physics rate).
    Forward,
}

/// IMU configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuConfig {
    /// Sensor name (selects its random stream).
    pub name: String,
    /// Sample rate (Hz); `1e9 / rate_hz` must be a whole number of nanoseconds.
    pub rate_hz: f64,
    /// Averaging window alignment.
    pub window: ImuWindow,
    /// Noise densities; `None` for a noise-free IMU with constant biases.
    pub noise: Option<ImuNoise>,
    /// Gyroscope bias at `t = 0` (rad/s).
    pub initial_gyro_bias: Vector3<f64>,
    /// Accelerometer bias at `t = 0` (m/s²).
    pub initial_accel_bias: Vector3<f64>,
    /// Gyroscope scale/misalignment matrix `M_g` (identity = ideal).
    pub gyro_matrix: Matrix3<f64>,
    /// Accelerometer scale/misalignment matrix `M_a` (identity = ideal).
    pub accel_matrix: Matrix3<f64>,
    /// Per-axis gyroscope range (rad/s); readings are clamped to ±this.
    pub gyro_range: Option<f64>,
    /// Per-axis accelerometer range (m/s²); readings are clamped to ±this.
    pub accel_range: Option<f64>,
    /// Platform vibration; `None`: none.
    pub vibration: Option<Vibration>,
    /// Bias instability; `None`: the bias is a pure random walk.
    pub bias_instability: Option<BiasInstability>,
}

impl Default for ImuConfig {
    /// EuRoC ADIS16448 densities at 200 Hz, known non-zero initial biases, ±300°/s and ±18 g.
    fn default() -> Self {
        Self {
            name: "imu".into(),
            rate_hz: 200.0,
            window: ImuWindow::Centered,
            noise: Some(ImuNoise::euroc()),
            initial_gyro_bias: Vector3::new(0.003, -0.002, 0.0015),
            initial_accel_bias: Vector3::new(0.05, -0.04, 0.08),
            gyro_matrix: Matrix3::identity(),
            accel_matrix: Matrix3::identity(),
            gyro_range: Some(300f64.to_radians()),
            accel_range: Some(18.0 * 9.81),
            vibration: None,
            bias_instability: None,
        }
    }
}

impl ImuConfig {
    /// A noise-free, bias-free, ideal IMU at `rate_hz`.
    pub fn ideal(rate_hz: f64) -> Self {
        Self {
            rate_hz,
            noise: None,
            initial_gyro_bias: Vector3::zeros(),
            initial_accel_bias: Vector3::zeros(),
            gyro_range: None,
            accel_range: None,
            ..Self::default()
        }
    }

    /// Sample period (ns).
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round() as i64
    }
}

/// True IMU biases at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuBias {
    /// Time (ns).
    pub t_ns: i64,
    /// Gyroscope bias (rad/s).
    pub gyro: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub accel: Vector3<f64>,
}

/// Generates IMU samples one by one from the physics ground truth.
#[derive(Debug)]
pub struct ImuSim {
    cfg: ImuConfig,
    period_ns: i64,
    next_k: i64,
    rng: ChaCha8Rng,
    bias: ImuBias,
    vibration: Option<VibrationSource>,
    wander: Option<BiasWander>,
}

fn gauss3(rng: &mut ChaCha8Rng, sigma: f64) -> Vector3<f64> {
    let mut n = || -> f64 { StandardNormal.sample(rng) };
    Vector3::new(n(), n(), n()) * sigma
}

/// The ground-truth speed at the physics state at or before `t_ns`.
fn speed_at(truth: &mut TruthBuffer, t_ns: i64) -> f64 {
    let tj = truth.step_at_or_before(t_ns);
    truth
        .state_at(tj)
        .expect("IMU sample precedes the buffered ground truth")
        .v
        .norm()
}

fn clamp3(v: Vector3<f64>, range: Option<f64>) -> Vector3<f64> {
    match range {
        Some(r) => v.map(|x| x.clamp(-r, r)),
        None => v,
    }
}

impl ImuSim {
    /// An IMU whose first sample is at `t = 0`, drawing noise from the stream of `cfg.name`.
    pub fn new(cfg: ImuConfig, seed: u64) -> Self {
        let rng = sensor_rng(seed, &cfg.name);
        let vibration = cfg.vibration.as_ref().map(|v| {
            VibrationSource::new(
                v,
                cfg.rate_hz,
                sensor_rng(seed, &format!("{}/vibration", cfg.name)),
            )
        });
        let period_s = cfg.period_ns() as f64 * 1e-9;
        let wander = cfg.bias_instability.as_ref().map(|b| {
            BiasWander::new(
                b,
                period_s,
                sensor_rng(seed, &format!("{}/bias_instability", cfg.name)),
            )
        });
        let bias = ImuBias {
            t_ns: 0,
            gyro: cfg.initial_gyro_bias,
            accel: cfg.initial_accel_bias,
        };
        Self {
            period_ns: cfg.period_ns(),
            cfg,
            next_k: 0,
            rng,
            bias,
            vibration,
            wander,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &ImuConfig {
        &self.cfg
    }

    /// Sample period (ns).
    pub fn period_ns(&self) -> i64 {
        self.period_ns
    }

    /// Timestamp of the next sample.
    pub fn next_time_ns(&self) -> i64 {
        self.next_k * self.period_ns
    }

    /// Earliest physics time the next sample needs (so the truth buffer may be trimmed to it).
    pub fn needs_from_ns(&self) -> i64 {
        self.next_time_ns() - self.period_ns
    }

    /// The noise-free, bias-free sample at `t_ns` (specific force, angular rate), averaged over
    /// the configured window. Requires the truth buffer to still hold the window.
    ///
    /// Where each physics step's values lie in time (see the module documentation): its angular
    /// rate is the rotation over the step, `[t_j, t_j + h]`; its specific force
    /// `R_jᵀ((v_{j+1} − v_j)/h − g)` is the second difference of the positions around `t_j`
    /// (`p_{j+1} − 2p_j + p_{j−1} = h(v_{j+1} − v_j)`), the acceleration at `t_j`, so the centred
    /// window averages it over `[t_j − h/2, t_j + h/2]`. (Taken over `[t_j, t_j + h]`, as the
    /// rapier scheme consumes it, it lagged the poses by `h/2`: 0.5 ms at the default 1 kHz,
    /// a velocity error of ~2e-4 m/s per 50 ms on a fast Lissajous.) The forward window keeps
    /// the scheme's own alignment: re-integrating its samples with the scheme is exact.
    pub fn ideal(&self, truth: &mut TruthBuffer, t_ns: i64) -> (Vector3<f64>, Vector3<f64>) {
        let h = truth.step_ns();
        let ((a, b), accel_shift) = match self.cfg.window {
            ImuWindow::Centered => (
                (t_ns - self.period_ns / 2, t_ns + (self.period_ns + 1) / 2),
                h / 2,
            ),
            ImuWindow::Forward => ((t_ns, t_ns + self.period_ns), 0),
        };
        // Step j's rate over [t_j, t_j + h] and its specific force over
        // [t_j − shift, t_j + h − shift], each weighted by its overlap with [a, b]; one pass over
        // the steps either touches.
        let weight = |lo: i64, hi: i64| (hi.min(b) - lo.max(a)) as f64 / (b - a) as f64;
        let mut tj = truth.step_at_or_before(a);
        let mut f = Vector3::zeros();
        let mut w = Vector3::zeros();
        while tj < b + accel_shift {
            let s0 = truth
                .state_at(tj)
                .expect("IMU window precedes the buffered ground truth");
            let s1 = truth.state_at(tj + h).expect("physics step missing");
            let (fj, wj) = ideal_imu(&s0, &s1);
            let (f_lo, f_hi) = (tj - accel_shift, tj + h - accel_shift);
            if f_hi > a && f_lo < b {
                f += fj * weight(f_lo, f_hi);
            }
            if tj < b {
                w += wj * weight(tj, tj + h);
            }
            tj += h;
        }
        (f, w)
    }

    /// Produces the next sample and the true bias it carries.
    pub fn next_sample(&mut self, truth: &mut TruthBuffer) -> (ImuSample, ImuBias) {
        let t_ns = self.next_time_ns();
        let (f, w) = self.ideal(truth, t_ns);
        let dt = self.period_ns as f64 * 1e-9;
        let mut bias = ImuBias { t_ns, ..self.bias };
        if let Some(wander) = &mut self.wander {
            let (g, a) = wander.current();
            bias.gyro += g;
            bias.accel += a;
            wander.step();
        }
        let mut gyro = self.cfg.gyro_matrix * w + bias.gyro;
        let mut accel = self.cfg.accel_matrix * f + bias.accel;
        if let Some(vibration) = &mut self.vibration {
            let speed = speed_at(truth, t_ns);
            let (g, a) = vibration.next(t_ns as f64 * 1e-9, speed);
            gyro += g;
            accel += a;
        }
        if let Some(n) = self.cfg.noise {
            gyro += gauss3(&mut self.rng, n.gyroscope_noise_density / dt.sqrt());
            accel += gauss3(&mut self.rng, n.accelerometer_noise_density / dt.sqrt());
            self.bias.gyro += gauss3(&mut self.rng, n.gyroscope_random_walk * dt.sqrt());
            self.bias.accel += gauss3(&mut self.rng, n.accelerometer_random_walk * dt.sqrt());
        }
        let sample = ImuSample {
            t_ns,
            gyro: clamp3(gyro, self.cfg.gyro_range),
            accel: clamp3(accel, self.cfg.accel_range),
        };
        self.next_k += 1;
        (sample, bias)
    }
}
