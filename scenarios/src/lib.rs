//! `scenarios`: scenario files, the runner, metrics, reports, dataset I/O and the `vio` CLI.
//!
//! For now it holds the `selfcheck` demo: a quick end-to-end check of the estimator's
//! mathematics that a newcomer can run. Scenario files and `vio run` arrive with the harness
//! spine.

pub mod selfcheck;
