//! Whether a raw IMU log moves: 1-s blocks compared with the log's quietest block and with
//! their neighbours. An Allan deviation of a moving log measures the motion, not the sensor.

use estimator::imu::ImuSample;
use nalgebra::Vector3;
use serde::Serialize;

/// A block moves when its noise (gyro axis or accelerometer-norm standard deviation) exceeds
/// the quietest block's by this factor…
const NOISE_FACTOR: f64 = 4.0;
/// …or its mean rate differs from the previous block's by more than this (rad/s, any axis)…
const RATE_STEP_RAD_S: f64 = 0.05;
/// …or its mean specific-force norm by more than this (m/s²).
const FORCE_STEP_M_S2: f64 = 0.2;

/// What the block test found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MotionCheck {
    /// Whole 1-s blocks tested.
    pub blocks: usize,
    /// Blocks that look like motion.
    pub moving_blocks: usize,
    /// Their share.
    pub moving_fraction: f64,
    /// Start (s from the log's start) of the first moving block.
    pub first_moving_s: Option<f64>,
    /// The longest stretch of still blocks `[from, to]` (s from the log's start).
    pub longest_still_s: Option<[f64; 2]>,
}

struct Block {
    gyro_std: f64,
    force_std: f64,
    gyro_mean: Vector3<f64>,
    force_mean: f64,
}

fn block_stats(s: &[ImuSample]) -> Block {
    let n = s.len() as f64;
    let gyro_mean = s.iter().map(|x| x.gyro).sum::<Vector3<f64>>() / n;
    let gyro_var = s
        .iter()
        .map(|x| (x.gyro - gyro_mean).component_mul(&(x.gyro - gyro_mean)))
        .sum::<Vector3<f64>>()
        / n;
    let norms: Vec<f64> = s.iter().map(|x| x.accel.norm()).collect();
    let force_mean = norms.iter().sum::<f64>() / n;
    let force_var = norms.iter().map(|v| (v - force_mean).powi(2)).sum::<f64>() / n;
    Block {
        gyro_std: gyro_var.max().sqrt(),
        force_std: force_var.sqrt(),
        gyro_mean,
        force_mean,
    }
}

/// Tests `samples` (period `dt_s`, the first at `offset_s` from the log's start) in 1-s blocks.
pub fn check_motion(samples: &[ImuSample], dt_s: f64, offset_s: f64) -> MotionCheck {
    let per_block = ((1.0 / dt_s).round() as usize).max(2);
    let blocks: Vec<Block> = samples.chunks_exact(per_block).map(block_stats).collect();
    let min_gyro = blocks
        .iter()
        .map(|b| b.gyro_std)
        .fold(f64::INFINITY, f64::min);
    let min_force = blocks
        .iter()
        .map(|b| b.force_std)
        .fold(f64::INFINITY, f64::min);
    let moving: Vec<bool> = blocks
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let noisy =
                b.gyro_std > NOISE_FACTOR * min_gyro || b.force_std > NOISE_FACTOR * min_force;
            let stepped = i > 0 && {
                let p = &blocks[i - 1];
                (b.gyro_mean - p.gyro_mean).amax() > RATE_STEP_RAD_S
                    || (b.force_mean - p.force_mean).abs() > FORCE_STEP_M_S2
            };
            noisy || stepped
        })
        .collect();
    let block_s = per_block as f64 * dt_s;
    let still: Vec<bool> = moving.iter().map(|m| !m).collect();
    let longest = super::spectrum::runs_of(&still)
        .into_iter()
        .max_by_key(|r| (r.len(), std::cmp::Reverse(r.start)));
    let moving_blocks = moving.iter().filter(|m| **m).count();
    MotionCheck {
        blocks: blocks.len(),
        moving_blocks,
        moving_fraction: if blocks.is_empty() {
            0.0
        } else {
            moving_blocks as f64 / blocks.len() as f64
        },
        first_moving_s: moving
            .iter()
            .position(|m| *m)
            .map(|i| offset_s + i as f64 * block_s),
        longest_still_s: longest.map(|r| {
            [
                offset_s + r.start as f64 * block_s,
                offset_s + r.end as f64 * block_s,
            ]
        }),
    }
}
