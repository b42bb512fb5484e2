//! What a solve is asked to do (method, tolerances, iteration cap) and what it reports.

use std::time::Duration;

/// Which trust-region strategy to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Levenberg–Marquardt with Ceres-style Jacobi damping `λ·diag(JᵀJ)`.
    LevenbergMarquardt,
    /// Powell's dogleg between the Cauchy point and the Gauss–Newton step.
    Dogleg,
}

/// Solver settings. Stop criteria are all relative or absolute tolerances and an iteration
/// cap, never time.
///
/// Deserializable: a table's missing keys take [`SolverOptions::default`]'s values.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SolverOptions {
    /// Trust-region strategy.
    pub method: Method,
    /// Maximum number of iterations (linearizations and modified steps).
    pub max_iterations: usize,
    /// Stop when `|Δcost| / cost` of an accepted step falls below this.
    pub function_tolerance: f64,
    /// Stop when `max |g|` falls below this.
    pub gradient_tolerance: f64,
    /// Stop when `‖δ‖ ≤ tol · (‖x‖ + tol)`.
    pub parameter_tolerance: f64,
    /// Initial trust radius (LM: `λ = 1/radius`).
    pub initial_trust_radius: f64,
    /// Clamp of the Jacobi scaling `diag(JᵀJ)` from below.
    pub min_diagonal: f64,
    /// Levenberg–Marquardt only: after each accepted step, one modified Gauss–Newton step (a
    /// chord step with the gradient made exact): the gradient is evaluated at the new point
    /// together with its cost, and the damped system of the last linearization, already
    /// factorized, is reused. It replaces the next linearization's second-order accumulation
    /// and factorization; the step after it linearizes afresh. A modified step that does not
    /// decrease the cost is dropped (nothing moves) and the next pass linearizes.
    pub modified_newton: bool,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            method: Method::LevenbergMarquardt,
            max_iterations: 10,
            function_tolerance: 1e-6,
            gradient_tolerance: 1e-10,
            parameter_tolerance: 1e-8,
            initial_trust_radius: 1e4,
            min_diagonal: 1e-6,
            modified_newton: false,
        }
    }
}

/// Why the solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// A tolerance was met.
    Converged,
    /// The iteration cap was reached.
    MaxIterations,
    /// No step could reduce the cost (trust region collapsed or factorization kept failing).
    NoProgress,
    /// The initial point could not be evaluated.
    InvalidInitialPoint,
    /// There was nothing to optimize.
    NothingToDo,
}

/// Statistics of one solve, for logs and timing reports.
#[derive(Clone, Copy, Debug)]
pub struct SolverSummary {
    /// Linearizations performed.
    pub iterations: usize,
    /// Accepted steps.
    pub successful_steps: usize,
    /// `½ Σ ρ` before.
    pub initial_cost: f64,
    /// `½ Σ ρ` after.
    pub final_cost: f64,
    /// Why it stopped.
    pub termination: Termination,
    /// Size of the reduced (dense) system.
    pub reduced_size: usize,
    /// Number of eliminated landmark blocks.
    pub landmarks: usize,
    /// Wall time spent (measured for reports; never used for decisions).
    pub time: Duration,
}
