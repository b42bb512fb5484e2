//! `rig.imu.recorded`: a recorded IMU log replayed under the simulated cameras.
//!
//! The log (EuRoC ASL `imu0/data.csv`) shares the clock of the replayed recording
//! (`trajectory.replay`), and is put on the run's clock by the same shift as the ground truth:
//! the recording's first kept sample is `t = 0`. Read with the dataset reader and checked at
//! the door: at least one row, stamps increasing, finite values (the reader's checks, each
//! naming the file and line), the rate `rig.imu.rate_hz` states, and the run's whole span
//! covered (the error names the part missing). A static start or stops change the motion's
//! timing, so the log's samples would no longer belong to it: they are refused with the key.
//! The ground-truth biases are the recording's when the replayed file is an EuRoC ASL ground
//! truth with bias columns, else zero.

use std::path::PathBuf;
use std::sync::Arc;

use estimator::geometry::Pose;
use estimator::imu::ImuSample;
use nalgebra::Vector3;
use sim::imu_source::RecordedImu;
use sim::motion::recording::{RecordingReport, TimeUnit};
use sim::motion::{Reference, Replay};

use super::{Scenario, SpecError};
use crate::dataset::{GroundTruthState, parse_groundtruth_csv, parse_imu_csv};

/// Largest relative difference between the log's median rate and `rig.imu.rate_hz`.
const RATE_TOLERANCE: f64 = 0.01;
/// An ASL ground-truth row within this of the replay's start (ns) is its exact stamp.
const START_MATCH_NS: i64 = 1_000;

/// A recorded IMU log, loaded and checked, with what its checks in the report need.
#[derive(Clone, Debug)]
pub struct RecordedImuLog {
    /// The file as the scenario names it.
    pub file: String,
    /// Recording clock − run clock (ns): the replay's first kept sample's stamp.
    pub shift_ns: i64,
    /// The log on the run's clock, with the biases of its samples.
    pub log: Arc<RecordedImu>,
    /// The replayed ground-truth file, as the scenario names it.
    pub groundtruth_file: String,
    /// The recording's ground truth on the run's clock (zero velocity and biases when the file
    /// has none).
    pub groundtruth: Vec<GroundTruthState>,
    /// Whether the biases come from the recording's ground truth (else zero).
    pub biases_from_groundtruth: bool,
}

impl Scenario {
    /// A replay's recorded IMU log (`rig.imu.recorded`), read and checked; `None` without one.
    pub(super) fn load_recorded_imu(&self) -> Result<Option<RecordedImuLog>, SpecError> {
        let key = "rig.imu.recorded";
        let Some(file) = &self.spec.rig.imu.recorded else {
            return Ok(None);
        };
        let Some(recording) = self.recording.as_ref() else {
            return Err(self.error(
                key,
                "a recorded IMU log needs a replayed trajectory (`trajectory.replay`) on its clock",
            ));
        };
        self.check_recorded_imu_keys()?;
        let (replay, report) = (&recording.0, &recording.1);
        // The log was flown along the file's true motion: a blended step would make the
        // simulated cameras disagree with it by up to half the step, and the run would score
        // that disagreement.
        if let Some(step) = report.steps.first() {
            return Err(self.error(
                "trajectory.replay",
                format!(
                    "line {}: a step of {:.4} m / {:.2}° cannot be blended under a recorded IMU log, which flew the file's true motion: cut the recording at that line, or simulate the IMU (remove `rig.imu.recorded`)",
                    step.line, step.position_m, step.angle_deg
                ),
            ));
        }
        let label = self.data_path(file);
        let text = self.data_file(key, file)?;
        let samples = parse_imu_csv(&text, &label).map_err(|e| self.error(key, e.to_string()))?;
        if samples.is_empty() {
            return Err(self.error(key, format!("{}: no IMU samples", label.display())));
        }
        let asl = self.asl_groundtruth(report)?;
        let shift_ns = start_ns(replay, asl.as_deref());
        let biases_from_groundtruth = asl.is_some();
        let groundtruth: Vec<GroundTruthState> = match asl {
            Some(rows) => rows
                .into_iter()
                .map(|r| GroundTruthState {
                    t_ns: r.t_ns - shift_ns,
                    ..r
                })
                .collect(),
            None => replay
                .samples
                .iter()
                .map(|s| GroundTruthState {
                    t_ns: (s.t * 1e9).round() as i64 - shift_ns,
                    pose: Pose::new(s.q, s.p),
                    velocity: Vector3::zeros(),
                    gyro_bias: Vector3::zeros(),
                    accel_bias: Vector3::zeros(),
                })
                .collect(),
        };
        let samples: Vec<ImuSample> = samples
            .into_iter()
            .map(|s| ImuSample {
                t_ns: s.t_ns - shift_ns,
                ..s
            })
            .collect();
        let biases = if biases_from_groundtruth {
            samples
                .iter()
                .map(|s| bias_at(&groundtruth, s.t_ns))
                .collect()
        } else {
            Vec::new()
        };
        let log = RecordedImu::new(samples, biases)
            .map_err(|e| self.error(key, format!("{}: {e}", label.display())))?;
        let rate = self.spec.rig.imu.rate_hz;
        let log_rate = 1e9 / log.period_ns().max(1) as f64;
        if ((log_rate - rate) / rate).abs() > RATE_TOLERANCE {
            return Err(self.error(
                "rig.imu.rate_hz",
                format!(
                    "{rate} Hz, but the recorded log {} runs at {log_rate:.3} Hz (median spacing {} ns)",
                    label.display(),
                    log.period_ns()
                ),
            ));
        }
        let duration = replay
            .duration()
            .map_or(self.spec.trajectory.duration_s, |d| {
                d.min(self.spec.trajectory.duration_s)
            });
        log.covers((duration * 1e9).round() as i64)
            .map_err(|e| self.error(key, format!("{}: {e}", label.display())))?;
        Ok(Some(RecordedImuLog {
            file: file.clone(),
            shift_ns,
            log: Arc::new(log),
            groundtruth_file: self
                .spec
                .trajectory
                .replay
                .as_ref()
                .map_or(String::new(), |r| r.file.clone()),
            groundtruth,
            biases_from_groundtruth,
        }))
    }

