//! Where a stream's IMU samples come from: the simulated IMU ([`ImuSim`]) measuring the
//! physics, or a recorded log ([`RecordedImu`]) replayed on the run's clock while the physics
//! still moves the cameras and gives the ground truth.
//!
//! A recorded log is checked when it is made (at least one sample, stamps strictly increasing,
//! every value finite) and against the run when a world is built ([`RecordedImu::covers`]).

use std::sync::Arc;

use estimator::imu::ImuSample;
use nalgebra::Vector3;

use crate::imu::{ImuBias, ImuSim};
use crate::motion::TruthBuffer;

/// A recorded IMU log on the run's clock (the recording's first ground-truth stamp at 0), with
/// the true biases of each sample when the recording has them.
#[derive(Clone, PartialEq)]
pub struct RecordedImu {
    samples: Vec<ImuSample>,
    /// `(gyro, accel)` bias of each sample; empty: zero.
    biases: Vec<(Vector3<f64>, Vector3<f64>)>,
    period_ns: i64,
}

impl std::fmt::Debug for RecordedImu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordedImu")
            .field("samples", &self.samples.len())
            .field("first_ns", &self.samples.first().map(|s| s.t_ns))
            .field("last_ns", &self.samples.last().map(|s| s.t_ns))
            .field("period_ns", &self.period_ns)
            .field("biases", &!self.biases.is_empty())
            .finish()
    }
}

impl RecordedImu {
    /// A log of `samples` (run clock) with one `(gyro, accel)` bias per sample, or none (`biases`
    /// empty: the biases are taken as zero). `Err` says what is wrong: no samples, stamps not
    /// strictly increasing, a value not finite, or a bias count that does not match.
    pub fn new(
        samples: Vec<ImuSample>,
        biases: Vec<(Vector3<f64>, Vector3<f64>)>,
    ) -> Result<Self, String> {
        if samples.is_empty() {
            return Err("the recorded IMU log has no samples".into());
        }
        if let Some(i) = samples.windows(2).position(|w| w[1].t_ns <= w[0].t_ns) {
            return Err(format!(
                "recorded IMU sample {} at {} ns does not follow the previous one at {} ns",
                i + 1,
                samples[i + 1].t_ns,
                samples[i].t_ns
            ));
        }
        let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
        if let Some(i) = samples
            .iter()
            .position(|s| !finite(&s.gyro) || !finite(&s.accel))
        {
            return Err(format!(
                "recorded IMU sample {i} at {} ns holds a value that is not finite",
                samples[i].t_ns
            ));
        }
        if !biases.is_empty() && biases.len() != samples.len() {
            return Err(format!(
                "{} biases for {} recorded IMU samples",
                biases.len(),
                samples.len()
            ));
        }
        if let Some(i) = biases.iter().position(|(g, a)| !finite(g) || !finite(a)) {
            return Err(format!("the bias of recorded IMU sample {i} is not finite"));
        }
        let mut d: Vec<i64> = samples.windows(2).map(|w| w[1].t_ns - w[0].t_ns).collect();
        d.sort_unstable();
        let period_ns = d.get(d.len() / 2).copied().unwrap_or(0);
        Ok(Self {
            samples,
            biases,
            period_ns,
        })
    }

    /// The samples (run clock).
    pub fn samples(&self) -> &[ImuSample] {
        &self.samples
    }

    /// Median sample spacing (ns; 0 for a single sample).
    pub fn period_ns(&self) -> i64 {
        self.period_ns
    }

    /// Whether the recording gave the samples' biases (else they are zero).
    pub fn has_biases(&self) -> bool {
        !self.biases.is_empty()
    }

    /// `Ok` when the log has a sample within one period of the run's start (0) and of its end
    /// (`end_ns`); `Err` says which part of the run it misses.
    pub fn covers(&self, end_ns: i64) -> Result<(), String> {
        let (first, last) = (
            self.samples[0].t_ns,
            self.samples[self.samples.len() - 1].t_ns,
        );
        let s = |t: i64| t as f64 * 1e-9;
        let span = format!(
            "the recorded IMU log spans {:.6} s to {:.6} s of the run's clock (the recording's first ground-truth stamp is 0)",
            s(first),
            s(last)
        );
        let after_start = self.samples.iter().find(|x| x.t_ns >= 0).map(|x| x.t_ns);
        match after_start {
            None => Err(format!(
                "{span}: it ends before the run starts; the run's 0 s to {:.6} s are missing",
                s(end_ns)
            )),
            Some(t) if t > self.period_ns => Err(format!(
                "{span}: the run's 0 s to {:.6} s are missing",
                s(t)
            )),
            _ if last < end_ns - self.period_ns => Err(format!(
                "{span}: the run's {:.6} s to {:.6} s are missing",
                s(last),
                s(end_ns)
            )),
            _ => Ok(()),
        }
    }
}

