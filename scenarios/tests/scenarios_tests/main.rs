//! The scenarios crate's tests: the `vio` CLI, scenario files and bad input, datasets, Kalibr rigs, metrics, reports, regressions, sweeps, the IMU model, the OpenVINS peer harness.
//!
//! One test binary per crate (each module is one former `tests/*.rs` file): one link instead of
//! one per file, and the tests of every module share the cores. Run one module with
//! `cargo test --release --test scenarios_tests MODULE::`.

mod common;

mod bad_input;
mod bench;
mod cli;
mod cli_eval;
mod dataset;
mod evo_agreement;
mod export_output;
mod fuzz;
mod image_stats;
mod imu_error_model;
mod imu_model;
mod input_fuzz;
mod interrupts;
mod kalibr;
mod key_listing;
mod metrics;
mod outside_estimator;
mod peer_openvins;
mod recorded_imu_input;
mod regress;
mod report;
mod set_option;
mod settings;
mod sweep;
mod sweep_runs;
mod units;
