//! The estimator crate's tests: factor Jacobians, manifolds, camera models, the KLT front end, marginalization, the window and its gauge.
//!
//! One test binary per crate (each module is one former `tests/*.rs` file): one link instead of
//! one per file, and the tests of every module share the cores. Run one module with
//! `cargo test --release --test estimator_tests MODULE::`.

mod common;

mod aiding_factors;
mod calibration_factors;
mod camera_props;
mod factor_jacobians;
mod frontend_klt;
mod gauge;
mod imu_props;
mod manifold_props;
mod marginalization;
mod window;
