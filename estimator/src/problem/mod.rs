//! The nonlinear least-squares problem: parameter-block manifolds, factors, robust losses and the
//! shared Jacobian checker.

mod factor;
pub mod gradient_check;
mod loss;
mod manifold;

pub use factor::{Factor, write_row_major};
pub use gradient_check::{CheckError, CheckOptions, check_factor_jacobians};
pub use loss::{CauchyLoss, HuberLoss, LossFunction, apply_loss};
pub use manifold::{Euclidean, Manifold, PoseManifold, QuaternionManifold};
