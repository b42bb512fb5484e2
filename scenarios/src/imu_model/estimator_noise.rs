//! The IMU noise model an estimator should assume on the platform a log was flown on
//! (`estimator_imu_noise.toml`, for a scenario's `[estimator.imu_noise]`).
//!
//! A preintegrating estimator models the IMU's error as white noise plus a bias random walk.
//! In flight the residual against the ground truth is far from white (vibration lines and bands,
//! a wandering bias), so no density reproduces it at every time scale. What the estimator
//! integrates is the error over the time scales its window spans: from one IMU factor (the
//! keyframe interval, at least the camera period) to the whole window. For white noise the
//! Allan deviation is `σ(τ) = N/√τ`; the density read off an Allan plot is the line of slope
//! −½ fitted in log-log over a band of τ, `ln N = mean ln(σ(τ)·√τ)`, and here the band is the
//! estimator's, `τ` log-spaced from the interval to the window's span. Vibration integrates
//! away faster than white noise (its deviation falls as `1/τ`), so the density matched at the
//! interval alone over-states the error over the window (measured on the realistic preset's
//! V1_01: velocity and gyroscope-bias NEES at a third of their band's centre), and the one
//! matched at the window alone under-states it for one factor. The axes share one density, the
//! mean of their variances, never below the sensor's datasheet. A fitted bias instability (a
//! first-order Gauss–Markov wander of deviation `σ_b = B/0.617` and correlation time `T`) is
//! handed on as what it is, for the estimator's Gauss–Markov bias model
//! (`estimator::bias_process`), and the random walks are the sensor's own beside it. (The
//! first version folded the wander into the random walk, `σ_b·√(2/T)` in quadrature: right
//! over times short against `T`, it forgets the bias faster than the bias moves over longer
//! ones, and left the gyroscope-bias NEES under-confident on the V1_01 preset, 1.46 against a
//! band from 1.68.)

use estimator::bias_process::BiasProcess;

use super::allan::AllanCurve;
use super::report::{EstimatorNoise, KalibrReference, SensorAllan, SensorPair};
use crate::spec::imu_error_model::BiasInstabilitySpec;

/// The Allan deviation at `tau` interpolated in log-log between the curve's points; `None`
/// outside the curve.
fn adev_at(c: &AllanCurve, tau: f64) -> Option<f64> {
    let i = c.tau_s.iter().position(|&t| t >= tau)?;
    if c.tau_s[i] == tau || i == 0 {
        return (c.tau_s[i] == tau).then_some(c.adev[i]);
    }
    let (t0, t1) = (c.tau_s[i - 1].ln(), c.tau_s[i].ln());
    let (a0, a1) = (c.adev[i - 1].ln(), c.adev[i].ln());
    Some((a0 + (a1 - a0) * (tau.ln() - t0) / (t1 - t0)).exp())
}

/// Points of the band the slope −½ line is fitted over (log-spaced, both ends included).
const BAND_POINTS: usize = 16;

/// The longest `τ` of the sensor's curves (the shortest over its axes).
fn longest_tau(s: &SensorAllan) -> f64 {
    s.axes
        .iter()
        .map(|a| a.curve.tau_s.last().copied().unwrap_or(0.0))
        .fold(f64::INFINITY, f64::min)
}

/// One curve's white-equivalent density over the band `[lo, hi]`: the geometric mean of
/// `σ(τ)·√τ` at log-spaced `τ` (the slope −½ line fitted in log-log); `None` where the curve
/// does not reach `lo`.
fn band_density(c: &AllanCurve, (lo, hi): (f64, f64)) -> Option<f64> {
    let n = if hi > lo { BAND_POINTS } else { 1 };
    let mut sum = 0.0;
    for k in 0..n {
        let f = if n == 1 {
            0.0
        } else {
            k as f64 / (n - 1) as f64
        };
        let tau = (lo.ln() + f * (hi / lo).ln()).exp().min(hi);
        sum += (adev_at(c, tau)? * tau.sqrt()).ln();
    }
    Some((sum / n as f64).exp())
}

