//! The IMU samples not yet consumed by a window interval, after spike rejection.

use std::collections::VecDeque;

use nalgebra::Vector3;

use crate::imu::{ImuError, ImuNoise, ImuSample, Preintegration, at_range};

/// Samples after a sample that a spike test needs.
const LOOKAHEAD: usize = 2;

/// IMU samples in time order, cut into preintegrated intervals as frames arrive.
///
/// With a spike threshold each sample is judged once the two after it have arrived: it is
/// excluded when it is farther than the threshold from the per-axis median of the five samples
/// around it (the median ignores up to two outliers, and follows smooth motion).
#[derive(Clone, Debug, Default)]
pub(super) struct ImuBuffer {
    /// Accepted samples.
    samples: VecDeque<ImuSample>,
    /// The last raw samples: up to `LOOKAHEAD` judged ones (context) and the unjudged ones.
    raw: VecDeque<ImuSample>,
    /// Raw samples not yet judged (the newest ones of `raw`).
    unjudged: usize,
    /// `(gyroscope rad/s, accelerometer m/s²)` thresholds; `None`: no test, no latency.
    spike_threshold: Option<(f64, f64)>,
    /// Times of the samples excluded since the last [`ImuBuffer::take_excluded`].
    excluded: Vec<i64>,
    /// Longest time between consecutive accepted samples that an interval may span (ns).
    max_gap_ns: i64,
    /// `(gyroscope rad/s, accelerometer m/s²)` ranges: a sample at a range on any axis is
    /// saturated (clipped), and an interval over it distrusts that axis
    /// ([`Preintegration::clipping_at`]).
    range: Option<(f64, f64)>,
    /// Times of the accepted samples that are saturated, oldest first.
    saturated: VecDeque<i64>,
    /// Saturated samples since the last [`ImuBuffer::take_saturated`].
    saturated_new: usize,
}

impl ImuBuffer {
    /// An empty buffer that excludes spikes above `spike_threshold` (see the type doc) and
    /// cuts no interval across a gap between samples longer than `max_gap_s`.
    /// `range`: the sensor's measuring ranges, past which it clips (see the field doc).
    pub fn new(
        spike_threshold: Option<(f64, f64)>,
        max_gap_s: f64,
        range: Option<(f64, f64)>,
    ) -> Self {
        Self {
            spike_threshold,
            max_gap_ns: (max_gap_s * 1e9).round() as i64,
            range,
            ..Self::default()
        }
    }

    /// Accepts `s` into the samples intervals are cut from, noting whether it is saturated.
    fn accept(&mut self, s: ImuSample) {
        if let Some((gyro, accel)) = self.range {
            let at = |v: &Vector3<f64>, r: f64| v.iter().any(|x| at_range(*x, r));
            if at(&s.gyro, gyro) || at(&s.accel, accel) {
                self.saturated.push_back(s.t_ns);
                self.saturated_new += 1;
            }
        }
        self.samples.push_back(s);
    }

    /// The number of saturated samples since the last call.
    pub fn take_saturated(&mut self) -> usize {
        std::mem::take(&mut self.saturated_new)
    }

    /// Appends a sample; its time must follow the newest one's. With spike rejection the
    /// sample is accepted (or excluded) `LOOKAHEAD` samples later.
    pub fn push(&mut self, sample: ImuSample) -> Result<(), ImuError> {
        self.check_next(&sample)?;
        let Some((gyro_max, accel_max)) = self.spike_threshold else {
            self.accept(sample);
            return Ok(());
        };
        self.raw.push_back(sample);
        self.unjudged += 1;
        if self.unjudged > LOOKAHEAD {
            self.judge_oldest_unjudged(gyro_max, accel_max);
        }
        Ok(())
    }

    /// Judges the samples still waiting for their look-ahead (at the end of the data), on the
    /// neighbourhood there is.
    pub fn flush(&mut self) {
        if let Some((gyro_max, accel_max)) = self.spike_threshold {
            while self.unjudged > 0 {
                self.judge_oldest_unjudged(gyro_max, accel_max);
            }
        }
    }