/// The IMU of a stream.
#[derive(Debug)]
pub(crate) enum ImuSource {
    /// Measures the physics.
    Simulated(Box<ImuSim>),
    /// Replays a log: the samples from `t = 0` on, `next` the index of the next one.
    Recorded {
        /// The log.
        log: Arc<RecordedImu>,
        /// Index of the next sample.
        next: usize,
        /// Nominal period (ns) handed to the faults.
        period_ns: i64,
    },
}

impl ImuSource {
    /// A recorded log's source, starting at its first sample at or after `t = 0`; `period_ns`
    /// is the nominal period the faults are told.
    pub(crate) fn recorded(log: Arc<RecordedImu>, period_ns: i64) -> Self {
        let next = log.samples.partition_point(|s| s.t_ns < 0);
        Self::Recorded {
            log,
            next,
            period_ns,
        }
    }

    /// Sample period (ns) as the faults see it.
    pub(crate) fn period_ns(&self) -> i64 {
        match self {
            Self::Simulated(imu) => imu.period_ns(),
            Self::Recorded { period_ns, .. } => *period_ns,
        }
    }

    /// Timestamp of the next sample (`i64::MAX` once a log is exhausted).
    pub(crate) fn next_time_ns(&self) -> i64 {
        match self {
            Self::Simulated(imu) => imu.next_time_ns(),
            Self::Recorded { log, next, .. } => log.samples.get(*next).map_or(i64::MAX, |s| s.t_ns),
        }
    }

    /// Earliest physics time the next sample needs (a log needs none).
    pub(crate) fn needs_from_ns(&self) -> i64 {
        match self {
            Self::Simulated(imu) => imu.needs_from_ns(),
            Self::Recorded { .. } => i64::MAX,
        }
    }

    /// The next sample and the true bias it carries.
    pub(crate) fn next_sample(&mut self, truth: &mut TruthBuffer) -> (ImuSample, ImuBias) {
        match self {
            Self::Simulated(imu) => imu.next_sample(truth),
            Self::Recorded { log, next, .. } => {
                let s = log.samples[*next];
                let (gyro, accel) = log
                    .biases
                    .get(*next)
                    .copied()
                    .unwrap_or_else(|| (Vector3::zeros(), Vector3::zeros()));
                *next += 1;
                (
                    s,
                    ImuBias {
                        t_ns: s.t_ns,
                        gyro,
                        accel,
                    },
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(t_ns: i64) -> ImuSample {
        ImuSample {
            t_ns,
            gyro: Vector3::new(0.0, 0.0, 0.1),
            accel: Vector3::new(0.0, 0.0, 9.81),
        }
    }

    #[test]
    fn bad_logs_are_refused_with_the_reason() {
        assert!(RecordedImu::new(Vec::new(), Vec::new()).is_err());
        let e = RecordedImu::new(vec![sample(0), sample(0)], Vec::new()).unwrap_err();
        assert!(e.contains("does not follow"), "{e}");
        let mut nan = sample(5);
        nan.accel.y = f64::NAN;
        let e = RecordedImu::new(vec![sample(0), nan], Vec::new()).unwrap_err();
        assert!(e.contains("not finite"), "{e}");
        let e = RecordedImu::new(
            vec![sample(0)],
            vec![(Vector3::zeros(), Vector3::zeros()); 2],
        )
        .unwrap_err();
        assert!(e.contains("2 biases"), "{e}");
    }

    #[test]
    fn coverage_names_the_missing_part() {
        let log =
            RecordedImu::new((0..=100).map(|k| sample(k * 5_000_000)).collect(), vec![]).unwrap();
        assert!(log.covers(500_000_000).is_ok());
        let e = log.covers(600_000_000).unwrap_err();
        assert!(e.contains("0.500000 s to 0.600000 s are missing"), "{e}");
        let late = RecordedImu::new(
            (0..=100)
                .map(|k| sample(100_000_000 + k * 5_000_000))
                .collect(),
            vec![],
        )
        .unwrap();
        let e = late.covers(500_000_000).unwrap_err();
        assert!(e.contains("0 s to 0.100000 s are missing"), "{e}");
    }
}
