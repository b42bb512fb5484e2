//! `sim`: the deterministic sensor-level simulator.
//!
//! A [`World`] (scene + trajectory + IMU + camera rig + faults, one seed) produces a lazily
//! generated, time-ordered [`stream::Stream`] of [`stream::Measurement`] events, with ground truth
//! queryable at any timestamp.

pub mod imu;
pub mod motion;
pub mod rng;
