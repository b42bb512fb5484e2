//! The biases' constant mean `c = [c_a, c_g]` of the Gauss–Markov bias model
//! ([`crate::bias_process`]) as a state of the window: one block shared by every IMU factor,
//! carried through marginalization like the extrinsics, and tied to the flight's first state
//! by the process's stationary law `b₀ − c ~ N(0, σ_b²)` — a factor on that frame, which goes
//! into the prior with it. It starts at that frame's biases (the initializer's), is dropped
//! with the window on a reset, and exists only when the estimator's model has a bias process.

use std::collections::VecDeque;
use std::sync::Arc;

use super::frame::{BlockRef, Prior, WindowFrame};
use super::window_problem::WindowProblem;
use crate::bias_process::BiasProcess;
use crate::imu::ImuNoise;
use crate::problem::{BlockId, BlockKind, Euclidean, LinearFactor};

/// The mean's value and the frame its stationarity factor is on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct BiasMean {
    /// `[c_a (m/s²), c_g (rad/s)]`.
    pub value: [f64; 6],
    /// The frame (seq) tied to the mean by the stationary law.
    pub anchor: u64,
}

/// Adds the mean's block to `built` when the model has a bias `process` and the IMU is active
/// (its factors use it) or the `prior` holds it; with its stationarity factor while the anchor
/// frame is in the window. A window with none yet starts one at its oldest frame. Returns the
/// block; `built.bias_mean_anchor` records the anchor for [`read_back`].
pub(super) fn add_block(
    current: Option<&BiasMean>,
    frames: &VecDeque<WindowFrame>,
    prior: Option<&Prior>,
    process: Option<&BiasProcess>,
    imu_active: bool,
    built: &mut WindowProblem,
) -> Option<BlockId> {
    let process = process?;
    let in_prior = prior.is_some_and(|(_, refs)| refs.contains(&BlockRef::BiasMean));
    if !(imu_active || in_prior) {
        return None;
    }
    let mean = match current {
        Some(m) => *m,
        None => {
            let first = frames.front()?;
            let (a, g) = (first.ba, first.bg);
            BiasMean {
                value: [a.x, a.y, a.z, g.x, g.y, g.z],
                anchor: first.seq,
            }
        }
    };
    let block = built
        .problem
        .add_block(&mean.value, Arc::new(Euclidean::new(6)), BlockKind::State)
        .expect("a finite bias mean");
    built.refs.push((BlockRef::BiasMean, block));
    built.bias_mean_anchor = Some(mean.anchor);
    if let Some(sb) = built.block(BlockRef::SpeedBias(mean.anchor)) {
        let r = built
            .problem
            .add_factor(Arc::new(stationary_law(process)), None, &[sb, block])
            .expect("sizes match");
        built.frame_factors.push((r, mean.anchor));
    }
    Some(block)
}

/// The solved mean, when `built` holds one.
pub(super) fn read_back(built: &WindowProblem) -> Option<BiasMean> {
    let block = built.block(BlockRef::BiasMean)?;
    let v = built.problem.values(block);
    Some(BiasMean {
        value: [v[0], v[1], v[2], v[3], v[4], v[5]],
        anchor: built.bias_mean_anchor?,
    })
}

/// `(b − c)/σ_b` over `[speed-bias (9), mean (6)]`: the stationary law of the wander.
fn stationary_law(process: &BiasProcess) -> LinearFactor {
    let (w_a, w_g) = (1.0 / process.sigma_accel, 1.0 / process.sigma_gyro);
    let mut a_sb = vec![0.0; 6 * 9];
    let mut a_c = vec![0.0; 6 * 6];
    for r in 0..3 {
        a_sb[r * 9 + 3 + r] = w_a;
        a_sb[(r + 3) * 9 + 6 + r] = w_g;
        a_c[r * 6 + r] = -w_a;
        a_c[(r + 3) * 6 + 3 + r] = -w_g;
    }
    LinearFactor::new(vec![a_sb, a_c], vec![0.0; 6], vec![9, 6]).expect("finite weights")
}

