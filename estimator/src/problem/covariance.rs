//! Marginal covariances from the Gauss-Newton information of a whole problem.

use nalgebra::DMatrix;

use super::graph::{BlockId, Problem};
use super::solver::dense_normal_equations;

/// The joint covariance of the tangent coordinates `coords` (each `(block, index in its
/// tangent)`): the matching part of the inverse of the problem's Gauss-Newton information,
/// every variable block (landmarks included) in one dense system. Coordinates of blocks that
/// are not variables (constant ones) get zero rows and columns. `None` if the information is not
/// positive definite.
pub fn marginal_covariance(problem: &Problem, coords: &[(BlockId, usize)]) -> Option<DMatrix<f64>> {
    let (h, _, blocks) = dense_normal_equations(problem)?;
    let mut offsets = Vec::with_capacity(blocks.len());
    let mut at = 0;
    for b in &blocks {
        offsets.push(at);
        at += problem.manifold(*b).tangent_size();
    }
    // (row in the output, column in H) of every coordinate of a variable block.
    let picks: Vec<(usize, usize)> = coords
        .iter()
        .enumerate()
        .filter_map(|(r, (id, i))| Some((r, offsets[blocks.iter().position(|b| b == id)?] + i)))
        .collect();
    let chol = h.cholesky()?;
    let mut e = DMatrix::zeros(at, picks.len());
    for (j, &(_, c)) in picks.iter().enumerate() {
        e[(c, j)] = 1.0;
    }
    let x = chol.solve(&e);
    // Symmetric by construction up to rounding.
    let mut cov = DMatrix::zeros(coords.len(), coords.len());
    for (i, &(ri, ci)) in picks.iter().enumerate() {
        for (j, &(rj, cj)) in picks.iter().enumerate() {
            cov[(ri, rj)] = 0.5 * (x[(ci, j)] + x[(cj, i)]);
        }
    }
    Some(cov)
}
