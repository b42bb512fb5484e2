//! `scenarios`: scenario files, the runner, metrics, reports, dataset I/O and the `vio` CLI.
//!
//! - [`dataset`]: TUM trajectories, EuRoC ASL folders, `sensor.yaml`, `features.csv`.
//! - [`metrics`]: association, alignment (SE3, Sim3, position+yaw), ATE, RPE, NEES — with
//!   evo's definitions.
//! - [`spec`] — the scenario TOML schema and its mapping onto the simulator and the estimator;
//! - [`catalog`] — the built-in scenarios (`scenarios/catalog/*.toml`, embedded);
//! - [`run`] — simulated stream → estimator, collecting estimates, ground truth, timings, events;
//! - [`report`] — evaluation, `report.json`, TUM files, the human summary;
//! - [`plot`] — `trajectory.png`;
//! - [`replay_report`] — what the checks of a replayed recording found and did;
//! - [`recorded_imu_report`] — a recorded IMU log's checks against the replayed ground truth;
//! - [`export`] — a scenario's measurements as an EuRoC ASL folder and `features.csv`;
//! - [`images`], [`tracks_image`] — `vio render`: images, depth, and the front end's tracks;
//! - [`regress`] — `vio regress`: a regression catalog against a stored baseline, JUnit XML;
//! - [`sweep`] — `vio sweep` / `sweep-merge`: a scenario over a parameter grid × seeds, sharded;
//! - [`bench`] — `vio bench`: per-stage timing, frames per second and peak memory;
//! - [`selfcheck`] — a quick end-to-end check of the estimator's mathematics;
//! - [`imu_model`] — `vio imu-model`: Allan deviation, noise-model fit, spectra and the residual
//!   of a recorded IMU log against its ground truth.

pub mod catalog;
pub mod dataset;
pub mod export;
pub mod frontend;
pub mod images;
pub mod imu_model;
pub mod metrics;
pub mod plot;
pub mod report;
pub mod run;
pub mod run_output;
pub mod selfcheck;
pub mod spec;
pub mod studies;
pub mod tracks_image;
