//! The scenario tests: the whole estimator on catalog scenarios and real data (convergence, faults, calibration, aiding, consistency, determinism, the front end, rendering).
//!
//! One test binary per crate (each module is one former `tests/*.rs` file): one link instead of
//! one per file, and the tests of every module share the cores. Run one module with
//! `cargo test --release --test scenario_tests MODULE::`.

mod common;

mod aiding;
mod bag_integrity;
mod calibration;
mod camera_errors;
mod consistency;
mod convergence;
mod determinism;
mod euroc;
mod faults;
mod frontend;
mod imu_fidelity;
mod persistent_points;
mod realism;
mod recorded_imu;
mod reliability;
mod rendered;
mod ros2_bag;
mod zero_velocity;
