//! The nonlinear least-squares problem: parameter-block manifolds, factors, robust losses, the
//! shared Jacobian checker, the solver, marginalization and marginal covariances.

pub(crate) mod covariance;
mod factor;
pub mod gradient_check;
mod graph;
mod linear_factor;
mod loss;
mod manifold;
pub mod marginalization;
mod prior;
pub mod solver;

pub use covariance::marginal_covariance;
pub use factor::{Factor, rotation_matrix, write_row_major};
pub use gradient_check::{CheckError, CheckOptions, check_factor_jacobians};
pub use graph::{BlockId, BlockKind, Problem, ProblemError, ResidualId};
pub use linear_factor::LinearFactor;
pub use loss::{CauchyLoss, HuberLoss, LossFunction, apply_loss};
pub use manifold::{Euclidean, Manifold, PoseManifold, QuaternionManifold};
pub use prior::{PriorError, PriorFactor};
pub use solver::{
    Linearization, Method, SchurComplementSystem, SolverOptions, SolverSummary, SolverWorkspace,
    Termination, schur_complement_system, solve, solve_keeping_linearization,
    solve_keeping_linearization_in,
};

/// Deterministic pseudo-random numbers in [−1, 1] for the unit tests (no RNG dependency in the
/// library).
#[cfg(test)]
pub(crate) fn test_lcg(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}
