//! The normal equations of a solve's last linearization, kept for marginal covariances (what
//! the window reports with every estimate) without linearizing the problem again.

use std::cell::{Cell, OnceCell};

use nalgebra::DMatrix;

use super::dense::{covariance_from_factor, dense_cholesky_factor};
use super::normal_equations::NormalEquations;
use super::plan::{Layout, NONE};
use super::vector::copy_upper;
use crate::problem::graph::BlockId;

/// The Gauss-Newton information of a problem at the point of a solve's last linearization,
/// landmarks kept apart (see [`super::solve_keeping_linearization`]). With the solver's stop
/// rules that point is the one before the last accepted step, inside the converged
/// neighbourhood; frames and points under first-estimate Jacobians have their Jacobians at
/// their linearization points either way.
pub struct Linearization {
    eqs: NormalEquations,
    layout: Layout,
    /// The Cholesky factor of the reduced information (landmarks eliminated): the solve's, or
    /// made on the first covariance asked for; shared by every covariance (`Err`: the buffer,
    /// not positive definite).
    factor: OnceCell<Result<Vec<f64>, Vec<f64>>>,
    /// The buffer the factor is made in, until it is.
    spare: Cell<Vec<f64>>,
}

impl Linearization {
    /// The normal equations of a solve's last linearization; `spare` is a buffer of an
    /// earlier one for the factor (its contents do not matter); `factor`, the solve's own
    /// Cholesky factor of this linearization's reduced system where its damping was
    /// negligible.
    pub(super) fn new(
        eqs: NormalEquations,
        layout: Layout,
        spare: Vec<f64>,
        factor: Option<Vec<f64>>,
    ) -> Self {
        Self {
            eqs,
            layout,
            factor: factor.map(|f| OnceCell::from(Ok(f))).unwrap_or_default(),
            spare: Cell::new(spare),
        }
    }

    /// Its buffers (`H_xx`, the factor's, the spare one), for the next system (see
    /// [`super::SolverWorkspace::recycle`]).
    pub(super) fn into_buffers(self) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let factor = match self.factor.into_inner() {
            Some(Ok(b) | Err(b)) => b,
            None => Vec::new(),
        };
        (self.eqs.hxx, factor, self.spare.into_inner())
    }

    /// Whether a factor is at hand (the solve's own, before any covariance was asked for).
    #[cfg(test)]
    pub(crate) fn holds_a_factor(&self) -> bool {
        self.factor.get().is_some()
    }

    /// The factor of the undamped reduced information, made on first use; `None` if that
    /// information is not positive definite.
    fn factor(&self) -> Option<&[f64]> {
        let made = self.factor.get_or_init(|| {
            // `H_xx`'s upper triangle, row by row, into the spare buffer; the landmarks
            // eliminated onto it; factored in place.
            let n = self.eqs.n;
            let mut h = self.spare.take();
            copy_upper(&mut h, &self.eqs.hxx, n);
            let (mut h, _, _) = self.eqs.undamped_reduced_onto(h);
            if dense_cholesky_factor(&mut h, n, &mut None) {
                Ok(h)
            } else {
                Err(h)
            }
        });
        made.as_deref().ok()
    }

    /// The joint covariance of the tangent coordinates `coords` (each `(block, index in its
    /// tangent)`): the matching part of the inverse of the information, with every landmark
    /// eliminated by the Schur complement and the reduced system factored once by Cholesky and
    /// solved for the requested columns. The factor is the solve's own where its last step was
    /// damped by `λ` ≤ 1e-10 (the window's are: its solves start at 1e-12), a relative change
    /// of the information's diagonal far below the precision any covariance is read to;
    /// otherwise the undamped system is factored on the first call. Coordinates of blocks outside the system
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
        let factor = self.factor()?;
        let picks: Vec<(usize, usize)> = coords
            .iter()
            .enumerate()
            .filter_map(|(r, (id, i))| {
                let o = *self.layout.state_offset.get(id.0)?;
                (o != NONE).then_some((r, o + i))
            })
            .collect();
        Some(covariance_from_factor(factor, n, &picks, coords.len()))
    }
}
