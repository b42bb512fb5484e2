//! Platform vibration seen by the IMU: band noise and narrow lines (rotor harmonics), one
//! profile at rest and one in motion, blended by a speed proxy so a platform at rest is as quiet
//! as its rest profile says.
//!
//! # Model
//! Each profile is a list of bands (a flat one-sided density per axis over `[lo_hz, hi_hz)`,
//! holding the band's RMS) and lines (a sinusoid of the given RMS per axis, random phase per
//! seed). The activity `a ∈ [0, 1]` follows the ground-truth speed: 0 at or below
//! `speed_at_rest_m_s`, 1 at or above `speed_in_flight_m_s`, linear between, and smoothed by a
//! first-order lag of `time_constant_s` (rotors spin up and down; the first sample starts at its
//! target). The vibration is `√(1 − a)·rest + √a·flight` of two independent draws, so its
//! density blends linearly between the profiles. It is added to the sensor's output after the
//! scale/misalignment and before saturation, like the real sensor's reading of the shaking it
//! sits on, and it is not part of the bias.

use nalgebra::Vector3;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;

use crate::shaped_noise::ShapedNoise;

/// A band of vibration noise.
#[derive(Clone, Debug, PartialEq)]
pub struct VibrationBand {
    /// Lower edge (Hz).
    pub lo_hz: f64,
    /// Upper edge (Hz), at most half the IMU rate.
    pub hi_hz: f64,
    /// RMS of the gyroscope reading in the band, per axis (rad/s).
    pub gyro_rms: Vector3<f64>,
    /// RMS of the accelerometer reading in the band, per axis (m/s²).
    pub accel_rms: Vector3<f64>,
}

/// A narrow vibration line: a sinusoid per axis.
#[derive(Clone, Debug, PartialEq)]
pub struct VibrationLine {
    /// Frequency (Hz), below half the IMU rate.
    pub freq_hz: f64,
    /// RMS of the gyroscope sinusoid per axis (rad/s).
    pub gyro_rms: Vector3<f64>,
    /// RMS of the accelerometer sinusoid per axis (m/s²).
    pub accel_rms: Vector3<f64>,
}

/// The vibration of one operating state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VibrationProfile {
    /// Band noise.
    pub bands: Vec<VibrationBand>,
    /// Narrow lines.
    pub lines: Vec<VibrationLine>,
}

/// How the ground-truth speed sets the activity between the rest and the motion profiles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ActivityProxy {
    /// At or below this speed the rest profile alone (m/s).
    pub speed_at_rest_m_s: f64,
    /// At or above this speed the motion profile alone (m/s).
    pub speed_in_flight_m_s: f64,
    /// First-order lag of the activity (s); 0 follows the speed at once.
    pub time_constant_s: f64,
}

impl ActivityProxy {
    /// The activity a speed asks for.
    pub fn target(&self, speed_m_s: f64) -> f64 {
        let span = self.speed_in_flight_m_s - self.speed_at_rest_m_s;
        if span <= 0.0 {
            return if speed_m_s > self.speed_at_rest_m_s {
                1.0
            } else {
                0.0
            };
        }
        ((speed_m_s - self.speed_at_rest_m_s) / span).clamp(0.0, 1.0)
    }
}

/// Vibration at rest and in motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Vibration {
    /// The platform at rest (rotors idling, engine running, or nothing).
    pub rest: VibrationProfile,
    /// The platform moving.
    pub flight: VibrationProfile,
    /// Speed proxy blending the two.
    pub activity: ActivityProxy,
}

/// One profile's generators: three axes per sensor, and each line's phases.
#[derive(Debug)]
struct ProfileSource {
    gyro: [ShapedNoise; 3],
    accel: [ShapedNoise; 3],
    lines: Vec<(VibrationLine, [f64; 6])>,
}

