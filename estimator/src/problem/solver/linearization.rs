//! The normal equations of a solve's last linearization, kept for marginal covariances (what
//! the window reports with every estimate) without linearizing the problem again.

use nalgebra::DMatrix;

use super::covariance_of_picks;
use super::normal_equations::NormalEquations;
use super::plan::{Layout, NONE};
use crate::problem::graph::BlockId;

/// The Gauss-Newton information of a problem at the point of a solve's last linearization,
/// landmarks kept apart (see [`super::solve_keeping_linearization`]). With the solver's stop
/// rules that point is the one before the last accepted step, inside the converged
/// neighbourhood; frames and points under first-estimate Jacobians have their Jacobians at
/// their linearization points either way.
pub struct Linearization {
    eqs: NormalEquations,
    layout: Layout,
}

impl Linearization {
    pub(super) fn new(eqs: NormalEquations, layout: Layout) -> Self {
        Self { eqs, layout }
    }

    /// The buffer of its `H_xx`, for the next system (see [`super::SolverWorkspace::recycle`]).
    pub(super) fn into_buffer(self) -> Vec<f64> {
        self.eqs.hxx
    }

    /// The joint covariance of the tangent coordinates `coords` (each `(block, index in its
    /// tangent)`): the matching part of the inverse of the information, with every landmark
    /// eliminated by the undamped Schur complement and the reduced system factored once by
    /// Cholesky and solved for the requested columns. Coordinates of blocks outside the system
    /// (constant or untouched) get zero rows and columns. `None` if a coordinate belongs to a
    /// landmark block (eliminated: use [`crate::problem::marginal_covariance`]) or the reduced
    /// information is not positive definite.
    pub fn marginal_covariance(&self, coords: &[(BlockId, usize)]) -> Option<DMatrix<f64>> {
        if coords.iter().any(|(b, _)| {
            self.layout
                .landmark_slot
                .get(b.0)
                .is_some_and(|s| *s != NONE)
        }) {
            return None;
        }
        let n = self.eqs.n;
        let (mut h, _, _) = self.eqs.undamped_reduced();
        let picks: Vec<(usize, usize)> = coords
            .iter()
            .enumerate()
            .filter_map(|(r, (id, i))| {
                let o = *self.layout.state_offset.get(id.0)?;
                (o != NONE).then_some((r, o + i))
            })
            .collect();
        covariance_of_picks(&mut h, n, &picks, coords.len())
    }
}
