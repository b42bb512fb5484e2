//! Marginal covariance of the newest state from the window's Gauss–Newton information.

use nalgebra::DMatrix;

use super::window::{BlockRef, Built};
use crate::problem::marginal_covariance;

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
