//! What a run on a recorded IMU log (`rig.imu.recorded`) reports about the log:
//! `report.json` → `replay.recorded_imu`, and one line of the summary.
//!
//! The log's samples within the run are compared with the IMU the recording's ground truth
//! implies, by the code of `vio imu-model --gt` ([`crate::imu_model::comparison::compare`]):
//! the clock lag, the frame check and the residual in flight and at rest. The white-noise σ
//! per sample of the `[rig.imu]` densities (what the estimator assumes) stands beside them.

use estimator::imu::{ImuNoise, ImuSample};
use serde::Serialize;

use crate::imu_model::comparison::compare;
use crate::imu_model::options::Options;
use crate::imu_model::report::{GroundTruthSection, SensorPair};
use crate::spec::RecordedImuLog;

/// Ground-truth rows kept beyond either end of the run (ns), so the spline through them covers
/// the run's first and last samples.
const GT_MARGIN_NS: i64 = 1_000_000_000;

/// `report.json` → `replay.recorded_imu`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RecordedImuReport {
    /// The log, as the scenario names it.
    pub file: String,
    /// Its samples within the run (before faults).
    pub samples: usize,
    /// Its median sample period (s).
    pub period_s: f64,
    /// Recording clock − run clock (ns): the shift the log and the ground truth share.
    pub clock_shift_ns: i64,
    /// The ground truth's biases: `recording` (the replayed file's bias columns) or `zero`.
    pub biases: &'static str,
    /// White-noise σ per sample of the `[rig.imu]` densities, `density · √rate` (rad/s, m/s²):
    /// what the estimator assumes.
    pub datasheet_sigma: SensorPair<f64>,
    /// The log against the IMU the recording's ground truth implies, over the run: clock lag,
    /// frame check, residual RMS in flight and at rest (`imu_model.json`'s `groundtruth`).
    pub comparison: Option<GroundTruthSection>,
    /// Why there is no comparison (a run too short, too little ground truth).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub comparison_error: Option<String>,
}

impl RecordedImuReport {
    /// The checks of `log` over the run's `[0, end_ns]`, with the estimator's densities
    /// `noise`.
    pub fn new(log: &RecordedImuLog, end_ns: i64, noise: &ImuNoise) -> Self {
        let sel: Vec<ImuSample> = log
            .log
            .samples()
            .iter()
            .filter(|s| (0..=end_ns).contains(&s.t_ns))
            .copied()
            .collect();
        let gt: Vec<_> = log
            .groundtruth
            .iter()
            .filter(|g| g.t_ns >= -GT_MARGIN_NS && g.t_ns <= end_ns + GT_MARGIN_NS)
            .copied()
            .collect();
        let dt = log.log.period_ns() as f64 * 1e-9;
        let result = if sel.is_empty() || dt <= 0.0 {
            Err("no samples of the log in the run".to_string())
        } else {
            compare(
                &sel,
                dt,
                &log.file,
                &log.groundtruth_file,
                &gt,
                &Options::default(),
                0,
            )
        };
        let (comparison, comparison_error) = match result {
            Ok(c) => (Some(c.section), None),
            Err(e) => (None, Some(e)),
        };
        let root_rate = if dt > 0.0 { dt.recip().sqrt() } else { 0.0 };
        Self {
            file: log.file.clone(),
            samples: sel.len(),
            period_s: dt,
            clock_shift_ns: log.shift_ns,
            biases: if log.biases_from_groundtruth {
                "recording"
            } else {
                "zero"
            },
            datasheet_sigma: SensorPair {
                gyro: noise.gyroscope_noise_density * root_rate,
                accel: noise.accelerometer_noise_density * root_rate,
            },
            comparison,
            comparison_error,
        }
    }

    /// One line for the run summary.
    pub fn summary(&self) -> String {
        let head = format!(
            "{}, {} samples, biases {}",
            self.file, self.samples, self.biases
        );
        let sigma = format!(
            "datasheet white noise {:.1e} rad/s, {:.1e} m/s² per sample",
            self.datasheet_sigma.gyro, self.datasheet_sigma.accel
        );
        let Some(c) = &self.comparison else {
            return format!(
                "{head}; no comparison with the ground truth ({}); {sigma}",
                self.comparison_error.as_deref().unwrap_or("-")
            );
        };
        let clock = match (&c.clock_vector, &c.clock) {
            (Some(v), Some(m)) => format!(
                "clock {:+.2} ms (rate vectors, correlation {:.4}; magnitudes {:+.2} ms)",
                v.lag_ms, v.correlation, m.lag_ms
            ),
            (Some(v), None) => format!(
                "clock {:+.2} ms (correlation {:.4})",
                v.lag_ms, v.correlation
            ),
            _ => "clock -".to_string(),
        };
        let frame = c.frame.map_or("frame -".to_string(), |f| {
            format!("frame {:.3}°", f.angle_deg)
        });
        // RMS over the three axes: comparable with a per-axis σ.
        let rms = |v: Option<[f64; 3]>| {
            v.map_or("-".to_string(), |a| {
                format!(
                    "{:.1e}",
                    ((a[0] * a[0] + a[1] * a[1] + a[2] * a[2]) / 3.0).sqrt()
                )
            })
        };
        let (g, a) = (&c.residual.gyro, &c.residual.accel);
        format!(
            "{head}; {clock}, {frame}; residual RMS flight / rest gyro {} / {} rad/s, accel {} / {} m/s²; {sigma}",
            rms(g.rms_flight),
            rms(g.rms_rest),
            rms(a.rms_flight),
            rms(a.rms_rest)
        )
    }
}
