//! A measured IMU log against the IMU its ground truth implies: the residual in flight and at
//! rest, the clock lag and the frame check. `vio imu-model --gt` reports it (with Allan
//! deviations and spectra of the residual on top), and so does a run that replays a recorded
//! IMU log (`report.json` → `replay.recorded_imu`).

use estimator::imu::ImuSample;
use nalgebra::Vector3;

use super::options::{MIN_SAMPLES, Options};
use super::report::{GroundTruthSection, ResidualStats, SensorPair};
use super::residual::{
    self, GRAVITY, Implied, clock_lag, default_knot_spacing_s, detect_rest, frame_rotation,
    gt_period_and_gaps, implied_bandwidth_hz, implied_imu, moving_average,
};
use super::spectrum::runs_of;
use crate::dataset::GroundTruthState;

/// Clock search range (s, either way).
const CLOCK_SEARCH_S: f64 = 0.05;
/// At most this many samples either way (an IMU faster than 20 kHz searches less than ±50 ms).
const MAX_CLOCK_LAGS: usize = 1000;

/// The comparison of a log with its ground truth.
#[derive(Clone, Debug)]
pub struct Comparison {
    /// What `imu_model.json` → `groundtruth` holds.
    pub section: GroundTruthSection,
    /// Measured − implied, per sample.
    pub residual: SensorPair<Vec<Vector3<f64>>>,
    /// Samples the ground truth covers…
    pub covered: Vec<bool>,
    /// …of those, at rest…
    pub rest: Vec<bool>,
    /// …and in flight.
    pub flight: Vec<bool>,
    /// The ground truth's speed at each sample (m/s; 0 where it does not cover).
    pub speed: Vec<f64>,
}

fn stats(r: &[Vector3<f64>], mask: &[bool]) -> (Option<[f64; 3]>, Option<[f64; 3]>) {
    let n = mask.iter().filter(|m| **m).count();
    if n == 0 {
        return (None, None);
    }
    let mut sum = Vector3::zeros();
    let mut sq = Vector3::zeros();
    for (x, _) in r.iter().zip(mask).filter(|(_, m)| **m) {
        sum += x;
        sq += x.component_mul(x);
    }
    let rms = (sq / n as f64).map(f64::sqrt);
    let mean = sum / n as f64;
    (Some([rms.x, rms.y, rms.z]), Some([mean.x, mean.y, mean.z]))
}

fn residual_stats(r: &[Vector3<f64>], rest: &[bool], flight: &[bool]) -> ResidualStats {
    let (rms_flight, mean_flight) = stats(r, flight);
    let (rms_rest, mean_rest) = stats(r, rest);
    ResidualStats {
        rms_flight,
        rms_rest,
        mean_flight,
        mean_rest,
    }
}

