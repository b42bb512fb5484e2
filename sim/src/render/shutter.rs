//! When each camera's rows are exposed, as the times of the scene renders and each row's
//! weights over them.
//!
//! Global shutters only: the renders are the motion-blur samples (or one at the capture time)
//! and every pixel averages them — the renderer's original path, unchanged.
//!
//! With a rolling-shutter camera in the rig, `readout_samples` renders are spread evenly from
//! half an exposure before the capture time to half an exposure after the longest readout. The
//! rendered images are read as a sequence linear in time between the renders: row `r`, exposed
//! over `[t_r − e/2, t_r + e/2]` (`t_r` its row time, `e` the motion-blur exposure, 0 without
//! blur), takes each render `k` with the weight of the hat function of `k` on that interval —
//! at `e = 0` the linear interpolation between the two renders that bracket `t_r`. Between
//! renders `Δ` apart, an image moving `v` px/s is placed to first order exactly (the blend of
//! two images `vΔ` apart is centred where the weights put it) and blurred by at most `vΔ`:
//! about 0.4 px at 9 renders over a 20 ms readout and 200 px/s.

use estimator::camera::RollingShutter;

use super::MotionBlur;

/// A row's weights sum to this.
pub(super) const WEIGHT_ONE: u32 = 1 << 16;

/// Midpoints an exposure interval's hat integrals are taken at.
const EXPOSURE_STEPS: usize = 64;

/// The renders of a frame and how each camera combines them.
pub(super) struct ShutterPlan {
    /// Render times relative to the capture time (ns).
    pub offsets_ns: Vec<i64>,
    /// Per camera, per row, per render: weights summing to [`WEIGHT_ONE`] (row-major,
    /// `rows × renders`); `None` for every camera when no camera rolls (plain average).
    pub row_weights: Vec<Option<Vec<u32>>>,
}

/// The plan for cameras with `shutters` (and their heights), the motion blur and the number of
/// renders spanning a readout.
pub(super) fn plan(
    shutters: &[(RollingShutter, u32)],
    blur: Option<MotionBlur>,
    readout_samples: u32,
) -> ShutterPlan {
    let longest = shutters
        .iter()
        .map(|(s, _)| s.readout_s)
        .fold(0.0f64, f64::max);
    if longest <= 0.0 {
        return ShutterPlan {
            offsets_ns: box_offsets_ns(blur),
            row_weights: vec![None; shutters.len()],
        };
    }
    let exposure = blur.map_or(0.0, |b| b.exposure_s);
    let (lo, hi) = (-0.5 * exposure, longest + 0.5 * exposure);
    let n = readout_samples.max(2) as usize;
    let offsets_ns: Vec<i64> = (0..n)
        .map(|k| ((lo + (hi - lo) * k as f64 / (n - 1) as f64) * 1e9).round() as i64)
        .collect();
    let times: Vec<f64> = offsets_ns.iter().map(|&o| o as f64 * 1e-9).collect();
    let row_weights = shutters
        .iter()
        .map(|(shutter, height)| {
            let mut w = Vec::with_capacity(*height as usize * n);
            for r in 0..*height {
                let t_r = shutter.row_time_s(&nalgebra::Vector2::new(0.0, f64::from(r)), *height);
                w.extend(quantized(&row_weights(&times, t_r, exposure)));
            }
            Some(w)
        })
        .collect();
    ShutterPlan {
        offsets_ns,
        row_weights,
    }
}

/// The motion-blur samples (centres of equal sub-intervals of the exposure), or the capture
/// time alone.
fn box_offsets_ns(blur: Option<MotionBlur>) -> Vec<i64> {
    match blur {
        None => vec![0],
        Some(b) => (0..b.samples)
            .map(|k| {
                let f = (f64::from(k) + 0.5) / f64::from(b.samples) - 0.5;
                (f * b.exposure_s * 1e9).round() as i64
            })
            .collect(),
    }
}

/// The hat function of render `k` on the grid `times` at `t` (clamped to the grid's span).
fn hat(times: &[f64], k: usize, t: f64) -> f64 {
    let t = t.clamp(times[0], times[times.len() - 1]);
    let left = k.checked_sub(1).map(|j| times[j]);
    let right = times.get(k + 1).copied();
    let tk = times[k];
    if t <= tk {
        left.map_or((t == tk) as u8 as f64, |l| ((t - l) / (tk - l)).max(0.0))
    } else {
        right.map_or(0.0, |r| ((r - t) / (r - tk)).max(0.0))
    }
}

