//! Marginal covariance of the newest state from the window's Gauss–Newton information.

use nalgebra::DMatrix;

use super::window::{BlockRef, Built};
use crate::problem::solver::dense_normal_equations;

/// Marginal covariance of frame `seq`'s pose (and speed-bias) blocks: the matching block of the
/// inverse of the whole window's Gauss-Newton information. `None` if a block is constant or
/// absent, or the information is not positive definite.
pub(super) fn newest_covariance(built: &Built, seq: u64) -> Option<DMatrix<f64>> {
    let (h, _, blocks) = dense_normal_equations(&built.problem)?;
    let mut offsets = Vec::with_capacity(blocks.len());
    let mut at = 0;
    for b in &blocks {
        offsets.push(at);
        at += built.problem.manifold(*b).tangent_size();
    }
    let mut cols = Vec::new();
    for r in [BlockRef::Pose(seq), BlockRef::SpeedBias(seq)] {
        let Some(id) = built.block(r) else { continue };
        let k = blocks.iter().position(|b| *b == id)?;
        cols.extend(offsets[k]..offsets[k] + built.problem.manifold(id).tangent_size());
    }
    if cols.is_empty() {
        return None;
    }
    let n = h.nrows();
    let chol = h.cholesky()?;
    let mut e = DMatrix::zeros(n, cols.len());
    for (j, &c) in cols.iter().enumerate() {
        e[(c, j)] = 1.0;
    }
    let x = chol.solve(&e);
    let m = cols.len();
    let mut cov = DMatrix::from_fn(m, m, |i, j| x[(cols[i], j)]);
    // Symmetric by construction up to rounding.
    cov = (&cov + cov.transpose()) * 0.5;
    Some(cov)
}