/// Compares the samples `sel` (median period `dt` s) of the log named `log` with the ground
/// truth `gt` read from `path` (same clock); `t0` is the stamp times in the report count from.
/// `Err` says why the ground truth cannot be compared (too few rows, too little overlap).
pub fn compare(
    sel: &[ImuSample],
    dt: f64,
    log: &str,
    path: &str,
    gt: &[GroundTruthState],
    opts: &Options,
    t0: i64,
) -> Result<Comparison, String> {
    let (gt_period, gt_gaps) = gt_period_and_gaps(gt);
    let knots = opts
        .knot_spacing_s
        .unwrap_or_else(|| default_knot_spacing_s(gt_period));
    let implied: Implied = implied_imu(gt, sel, knots).map_err(|e| format!("{path}: {e}"))?;
    let covered = &implied.covered;
    let n_cov = covered.iter().filter(|c| **c).count();
    if n_cov < MIN_SAMPLES {
        return Err(format!(
            "{path}: the ground truth covers {n_cov} of the {} selected samples of {log}; the comparison needs at least {MIN_SAMPLES} (does it belong to this log?)",
            sel.len(),
        ));
    }
    let bandwidth = implied_bandwidth_hz(gt_period, knots);
    let (rest, rest_rule) = match opts.rest_until_s {
        Some(s) => (
            sel.iter()
                .zip(covered)
                .map(|(x, c)| *c && ((x.t_ns - t0) as f64 * 1e-9) < s)
                .collect::<Vec<bool>>(),
            format!("--rest-until {s} s"),
        ),
        None => (
            detect_rest(&implied, dt),
            format!(
                "ground truth: speed < {} m/s and |ω| < {} rad/s for ≥ {} s",
                residual::REST_SPEED_M_S,
                residual::REST_RATE_RAD_S,
                residual::REST_MIN_S
            ),
        ),
    };
    let rel_s = |s: &ImuSample| (s.t_ns - t0) as f64 * 1e-9;
    let flight: Vec<bool> = covered.iter().zip(&rest).map(|(c, r)| *c && !r).collect();
    let n_rest = rest.iter().filter(|r| **r).count();
    let n_flight = flight.iter().filter(|r| **r).count();
    let r_gyro: Vec<Vector3<f64>> = sel
        .iter()
        .zip(&implied.gyro)
        .map(|(s, i)| s.gyro - i)
        .collect();
    let r_accel: Vec<Vector3<f64>> = sel
        .iter()
        .zip(&implied.accel)
        .map(|(s, i)| s.accel - i)
        .collect();

    // Clock and frame over the flight (or everything covered when nothing flies), the measured
    // rate low-passed to the implied IMU's band.
    let moving = if n_flight >= MIN_SAMPLES {
        &flight
    } else {
        covered
    };
    let half = ((0.25 / (bandwidth.max(0.5) * dt)).round() as usize).max(1);
    let low = |v: Vec<f64>| moving_average(&v, half);
    let meas_lp: Vec<Vector3<f64>> = {
        let axes: Vec<Vec<f64>> = (0..3)
            .map(|a| low(sel.iter().map(|s| s.gyro[a]).collect()))
            .collect();
        (0..sel.len())
            .map(|i| Vector3::new(axes[0][i], axes[1][i], axes[2][i]))
            .collect()
    };
    let meas_mag: Vec<f64> = meas_lp.iter().map(|w| w.norm()).collect();
    let impl_mag: Vec<f64> = implied.gyro.iter().map(|w| w.norm()).collect();
    let max_lag = ((CLOCK_SEARCH_S / dt).round() as usize).clamp(1, MAX_CLOCK_LAGS);
    let clock = clock_lag(&[&meas_mag], &[&impl_mag], moving, dt, max_lag);
    let meas_unbiased: Vec<Vector3<f64>> = meas_lp
        .iter()
        .zip(&implied.gyro_bias)
        .map(|(m, b)| m - b)
        .collect();
    let impl_unbiased: Vec<Vector3<f64>> = implied
        .gyro
        .iter()
        .zip(&implied.gyro_bias)
        .map(|(w, b)| w - b)
        .collect();
    let frame = frame_rotation(&meas_unbiased, &impl_unbiased, moving);
    let channels = |v: &[Vector3<f64>]| -> Vec<Vec<f64>> {
        (0..3).map(|a| v.iter().map(|x| x[a]).collect()).collect()
    };
    let (mc, ic) = (channels(&meas_unbiased), channels(&impl_unbiased));
    let mr: Vec<&[f64]> = mc.iter().map(Vec::as_slice).collect();
    let ir: Vec<&[f64]> = ic.iter().map(Vec::as_slice).collect();
    let clock_vector = clock_lag(&mr, &ir, moving, dt, max_lag);

    let section = GroundTruthSection {
        path: path.to_string(),
        rows: gt.len(),
        period_s: gt_period,
        gaps: gt_gaps,
        knot_spacing_s: knots,
        rest_stretches_s: runs_of(&rest)
            .into_iter()
            .map(|r| [rel_s(&sel[r.start]), rel_s(&sel[r.end - 1])])
            .collect(),
        valid_bandwidth_hz: bandwidth,
        gravity: GRAVITY,
        covered_samples: n_cov,
        rest_samples: n_rest,
        flight_samples: n_flight,
        rest_rule,
        clock,
        clock_vector,
        frame,
        residual: SensorPair {
            gyro: residual_stats(&r_gyro, &rest, &flight),
            accel: residual_stats(&r_accel, &rest, &flight),
        },
    };
    Ok(Comparison {
        section,
        residual: SensorPair {
            gyro: r_gyro,
            accel: r_accel,
        },
        covered: implied.covered,
        rest,
        flight,
        speed: implied.speed,
    })
}
