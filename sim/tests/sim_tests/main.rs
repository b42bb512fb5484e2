//! The simulator crate's tests: motion, recordings, the IMU and its error model, cameras, faults, rendering, streams and determinism.
//!
//! One test binary per crate (each module is one former `tests/*.rs` file): one link instead of
//! one per file, and the tests of every module share the cores. Run one module with
//! `cargo test --release --test sim_tests MODULE::`.

mod common;

mod camera;
mod determinism;
mod faults;
mod imu;
mod imu_error_model;
mod motion;
mod recorded_imu;
mod recording;
mod recording_fuzz;
mod render;
mod replay;
mod stream;
