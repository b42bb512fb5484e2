//! Outside estimators in the harness: a scenario with `estimator_adapter` is exported as the
//! adapter's input, the adapter's program runs on it, and its trajectory is scored by the same
//! pipeline, metrics, expectations and `report.json` as ours ([`run_outside`]). The adapter file
//! itself is read and checked with the scenario ([`crate::spec::estimator_adapter`]).

mod outside_run;
pub mod program;
pub mod stamped_rows;
pub mod state_covariance;
pub mod trajectory;

pub use outside_run::run_outside;