    /// Accepts or excludes the oldest unjudged raw sample against the per-axis median of the
    /// (up to) five raw samples around it.
    fn judge_oldest_unjudged(&mut self, gyro_max: f64, accel_max: f64) {
        let j = self.raw.len() - self.unjudged;
        let lo = j.saturating_sub(2);
        let hi = (j + LOOKAHEAD).min(self.raw.len() - 1);
        let hood: Vec<&ImuSample> = self.raw.range(lo..=hi).collect();
        let s = self.raw[j];
        let far = |get: fn(&ImuSample) -> f64, max: f64| {
            let mut v: Vec<f64> = hood.iter().map(|x| get(x)).collect();
            v.sort_by(f64::total_cmp);
            (get(&s) - v[v.len() / 2]).abs() > max
        };
        let spike = far(|x| x.gyro.x, gyro_max)
            || far(|x| x.gyro.y, gyro_max)
            || far(|x| x.gyro.z, gyro_max)
            || far(|x| x.accel.x, accel_max)
            || far(|x| x.accel.y, accel_max)
            || far(|x| x.accel.z, accel_max);
        if spike {
            self.excluded.push(s.t_ns);
        } else {
            self.accept(s);
        }
        self.unjudged -= 1;
        while self.raw.len() > LOOKAHEAD + self.unjudged {
            self.raw.pop_front();
        }
    }

    /// Times of the samples excluded as spikes since the last call.
    pub fn take_excluded(&mut self) -> Vec<i64> {
        std::mem::take(&mut self.excluded)
    }