/// [`band_density`] per axis.
fn white_over(s: &SensorAllan, band: (f64, f64)) -> Option<[f64; 3]> {
    let mut out = [0.0; 3];
    for (a, v) in out.iter_mut().enumerate() {
        *v = band_density(&s.axes.get(a)?.curve, band)?;
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

/// The recommendation from the in-flight residual's Allan deviations, the band of time scales
/// `(interval, window)` (s) the estimator spans, the sensor's Kalibr values and the fitted bias
/// instability; `None` where the residual's curve does not reach the interval. A curve shorter
/// than the window is fitted up to its end, and the reasoning says so.
pub fn recommend(
    flight: &SensorPair<SensorAllan>,
    (interval_s, window_s): (f64, f64),
    kalibr: Option<&KalibrReference>,
    bias: Option<&BiasInstabilitySpec>,
) -> Option<EstimatorNoise> {
    let reach = longest_tau(&flight.gyro).min(longest_tau(&flight.accel));
    let clipped = window_s > reach;
    let window_s = window_s.min(reach).max(interval_s);
    let band = (interval_s, window_s);
    let per_axis = SensorPair {
        gyro: white_over(&flight.gyro, band)?,
        accel: white_over(&flight.accel, band)?,
    };
    let mut reasoning = vec![format!(
        "white densities: the slope −½ line (white noise) fitted in log-log to the in-flight residual's Allan deviation over the estimator's time scales, {:.0} ms (the IMU interval) to {:.0} ms (its window's span){}: the white noise that integrates to the same error over them; the mean of the axes' variances",
        interval_s * 1e3,
        window_s * 1e3,
        if clipped {
            ", the curve's end short of the window"
        } else {
            ""
        }
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
    // With a fitted bias instability the estimator models it as what it is, a Gauss–Markov
    // wander about a constant (the three bias-instability keys), and the random walks are the
    // sensor's own beside it; the random walk an estimator without that model would use
    // instead (the wander's spread over times short against T, added in quadrature) is said.
    let process =
        bias.map(|b| BiasProcess::from_allan_floors(b.gyro_rad_s, b.accel_m_s2, b.correlation_s));
    let spreads = process.map(|p| p.random_walk_equivalents());
    let walk = |sheet: Option<f64>, wander: Option<f64>, name: &str, r: &mut Vec<String>| {
        r.push(match (sheet, wander) {
            (Some(s), Some(w)) => format!(
                "{name}: the sensor.yaml's {s:.3e}, beside the bias instability (an estimator that models the bias as a random walk alone: √({s:.3e}² + {w:.3e}²) = {:.3e}, the wander σ_b·√(2/T))",
                (s * s + w * w).sqrt()
            ),
            (None, Some(w)) => format!(
                "{name}: not set (no sensor.yaml), beside the bias instability (a random walk alone: the wander's {w:.3e})"
            ),
            (Some(s), None) => format!("{name}: the sensor.yaml's {s:.3e} (no bias instability fitted)"),
            (None, None) => return None,
        });
        sheet
    };
    let gyro_k = walk(
        kalibr.map(|k| k.gyroscope_random_walk),
        spreads.map(|(_, g)| g),
        "gyroscope_random_walk",
        &mut reasoning,
    );
    let accel_k = walk(
        kalibr.map(|k| k.accelerometer_random_walk),
        spreads.map(|(a, _)| a),
        "accelerometer_random_walk",
        &mut reasoning,
    );
    if let (Some(b), Some(p)) = (bias, process) {
        reasoning.push(format!(
            "bias instability: the fitted Gauss–Markov wander, Allan floors {:.3e} rad/s and {:.3e} m/s² (σ_b = floor/0.617: {:.3e} and {:.3e}), correlation time {:.2} s; the estimator holds the biases' constant mean as a state",
            b.gyro_rad_s, b.accel_m_s2, p.sigma_gyro, p.sigma_accel, b.correlation_s
        ));
    }
    Some(EstimatorNoise {
        interval_s,
        window_s,
        gyroscope_noise_density: gyro_n,
        accelerometer_noise_density: accel_n,
        gyroscope_random_walk: gyro_k,
        accelerometer_random_walk: accel_k,
        bias_instability: bias.map(|b| (b.gyro_rad_s, b.accel_m_s2, b.correlation_s)),
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
        if let Some((gyro, accel, tau)) = self.bias_instability {
            out.push_str(&format!(
                "gyroscope_bias_instability = {gyro:?}\naccelerometer_bias_instability = {accel:?}\nbias_correlation_time_s = {tau:?}\n"
            ));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(f: impl Fn(f64) -> f64) -> AllanCurve {
        let tau_s: Vec<f64> = (0..40).map(|k| 0.005 * 1.25f64.powi(k)).collect();
        AllanCurve {
            adev: tau_s.iter().map(|&t| f(t)).collect(),
            cluster_samples: vec![1; tau_s.len()],
            relative_sigma: vec![0.0; tau_s.len()],
            tau_s,
        }
    }

    #[test]
    fn white_noise_reads_its_own_density_over_any_band() {
        let c = curve(|t| 2e-3 / t.sqrt());
        for band in [(0.05, 0.05), (0.05, 0.8), (0.1, 2.0)] {
            let n = band_density(&c, band).unwrap();
            assert!((n / 2e-3 - 1.0).abs() < 1e-9, "{band:?}: {n}");
        }
    }

    /// Vibration integrates away as 1/τ: over a band its density is the one at the band's
    /// log-midpoint, below the interval's and above the window's.
    #[test]
    fn vibration_reads_the_density_at_the_bands_log_midpoint() {
        let c = curve(|t| 1e-4 / t);
        let (lo, hi) = (0.05f64, 0.8f64);
        let n = band_density(&c, (lo, hi)).unwrap();
        let mid = (lo * hi).sqrt();
        assert!((n / (1e-4 / mid.sqrt()) - 1.0).abs() < 1e-6, "{n}");
        assert!(n < 1e-4 / lo.sqrt() && n > 1e-4 / hi.sqrt());
        // A curve that does not reach the band's start gives nothing.
        assert!(band_density(&c, (1e-3, 0.8)).is_none());
    }
}
