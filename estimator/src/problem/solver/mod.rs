//! Levenberg–Marquardt and Powell's dogleg on the manifold, with landmark blocks eliminated by
//! the Schur complement and the reduced system solved by dense Cholesky (faer's LLT).
//!
//! A solve plans its normal equations once (`NormalEquations::new`: residuals grouped by
//! landmark, the landmark–state coupling blocks `H_xl` laid out in one buffer) and every
//! linearization refills the same buffers. Rotation matrices of pose blocks are computed once
//! per evaluation pass and handed to the factors (`Factor::evaluate_with_rotations`).
//!
//! Everything is deterministic: blocks are visited in id order, no threads (faer runs with
//! `Par::Seq`), and stopping is decided by iteration count, cost change, gradient and step size
//! — never by wall-clock time. Timing is measured for reports only.

mod accumulate;
mod dense;
mod dogleg;
mod linearization;
mod normal_equations;
mod options;
mod plan;
mod schur;
mod trust_region;
mod vector;

pub(crate) use dense::covariance_of_picks;
pub use dense::dense_normal_equations;
pub use linearization::Linearization;
pub use options::{Method, SolverOptions, SolverSummary, Termination};
pub(crate) use plan::{Layout, NONE};
pub use schur::{SchurComplementSystem, schur_complement_system};
pub use trust_region::{
    SolverWorkspace, solve, solve_keeping_linearization, solve_keeping_linearization_in,
};
pub(crate) use vector::{dot, is_symmetric, mirror_upper};
