//! The IMU noise model an estimator should assume on the platform a log was flown on
//! (`estimator_imu_noise.toml`, for a scenario's `[estimator.imu_noise]`).
//!
//! A preintegrating estimator models the IMU's error as white noise plus a bias random walk.
//! In flight the residual against the ground truth is far from white (vibration lines and bands,
//! a wandering bias), so no density reproduces it at every time scale. What the estimator
//! integrates is the error over its IMU intervals, so the white density it assumes is the one
//! whose integral over the interval has the residual's own variance there: for white noise the
//! Allan deviation is `σ(τ) = N/√τ`, so `N = σ(τ)·√τ` read off the in-flight residual's Allan
//! deviation at the interval (the camera period, the shortest interval an IMU factor spans).
//! The axes share one density, the mean of their variances. The random walk adds to the
//! sensor's own the rate at which the fitted bias instability (a first-order Gauss–Markov
//! wander of deviation `σ_b = B/0.617` and correlation time `T`) spreads over times short
//! against `T`: `σ_b·√(2/T)`. Neither value goes below the sensor's datasheet.

use super::report::{EstimatorNoise, KalibrReference, SensorAllan, SensorPair};
use crate::spec::imu_error_model::BiasInstabilitySpec;

/// The Allan deviation at `tau` interpolated in log-log between the curve's points; `None`
/// outside the curve.
fn adev_at(s: &SensorAllan, axis: usize, tau: f64) -> Option<f64> {
    let c = &s.axes.get(axis)?.curve;
    let i = c.tau_s.iter().position(|&t| t >= tau)?;
    if c.tau_s[i] == tau || i == 0 {
        return (c.tau_s[i] == tau).then_some(c.adev[i]);
    }
    let (t0, t1) = (c.tau_s[i - 1].ln(), c.tau_s[i].ln());
    let (a0, a1) = (c.adev[i - 1].ln(), c.adev[i].ln());
    Some((a0 + (a1 - a0) * (tau.ln() - t0) / (t1 - t0)).exp())
}

/// White-equivalent density per axis at `tau`.
fn white_at(s: &SensorAllan, tau: f64) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    for (a, v) in out.iter_mut().enumerate() {
        *v = adev_at(s, a, tau)? * tau.sqrt();
    }
    Some(out)
}

fn rms(v: [f64; 3]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt()
}

/// One sensor's white density from its axes' values, never below the datasheet's `sheet`.
fn white_density(axes: [f64; 3], sheet: Option<f64>, name: &str, r: &mut Vec<String>) -> f64 {
    let measured = rms(axes);
    let axes = format!("{:.2e} {:.2e} {:.2e}", axes[0], axes[1], axes[2]);
    match sheet {
        Some(s) if measured < s => {
            r.push(format!(
                "{name}: the flight measured {measured:.3e} (axes {axes}), below the sensor.yaml's {s:.3e}: kept the sensor.yaml's"
            ));
            s
        }
        Some(s) => {
            r.push(format!(
                "{name}: {measured:.3e} = {:.1}× the sensor.yaml's {s:.3e} (axes {axes})",
                measured / s
            ));
            measured
        }
        None => {
            r.push(format!(
                "{name}: {measured:.3e} (axes {axes}; no sensor.yaml)"
            ));
            measured
        }
    }
}

/// The recommendation from the in-flight residual's Allan deviations, the interval, the
/// sensor's Kalibr values and the fitted bias instability; `None` where the residual's curve
/// does not reach the interval.
pub fn recommend(
    flight: &SensorPair<SensorAllan>,
    interval_s: f64,
    kalibr: Option<&KalibrReference>,
    bias: Option<&BiasInstabilitySpec>,
) -> Option<EstimatorNoise> {
    let per_axis = SensorPair {
        gyro: white_at(&flight.gyro, interval_s)?,
        accel: white_at(&flight.accel, interval_s)?,
    };
    let mut reasoning = vec![format!(
        "white densities: the in-flight residual's Allan deviation at the {:.0} ms IMU interval times √τ (the white noise that integrates to the same error over it), the mean of the axes' variances",
        interval_s * 1e3
    )];
    let gyro_n = white_density(
        per_axis.gyro,
        kalibr.map(|k| k.gyroscope_noise_density),
        "gyroscope_noise_density",
        &mut reasoning,
    );
    let accel_n = white_density(
        per_axis.accel,
        kalibr.map(|k| k.accelerometer_noise_density),
        "accelerometer_noise_density",
        &mut reasoning,
    );
    let walk = |sheet: Option<f64>, floor_b: Option<f64>, name: &str, r: &mut Vec<String>| {
        let wander = bias.zip(floor_b).map(|(b, floor_b)| {
            let sigma_b = floor_b / sim::bias_instability::ALLAN_PEAK_PER_SIGMA;
            sigma_b * (2.0 / b.correlation_s).sqrt()
        });
        let total = match (sheet, wander) {
            (None, None) => return None,
            (s, w) => (s.unwrap_or(0.0).powi(2) + w.unwrap_or(0.0).powi(2)).sqrt(),
        };
        r.push(match (sheet, wander, bias) {
            (Some(s), Some(w), Some(b)) => format!(
                "{name}: √(sensor.yaml {s:.3e}² + bias instability {w:.3e}²) = {total:.3e} ({:.1}× the sensor.yaml's; the wander σ_b·√(2/T), T = {:.2} s)",
                total / s,
                b.correlation_s
            ),
            (None, Some(w), _) => format!("{name}: the bias instability's {w:.3e} (no sensor.yaml)"),
            _ => format!("{name}: the sensor.yaml's {total:.3e} (no bias instability fitted)"),
        });
        Some(total)
    };
    let gyro_k = walk(
        kalibr.map(|k| k.gyroscope_random_walk),
        bias.map(|b| b.gyro_rad_s),
        "gyroscope_random_walk",
        &mut reasoning,
    );
    let accel_k = walk(
        kalibr.map(|k| k.accelerometer_random_walk),
        bias.map(|b| b.accel_m_s2),
        "accelerometer_random_walk",
        &mut reasoning,
    );
    Some(EstimatorNoise {
        interval_s,
        gyroscope_noise_density: gyro_n,
        accelerometer_noise_density: accel_n,
        gyroscope_random_walk: gyro_k,
        accelerometer_random_walk: accel_k,
        per_axis,
        reasoning,
    })
}

impl EstimatorNoise {
    /// `estimator_imu_noise.toml`: the reasoning as comments, then the keys of
    /// `[estimator.imu_noise]`.
    pub fn to_toml(&self, log: &str) -> String {
        let mut out = format!(
            "# The IMU noise model an estimator should assume on this platform, measured by `vio imu-model --gt`\n# from {log}.\n# Paste under [estimator.imu_noise], or name this file: [estimator] imu_noise = \"<path>\".\n"
        );
        for r in &self.reasoning {
            out.push_str(&format!("# {r}\n"));
        }
        out.push_str(&format!(
            "gyroscope_noise_density = {:?}\naccelerometer_noise_density = {:?}\n",
            self.gyroscope_noise_density, self.accelerometer_noise_density
        ));
        if let Some(k) = self.gyroscope_random_walk {
            out.push_str(&format!("gyroscope_random_walk = {k:?}\n"));
        }
        if let Some(k) = self.accelerometer_random_walk {
            out.push_str(&format!("accelerometer_random_walk = {k:?}\n"));
        }
        out
    }
}