    /// The keys that cannot go with a recorded log.
    fn check_recorded_imu_keys(&self) -> Result<(), SpecError> {
        let (t, imu) = (&self.spec.trajectory, &self.spec.rig.imu);
        let timing = "changes the motion's timing, so the recorded IMU log would no longer match the motion it replays: remove it or `rig.imu.recorded`";
        if t.static_start.is_some() {
            return Err(self.error(
                "trajectory.static_start",
                format!("a static start {timing}"),
            ));
        }
        if !t.stops.is_empty() {
            return Err(self.error("trajectory.stops", format!("a stop {timing}")));
        }
        if imu.noise_free {
            return Err(self.error(
                "rig.imu.noise_free",
                "a recorded IMU log is what it is: remove `noise_free` or `recorded`",
            ));
        }
        for (k, v) in [
            ("initial_gyro_bias_rad_s", imu.initial_gyro_bias_rad_s),
            ("initial_accel_bias_m_s2", imu.initial_accel_bias_m_s2),
        ] {
            if v != [0.0; 3] {
                return Err(self.error(
                    &format!("rig.imu.{k}"),
                    "a recorded IMU log carries its own biases: remove it or `recorded`",
                ));
            }
        }
        Ok(())
    }

    /// The replayed file's rows as an EuRoC ASL ground truth with biases (stamps in ns), or
    /// `None` when it is not one (a TUM file, other columns, another time unit).
    fn asl_groundtruth(
        &self,
        report: &RecordingReport,
    ) -> Result<Option<Vec<GroundTruthState>>, SpecError> {
        let Some(r) = &self.spec.trajectory.replay else {
            return Ok(None);
        };
        if report.time_unit != TimeUnit::Nanoseconds {
            return Ok(None);
        }
        let text = self.data_file("trajectory.replay.file", &r.file)?;
        Ok(parse_groundtruth_csv(&text, &self.data_path(&r.file)).ok())
    }

    /// A data file's path as errors name it: relative to the scenario file, or as written for
    /// catalog scenarios.
    pub(super) fn data_path(&self, rel: &str) -> PathBuf {
        self.origin.path_of(rel)
    }

    /// The recorded IMU log (`rig.imu.recorded`), when the scenario has one.
    pub fn recorded_imu(&self) -> Option<&RecordedImuLog> {
        self.recorded_imu.as_deref()
    }
}

/// The replay's start on the recording's clock (ns): the ASL row at its first kept sample
/// when there is one (exact), else its stamp rounded to the ns.
fn start_ns(replay: &Replay, asl: Option<&[GroundTruthState]>) -> i64 {
    let rounded = (replay.t_file0 * 1e9).round() as i64;
    asl.and_then(|rows| {
        let i = rows.partition_point(|r| r.t_ns < rounded);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|j| rows.get(j))
            .map(|r| r.t_ns)
            .min_by_key(|t| (t - rounded).abs())
            .filter(|t| (t - rounded).abs() <= START_MATCH_NS)
    })
    .unwrap_or(rounded)
}

/// The ground truth's `(gyro, accel)` bias at `t_ns`: linear between rows, the end rows'
/// outside.
fn bias_at(gt: &[GroundTruthState], t_ns: i64) -> (Vector3<f64>, Vector3<f64>) {
    let j = gt.partition_point(|r| r.t_ns <= t_ns);
    if j == 0 {
        return (gt[0].gyro_bias, gt[0].accel_bias);
    }
    if j == gt.len() {
        let last = &gt[gt.len() - 1];
        return (last.gyro_bias, last.accel_bias);
    }
    let (a, b) = (&gt[j - 1], &gt[j]);
    let u = (t_ns - a.t_ns) as f64 / (b.t_ns - a.t_ns) as f64;
    (
        a.gyro_bias.lerp(&b.gyro_bias, u),
        a.accel_bias.lerp(&b.accel_bias, u),
    )
}
