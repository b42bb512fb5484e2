//! `sim`: the deterministic sensor-level simulator.
//!
//! A [`World`] (scene + trajectory + IMU + camera rig + faults, one seed) produces a lazily
//! generated, time-ordered [`stream::Stream`] of [`stream::Measurement`] events, with ground truth
//! queryable at any timestamp.
//!
//! ```
//! use sim::{World, WorldConfig};
//! let world = World::new(WorldConfig { duration_s: 1.0, ..WorldConfig::default() }).unwrap();
//! let mut stream = world.stream();
//! let n_imu = stream
//!     .by_ref()
//!     .filter(|m| matches!(m, sim::stream::Measurement::Imu(_)))
//!     .count();
//! assert_eq!(n_imu, 201); // 200 Hz over [0, 1] s, both ends included
//! ```
//!
//! Conventions: timestamps are `i64` nanoseconds from the start of the run; world frame z up,
//! `g = (0, 0, −9.81)`; body frame = IMU frame; poses `T_w_b`. Determinism: every random draw
//! comes from a ChaCha8 stream derived from (seed, sensor name) ([`rng::sensor_rng`]).

pub mod aiding_sensors;
pub mod bias_instability;
pub mod camera;
pub mod faults;
pub mod imu;
pub mod imu_source;
pub mod input_file;
pub mod limits;
pub mod motion;
pub mod plausible;
pub mod render;
mod render_worker;
pub mod rng;
pub mod scene;
pub mod shaped_noise;
pub mod stream;
pub mod tracker_error;
pub mod validate;
pub mod vibration;
mod world;
mod world_config;

pub use world::{World, reference_motion};
pub use world_config::{SimError, StaticStartConfig, TrajectoryConfig, WorldConfig};