/// The biases' step over `dt` seconds between two speed-bias blocks `[v, ba, bg]` that no IMU
/// interval joins, so the bias estimate survives an IMU dropout (the velocity unconstrained):
/// the random walk `(b_j − b_i)/(σ_rw √dt)` over `[speed-bias i, speed-bias j]`, or with a bias
/// `process` the Gauss–Markov step `(b_j − φ b_i − (1 − φ) c)/σ` over `[speed-bias i,
/// speed-bias j, mean]`, `σ²` the walk's variance and the drive's.
pub(super) fn bias_step(dt: f64, noise: &ImuNoise, process: Option<&BiasProcess>) -> LinearFactor {
    let dt = dt.max(1e-6);
    let (sigma_a, sigma_g, keep) = match process {
        None => (
            noise.accelerometer_random_walk * dt.sqrt(),
            noise.gyroscope_random_walk * dt.sqrt(),
            1.0,
        ),
        Some(p) => {
            let (drive_a, drive_g) = p.drive_variances(dt);
            (
                (noise.accelerometer_random_walk.powi(2) * dt + drive_a).sqrt(),
                (noise.gyroscope_random_walk.powi(2) * dt + drive_g).sqrt(),
                p.keep(dt),
            )
        }
    };
    // A floor keeps the weights finite for noise-free configurations.
    let w_a = 1.0 / sigma_a.max(1e-9);
    let w_g = 1.0 / sigma_g.max(1e-9);
    let mut a_i = vec![0.0; 6 * 9];
    let mut a_j = vec![0.0; 6 * 9];
    let mut a_c = vec![0.0; 6 * 6];
    for r in 0..3 {
        a_i[r * 9 + 3 + r] = -keep * w_a;
        a_i[(r + 3) * 9 + 6 + r] = -keep * w_g;
        a_j[r * 9 + 3 + r] = w_a;
        a_j[(r + 3) * 9 + 6 + r] = w_g;
        a_c[r * 6 + r] = -(1.0 - keep) * w_a;
        a_c[(r + 3) * 6 + 3 + r] = -(1.0 - keep) * w_g;
    }
    let (blocks, sizes) = match process {
        Some(_) => (vec![a_i, a_j, a_c], vec![9, 9, 6]),
        None => (vec![a_i, a_j], vec![9, 9]),
    };
    LinearFactor::new(blocks, vec![0.0; 6], sizes).expect("finite weights")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::Factor;

    fn residual(f: &LinearFactor, params: &[&[f64]]) -> Vec<f64> {
        let mut r = vec![0.0; 6];
        assert!(f.evaluate(params, &mut r, None));
        r
    }

    #[test]
    fn the_gap_step_is_the_random_walk_or_the_gauss_markov_step() {
        let noise = ImuNoise::euroc();
        let sb = |ba: f64, bg: f64| [0.0, 0.0, 0.0, ba, ba, ba, bg, bg, bg];
        // Random walk: (b_j − b_i)/(σ_rw √dt).
        let walk = bias_step(0.25, &noise, None);
        let r = residual(&walk, &[&sb(0.1, 0.01), &sb(0.3, 0.02)]);
        assert!((r[0] - 0.2 / (noise.accelerometer_random_walk * 0.5)).abs() < 1e-9);
        assert!((r[3] - 0.01 / (noise.gyroscope_random_walk * 0.5)).abs() < 1e-6);
        // Gauss–Markov: zero where b_j = φ b_i + (1 − φ) c, and weighted by the walk's and the
        // drive's variances together elsewhere.
        let p = BiasProcess::from_allan_floors(4e-4, 1e-2, 2.0);
        let step = bias_step(0.25, &noise, Some(&p));
        let (keep, c) = (p.keep(0.25), [0.5, 0.5, 0.5, 0.05, 0.05, 0.05]);
        let on = sb(
            keep * 0.1 + (1.0 - keep) * 0.5,
            keep * 0.01 + (1.0 - keep) * 0.05,
        );
        let r = residual(&step, &[&sb(0.1, 0.01), &on, &c]);
        assert!(r.iter().all(|v| v.abs() < 1e-9), "{r:?}");
        let (drive_a, _) = p.drive_variances(0.25);
        let sigma = (noise.accelerometer_random_walk.powi(2) * 0.25 + drive_a).sqrt();
        let r = residual(&step, &[&sb(0.1, 0.01), &sb(on[3] + sigma, on[6]), &c]);
        assert!((r[0] - 1.0).abs() < 1e-9 && r[3].abs() < 1e-9, "{r:?}");
    }

    #[test]
    fn the_stationary_law_weighs_the_deviation_from_the_mean_by_sigma_b() {
        let p = BiasProcess::from_allan_floors(4e-4, 1e-2, 8.0);
        let f = stationary_law(&p);
        let sb = [9.0, 9.0, 9.0, 0.1, 0.2, 0.3, 0.01, 0.02, 0.03];
        let c = [
            0.1,
            0.2,
            0.3 - p.sigma_accel,
            0.01,
            0.02,
            0.03 + 2.0 * p.sigma_gyro,
        ];
        let r = residual(&f, &[&sb, &c]);
        let want = [0.0, 0.0, 1.0, 0.0, 0.0, -2.0];
        assert!(
            r.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-9),
            "{r:?}"
        );
    }
}
