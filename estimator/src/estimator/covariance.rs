//! The window's Gauss–Newton information: the newest state's marginal covariance, and the
//! window problem itself for analysis (gauge freedoms, consistency).

use nalgebra::DMatrix;

use super::Estimator;
use super::window::{BlockRef, Built};
use crate::problem::{BlockId, Problem, marginal_covariance};

/// Marginal covariance of frame `seq`'s pose (and speed-bias) blocks: the matching block of the
/// inverse of the whole window's Gauss-Newton information. `None` if a block is constant or
/// absent, or the information is not positive definite.
pub(super) fn newest_covariance(built: &Built, seq: u64) -> Option<DMatrix<f64>> {
    let mut coords = Vec::new();
    for r in [BlockRef::Pose(seq), BlockRef::SpeedBias(seq)] {
        let Some(id) = built.block(r) else { continue };
        if built.problem.is_constant(id) {
            return None;
        }
        let n = built.problem.manifold(id).tangent_size();
        coords.extend((0..n).map(|i| (id, i)));
    }
    if coords.is_empty() {
        return None;
    }
    marginal_covariance(&built.problem, &coords)
}

/// The window as the nonlinear least-squares problem the next solve would start from (prior,
/// IMU and reprojection factors at the current estimates, first-estimate points set), with the
/// roles of its blocks. For analysis and tests; the estimator does not use it.
pub struct WindowSystem {
    /// The problem.
    pub problem: Problem,
    /// Pose block of each window frame, oldest first.
    pub poses: Vec<BlockId>,
    /// Speed-bias block of each window frame (empty without the IMU).
    pub speed_biases: Vec<BlockId>,
    /// Landmark (inverse-depth) blocks.
    pub landmarks: Vec<BlockId>,
    /// Persistent world-point blocks (states: the prior may hold them).
    pub points: Vec<BlockId>,
}

impl Estimator {
    /// The current window as a [`WindowSystem`]; `None` before the first frame.
    pub fn window_system(&self) -> Option<WindowSystem> {
        if self.window.frames.is_empty() {
            return None;
        }
        let imu_active = self.config.suite.uses_imu() && self.status == super::Status::Tracking;
        let built = self.window.build(&self.problem_settings(), imu_active);
        let seqs: Vec<u64> = self.window.frames.iter().map(|f| f.seq).collect();
        let poses = seqs
            .iter()
            .filter_map(|s| built.block(BlockRef::Pose(*s)))
            .collect();
        let speed_biases = seqs
            .iter()
            .filter_map(|s| built.block(BlockRef::SpeedBias(*s)))
            .collect();
        let landmarks = built.landmarks.iter().map(|(_, b)| *b).collect();
        let points = built.points.iter().map(|(_, b)| *b).collect();
        Some(WindowSystem {
            problem: built.problem,
            poses,
            speed_biases,
            landmarks,
            points,
        })
    }
}
