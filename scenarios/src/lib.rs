//! `scenarios`: scenario files, the runner, metrics, reports, dataset I/O and the `vio` CLI.
//!
//! - [`dataset`]: TUM trajectories, EuRoC ASL folders, `sensor.yaml`, `features.csv`.
//! - [`metrics`]: association, alignment (SE3, Sim3, position+yaw), ATE, RPE, NEES — with
//!   evo's definitions.
//! - [`selfcheck`]: a quick end-to-end check of the estimator's mathematics (`vio selfcheck`).
//!
//! Scenario files and `vio run` arrive with the harness spine.

pub mod dataset;
pub mod metrics;
pub mod selfcheck;