/// The weights of the renders at `times` for a row exposed over `[t − e/2, t + e/2]`.
fn row_weights(times: &[f64], t: f64, exposure: f64) -> Vec<f64> {
    (0..times.len())
        .map(|k| {
            if exposure <= 0.0 {
                return hat(times, k, t);
            }
            (0..EXPOSURE_STEPS)
                .map(|i| {
                    let s = t + exposure * ((i as f64 + 0.5) / EXPOSURE_STEPS as f64 - 0.5);
                    hat(times, k, s)
                })
                .sum::<f64>()
                / EXPOSURE_STEPS as f64
        })
        .collect()
}

/// Weights in integers summing exactly to [`WEIGHT_ONE`] (the rounding remainder goes to the
/// largest weight).
fn quantized(w: &[f64]) -> Vec<u32> {
    let total: f64 = w.iter().sum();
    let mut q: Vec<u32> = w
        .iter()
        .map(|v| (v / total * f64::from(WEIGHT_ONE)).round() as u32)
        .collect();
    let sum: i64 = q.iter().map(|&v| i64::from(v)).sum();
    let largest = (0..q.len())
        .max_by_key(|&k| q[k])
        .expect("at least two renders");
    q[largest] = (i64::from(q[largest]) + i64::from(WEIGHT_ONE) - sum) as u32;
    q
}

#[cfg(test)]
mod tests {
    use super::*;
    use estimator::camera::ReadoutDirection;

    fn shutter(readout_s: f64) -> RollingShutter {
        RollingShutter {
            readout_s,
            direction: ReadoutDirection::TopToBottom,
        }
    }

    #[test]
    fn global_shutters_keep_the_plain_average() {
        let p = plan(&[(shutter(0.0), 480)], None, 9);
        assert_eq!(p.offsets_ns, vec![0]);
        assert!(p.row_weights[0].is_none());
    }

    #[test]
    fn rows_interpolate_the_renders_that_bracket_their_time() {
        // 5 renders over 20 ms, 8 rows: row r at 2.5 ms · r.
        let p = plan(&[(shutter(0.02), 8), (shutter(0.0), 8)], None, 5);
        assert_eq!(
            p.offsets_ns,
            vec![0, 5_000_000, 10_000_000, 15_000_000, 20_000_000]
        );
        let w = p.row_weights[0].as_ref().unwrap();
        for r in 0..8 {
            let row = &w[r * 5..r * 5 + 5];
            assert_eq!(row.iter().sum::<u32>(), WEIGHT_ONE);
            // The weights' mean time is the row's time.
            let mean: f64 = row
                .iter()
                .enumerate()
                .map(|(k, &v)| f64::from(v) / f64::from(WEIGHT_ONE) * 5.0 * k as f64)
                .sum();
            assert!((mean - 2.5 * r as f64).abs() < 1e-3, "row {r}: {mean}");
        }
        // A global shutter in the same rig takes the render at its capture time.
        let g = p.row_weights[1].as_ref().unwrap();
        assert!(g.chunks(5).all(|row| row == [WEIGHT_ONE, 0, 0, 0, 0]));
    }

    #[test]
    fn an_exposure_spreads_each_row_over_its_interval() {
        let blur = MotionBlur {
            exposure_s: 0.004,
            samples: 4,
        };
        let p = plan(&[(shutter(0.02), 4)], Some(blur), 12);
        assert_eq!(p.offsets_ns[0], -2_000_000);
        assert_eq!(*p.offsets_ns.last().unwrap(), 22_000_000);
        let w = p.row_weights[0].as_ref().unwrap();
        for r in 0..4 {
            let row = &w[r * 12..r * 12 + 12];
            assert_eq!(row.iter().sum::<u32>(), WEIGHT_ONE);
            let times: Vec<f64> = p.offsets_ns.iter().map(|&o| o as f64 * 1e-6).collect();
            let mean: f64 = row
                .iter()
                .zip(&times)
                .map(|(&v, t)| f64::from(v) / f64::from(WEIGHT_ONE) * t)
                .sum();
            assert!((mean - 5.0 * r as f64).abs() < 1e-2, "row {r}: {mean} ms");
            // More than two renders share a row: the exposure blurs it.
            assert!(row.iter().filter(|&&v| v > 0).count() >= 3);
        }
    }
}
