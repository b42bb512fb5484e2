//! The IMU samples not yet consumed by a window interval.

use std::collections::VecDeque;

use nalgebra::Vector3;

use crate::imu::{ImuError, ImuNoise, ImuSample, Preintegration};

/// IMU samples in time order, cut into preintegrated intervals as frames arrive.
#[derive(Clone, Debug, Default)]
pub(super) struct ImuBuffer {
    samples: VecDeque<ImuSample>,
}

impl ImuBuffer {
    /// Appends a sample; its time must follow the newest one's.
    pub fn push(&mut self, sample: ImuSample) -> Result<(), ImuError> {
        self.check_next(&sample)?;
        self.samples.push_back(sample);
        Ok(())
    }

    /// Whether `sample` may follow the newest sample.
    pub fn check_next(&self, sample: &ImuSample) -> Result<(), ImuError> {
        match self.samples.back() {
            Some(last) if sample.t_ns <= last.t_ns => Err(ImuError::NonIncreasingTime {
                t_ns: sample.t_ns,
                prev_t_ns: last.t_ns,
            }),
            _ => Ok(()),
        }
    }

    /// Time of the newest sample.
    pub fn newest_t_ns(&self) -> Option<i64> {
        self.samples.back().map(|s| s.t_ns)
    }

    /// Time of the oldest sample.
    pub fn oldest_t_ns(&self) -> Option<i64> {
        self.samples.front().map(|s| s.t_ns)
    }

    /// Up to `n` samples at or before `t_ns`, newest first.
    pub fn recent(&self, t_ns: i64, n: usize) -> Vec<ImuSample> {
        self.samples
            .iter()
            .filter(|s| s.t_ns <= t_ns)
            .rev()
            .take(n)
            .copied()
            .collect()
    }

    /// Cuts a preintegration over `[t0, t1]` linearized at the biases (end samples
    /// interpolated), then drops the samples no later interval needs (the last one at or before
    /// `t1` stays for the next interval's interpolation).
    pub fn take_interval(
        &mut self,
        t0: i64,
        t1: i64,
        ba: Vector3<f64>,
        bg: Vector3<f64>,
        noise: ImuNoise,
    ) -> Option<Preintegration> {
        let at = |buf: &VecDeque<ImuSample>, t: i64| -> Option<ImuSample> {
            let i = buf.iter().position(|s| s.t_ns >= t)?;
            if buf[i].t_ns == t || i == 0 {
                return Some(ImuSample { t_ns: t, ..buf[i] });
            }
            Some(ImuSample::interpolate(&buf[i - 1], &buf[i], t))
        };
        let first = at(&self.samples, t0)?;
        let last = at(&self.samples, t1)?;
        let mut p = Preintegration::new(first, ba, bg, noise).ok()?;
        for s in self.samples.iter().filter(|s| s.t_ns > t0 && s.t_ns < t1) {
            p.push(*s).ok()?;
        }
        p.push(last).ok()?;
        while self.samples.len() >= 2 && self.samples[1].t_ns <= t1 {
            self.samples.pop_front();
        }
        Some(p)
    }
}