    /// Whether `sample` may follow the newest sample.
    pub fn check_next(&self, sample: &ImuSample) -> Result<(), ImuError> {
        match self.raw.back().or(self.samples.back()) {
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
    /// `t1` stays for the next interval's interpolation). `None` when the samples do not bracket
    /// both ends, when two consecutive samples over the interval are more than the buffer's
    /// maximum gap apart (an IMU dropout: nothing is invented across it). An interval over a
    /// saturated sample takes the clipped axes as bounds, not measurements
    /// ([`Preintegration::clipping_at`]).
    pub fn take_interval(
        &mut self,
        t0: i64,
        t1: i64,
        ba: Vector3<f64>,
        bg: Vector3<f64>,
        noise: ImuNoise,
    ) -> Option<Preintegration> {
        // Both ends are bracketed (checked below), so a sample before `t` exists unless one
        // falls on it.
        let at = |buf: &VecDeque<ImuSample>, t: i64| -> Option<ImuSample> {
            let i = buf.iter().position(|s| s.t_ns >= t)?;
            if buf[i].t_ns == t {
                return Some(buf[i]);
            }
            Some(ImuSample::interpolate(&buf[i - 1], &buf[i], t))
        };
        let bracket_start = self.samples.iter().rposition(|s| s.t_ns <= t0)?;
        let bracket_end = self.samples.iter().position(|s| s.t_ns >= t1)?;
        let gap = (bracket_start..bracket_end)
            .any(|i| self.samples[i + 1].t_ns - self.samples[i].t_ns > self.max_gap_ns);
        let (lo, hi) = (
            self.samples[bracket_start].t_ns,
            self.samples[bracket_end].t_ns,
        );
        let clipped = self.saturated.iter().any(|&t| t >= lo && t <= hi);
        if gap {
            self.drop_before(t1);
            return None;
        }
        let first = at(&self.samples, t0)?;
        let last = at(&self.samples, t1)?;
        let mut p = Preintegration::new(first, ba, bg, noise).ok()?;
        if clipped && let Some(range) = self.range {
            p = p.clipping_at(range);
        }
        for s in self.samples.iter().filter(|s| s.t_ns > t0 && s.t_ns < t1) {
            p.push(*s).ok()?;
        }
        p.push(last).ok()?;
        self.drop_before(t1);
        Some(p)
    }

    /// Drops the samples before `t_ns` except the last one at or before it.
    fn drop_before(&mut self, t_ns: i64) {
        while self.samples.len() >= 2 && self.samples[1].t_ns <= t_ns {
            self.samples.pop_front();
        }
        let oldest = self.samples.front().map_or(i64::MAX, |s| s.t_ns);
        while self.saturated.front().is_some_and(|&t| t < oldest) {
            self.saturated.pop_front();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// 200 Hz samples of a violent but smooth motion: yaw rate swinging ±2.5 rad/s at 1 Hz
    /// (15.7 rad/s² peak), specific force ±20 m/s² at 2 Hz (251 m/s³ peak jerk), plus EuRoC-like
    /// white noise (0.0024 rad/s, 0.028 m/s² per sample).
    fn motion(n: usize, rng: &mut ChaCha8Rng) -> Vec<ImuSample> {
        (0..n)
            .map(|k| {
                let t = k as f64 * 0.005;
                let w = 2.0 * std::f64::consts::PI;
                let noise = |rng: &mut ChaCha8Rng, s: f64| s * (rng.random::<f64>() - 0.5) * 3.46;
                ImuSample {
                    t_ns: (k as i64) * 5_000_000,
                    gyro: Vector3::new(
                        noise(rng, 0.0024),
                        0.3 * (w * 0.5 * t).sin() + noise(rng, 0.0024),
                        2.5 * (w * t).sin() + noise(rng, 0.0024),
                    ),
                    accel: Vector3::new(
                        20.0 * (w * 2.0 * t).sin() + noise(rng, 0.028),
                        noise(rng, 0.028),
                        9.81 + noise(rng, 0.028),
                    ),
                }
            })
            .collect()
    }

    fn run(samples: &[ImuSample]) -> (Vec<i64>, usize) {
        let mut buf = ImuBuffer::new(Some((1.0, 10.0)), 0.05, None);
        let mut excluded = Vec::new();
        for s in samples {
            buf.push(*s).unwrap();
            excluded.extend(buf.take_excluded());
        }
        buf.flush();
        excluded.extend(buf.take_excluded());
        (excluded, buf.samples.len())
    }

    /// No false alarm on violent smooth motion; every sample comes out, in order.
    #[test]
    fn smooth_motion_is_never_excluded() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let samples = motion(4000, &mut rng);
        let (excluded, kept) = run(&samples);
        assert!(excluded.is_empty(), "excluded {excluded:?}");
        assert_eq!(kept, samples.len());
    }

    /// Spikes of the fault (1 % of samples, ±3 rad/s on one gyroscope axis and
    /// ±30 m/s² on one accelerometer axis) are all excluded and nothing else is; so are
    /// gyroscope-only spikes of 1.5 rad/s.
    #[test]
    fn spikes_are_excluded_exactly() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut samples = motion(12_000, &mut rng);
        let mut truth = Vec::new();
        for (k, s) in samples.iter_mut().enumerate() {
            if rng.random::<f64>() < 0.01 {
                let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
                let (g, a) = (rng.random_range(0..3), rng.random_range(0..3));
                if k % 2 == 0 {
                    s.gyro[g] += sign * 3.0;
                    s.accel[a] += sign * 30.0;
                } else {
                    s.gyro[g] += sign * 1.5;
                }
                truth.push(s.t_ns);
            }
        }
        assert!(truth.len() > 90, "{} spikes", truth.len());
        let (excluded, kept) = run(&samples);
        assert_eq!(excluded, truth);
        assert_eq!(kept + truth.len(), samples.len());
    }

    /// Without a threshold every sample is accepted at once (no latency).
    #[test]
    fn no_threshold_no_latency() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut buf = ImuBuffer::new(None, 0.05, None);
        for s in motion(5, &mut rng) {
            buf.push(s).unwrap();
            assert_eq!(buf.newest_t_ns(), Some(s.t_ns));
        }
    }

    /// An interval across a dropout longer than the maximum gap is refused (nothing is
    /// interpolated over it), intervals on either side of it are cut normally, and the one
    /// across the gap leaves no stale samples behind.
    #[test]
    fn no_interval_across_a_dropout() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let noise = ImuNoise {
            gyroscope_noise_density: 1.7e-4,
            accelerometer_noise_density: 2e-3,
            gyroscope_random_walk: 1.9e-5,
            accelerometer_random_walk: 3e-3,
        };
        let ms = 1_000_000;
        let mut buf = ImuBuffer::new(None, 0.05, None);
        // 200 Hz samples over [0, 1] s and [1.5, 2] s: a 0.5 s dropout.
        for s in motion(401, &mut rng)
            .into_iter()
            .filter(|s| s.t_ns <= 1000 * ms || s.t_ns >= 1500 * ms)
        {
            buf.push(s).unwrap();
        }
        let z = Vector3::zeros();
        let before = buf.take_interval(900 * ms, 950 * ms, z, z, noise).unwrap();
        assert_eq!(before.start_ns(), 900 * ms);
        assert!((before.dt() - 0.05).abs() < 1e-12);
        assert!(
            buf.take_interval(950 * ms, 1200 * ms, z, z, noise)
                .is_none()
        );
        assert!(
            buf.take_interval(1200 * ms, 1510 * ms, z, z, noise)
                .is_none()
        );
        let after = buf
            .take_interval(1510 * ms, 1560 * ms, z, z, noise)
            .unwrap();
        assert_eq!(after.start_ns(), 1510 * ms);
        assert_eq!(buf.oldest_t_ns(), Some(1560 * ms));
        // A gap of two missing samples (15 ms) is no dropout.
        let mut buf = ImuBuffer::new(None, 0.05, None);
        for s in motion(40, &mut rng)
            .into_iter()
            .filter(|s| s.t_ns != 50 * ms && s.t_ns != 55 * ms)
        {
            buf.push(s).unwrap();
        }
        assert!(buf.take_interval(40 * ms, 90 * ms, z, z, noise).is_some());
    }
}
