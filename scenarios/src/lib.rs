//! `scenarios`: scenario files, the runner, metrics, reports, dataset I/O and the `vio` CLI.
//!
//! - [`dataset`]: TUM trajectories, EuRoC ASL folders, `sensor.yaml`, `features.csv`.
//! - [`metrics`]: association, alignment (SE3, Sim3, position+yaw), ATE, RPE, NEES — with
//!   evo's definitions.
//! - [`spec`] — the scenario TOML schema and its mapping onto the simulator and the estimator;
//! - [`catalog`] — the built-in scenarios (`scenarios/catalog/*.toml`, embedded);
//! - [`pipeline`] — the one run pipeline: a scenario or a recorded dataset → estimate → evaluated
//!   report ([`pipeline::run_to_report`]); [`run`] — the runner that feeds our estimator;
//!   [`run_output`] — what a run produced;
//! - [`report`] — evaluation, `report.json` and its sections (window against batch, recovery,
//!   replay and recorded-IMU checks, calibration), the TUM files, the human summary;
//! - [`plot`] — `trajectory.png`;
//! - [`export`] — a scenario's measurements as an EuRoC ASL folder and `features.csv`;
//! - [`external`] — an outside estimator (`estimator_adapter`) run on the export and scored;
//! - [`frontend`] — the image front end's statistics in a run;
//! - [`images`], [`tracks_image`] — `vio render`: images, depth, and the front end's tracks;
//! - [`studies`] — `vio regress` (the regression catalog against a baseline, JUnit XML),
//!   `vio sweep` / `sweep-merge` (a scenario over a parameter grid × seeds, sharded),
//!   `vio bench` (per-stage timing) and `vio nees` (Monte-Carlo consistency);
//! - [`selfcheck`] — a quick end-to-end check of the estimator's mathematics;
//! - [`imu_model`] — `vio imu-model`: Allan deviation, noise-model fit, spectra and the residual
//!   of a recorded IMU log against its ground truth.

pub mod catalog;
pub mod dataset;
pub mod export;
pub mod external;
pub mod frontend;
pub mod images;
pub mod imu_model;
pub mod metrics;
pub mod pipeline;
pub mod plot;
pub mod report;
pub mod run;
pub mod run_output;
pub mod selfcheck;
pub mod spec;
pub mod studies;
mod track_drawing;
pub mod tracks_image;
