//! The problem a window builds for one solve (`WindowProblem`, the `Problem` with the map from
//! its blocks back to the window's states and the factors it holds by kind), and the settings
//! the build needs.

use std::sync::Arc;

use super::config::EstimatorConfig;
use super::frame::BlockRef;
use crate::problem::{BlockId, LossFunction, Problem, ResidualId};

/// A window problem and the map from its blocks back to the window's states.
pub(super) struct WindowProblem {
    pub problem: Problem,
    pub refs: Vec<(BlockRef, BlockId)>,
    pub landmarks: Vec<(u64, BlockId)>,
    /// (IMU factor, or bias random-walk factor across an IMU gap; index of its later frame in
    /// the window).
    pub imu: Vec<(ResidualId, usize)>,
    /// (residual, track id) of the inverse-depth landmarks' factors.
    pub visual: Vec<(ResidualId, u64)>,
    /// Persistent world points: (point key, block).
    pub points: Vec<(u64, BlockId)>,
    /// (residual, point key, frame seq) of every observation of a persistent world point.
    pub point_obs: Vec<(ResidualId, u64, u64)>,
    /// (factor, frame seq) of the factors on one frame's states (zero velocity, GNSS, wheel):
    /// they go into the prior with their frame.
    pub frame_factors: Vec<(ResidualId, u64)>,
    pub prior: Option<ResidualId>,
    /// The frame the biases' mean is tied to, when the problem holds the mean.
    pub bias_mean_anchor: Option<u64>,
}

impl WindowProblem {
    /// A problem whose blocks are `refs` (and the persistent `points` among them), with no
    /// factor recorded yet.
    pub fn new(
        problem: Problem,
        refs: Vec<(BlockRef, BlockId)>,
        points: Vec<(u64, BlockId)>,
    ) -> Self {
        Self {
            problem,
            refs,
            landmarks: Vec::new(),
            imu: Vec::new(),
            visual: Vec::new(),
            points,
            point_obs: Vec::new(),
            frame_factors: Vec::new(),
            prior: None,
            bias_mean_anchor: None,
        }
    }

    /// The problem block of a window state, if it is in the problem.
    pub fn block(&self, r: BlockRef) -> Option<BlockId> {
        self.refs.iter().find(|(x, _)| *x == r).map(|(_, b)| *b)
    }

    /// The problem block of a window state if it is in the problem and not held constant.
    pub fn variable_block(&self, r: BlockRef) -> Option<BlockId> {
        self.block(r).filter(|b| !self.problem.is_constant(*b))
    }
}

/// What the window's problem needs besides the states: settings and the robust loss.
pub(super) struct ProblemSettings<'a> {
    pub config: &'a EstimatorConfig,
    /// Robust loss of the reprojection factors.
    pub huber: &'a Arc<dyn LossFunction>,
}