/// The one-sided density of `bands` for the RMS `rms` picks out of each (one axis of one sensor).
fn band_density(
    bands: &[VibrationBand],
    rms: impl Fn(&VibrationBand) -> f64,
) -> impl Fn(f64) -> f64 {
    let flat: Vec<(f64, f64, f64)> = bands
        .iter()
        .map(|b| (b.lo_hz, b.hi_hz, rms(b).powi(2) / (b.hi_hz - b.lo_hz)))
        .collect();
    move |f| {
        flat.iter()
            .filter(|(lo, hi, _)| f >= *lo && f < *hi)
            .map(|(_, _, s)| s)
            .sum()
    }
}

impl ProfileSource {
    fn new(p: &VibrationProfile, fs_hz: f64, rng: &mut ChaCha8Rng) -> Self {
        // Drawn in this order: gyro x, y, z, then accel x, y, z.
        let gyro: [ShapedNoise; 3] = std::array::from_fn(|a| {
            ShapedNoise::new(fs_hz, band_density(&p.bands, |b| b.gyro_rms[a]), rng)
        });
        let accel: [ShapedNoise; 3] = std::array::from_fn(|a| {
            ShapedNoise::new(fs_hz, band_density(&p.bands, |b| b.accel_rms[a]), rng)
        });
        let lines = p
            .lines
            .iter()
            .map(|l| {
                let phases = std::array::from_fn(|_| rng.random::<f64>() * std::f64::consts::TAU);
                (l.clone(), phases)
            })
            .collect();
        Self { gyro, accel, lines }
    }

    fn next(&mut self, t_s: f64, rng: &mut ChaCha8Rng) -> (Vector3<f64>, Vector3<f64>) {
        let mut g = Vector3::zeros();
        let mut a = Vector3::zeros();
        for i in 0..3 {
            g[i] = self.gyro[i].next_sample(rng);
            a[i] = self.accel[i].next_sample(rng);
        }
        for (line, phase) in &self.lines {
            let arg = std::f64::consts::TAU * line.freq_hz * t_s;
            for i in 0..3 {
                g[i] += line.gyro_rms[i] * std::f64::consts::SQRT_2 * (arg + phase[i]).sin();
                a[i] += line.accel_rms[i] * std::f64::consts::SQRT_2 * (arg + phase[i + 3]).sin();
            }
        }
        (g, a)
    }
}

/// Draws the vibration sample by sample.
#[derive(Debug)]
pub struct VibrationSource {
    rest: ProfileSource,
    flight: ProfileSource,
    activity: ActivityProxy,
    /// Current activity; `None` before the first sample.
    level: Option<f64>,
    period_s: f64,
    rng: ChaCha8Rng,
}

impl VibrationSource {
    /// Generators for an IMU sampling at `fs_hz`, drawing from `rng` (its own stream).
    pub fn new(v: &Vibration, fs_hz: f64, mut rng: ChaCha8Rng) -> Self {
        let rest = ProfileSource::new(&v.rest, fs_hz, &mut rng);
        let flight = ProfileSource::new(&v.flight, fs_hz, &mut rng);
        Self {
            rest,
            flight,
            activity: v.activity,
            level: None,
            period_s: 1.0 / fs_hz,
            rng,
        }
    }

    /// The activity the last sample used (0 before the first).
    pub fn activity(&self) -> f64 {
        self.level.unwrap_or(0.0)
    }

    /// The vibration (gyro, accel) of the sample at `t_s` with the platform at `speed_m_s`.
    pub fn next(&mut self, t_s: f64, speed_m_s: f64) -> (Vector3<f64>, Vector3<f64>) {
        let target = self.activity.target(speed_m_s);
        let level = match self.level {
            None => target,
            Some(prev) if self.activity.time_constant_s > 0.0 => {
                let keep = (-self.period_s / self.activity.time_constant_s).exp();
                target + (prev - target) * keep
            }
            Some(_) => target,
        };
        self.level = Some(level);
        let (gr, ar) = self.rest.next(t_s, &mut self.rng);
        let (gf, af) = self.flight.next(t_s, &mut self.rng);
        let (wr, wf) = ((1.0 - level).sqrt(), level.sqrt());
        (gr * wr + gf * wf, ar * wr + af * wf)
    }
}
