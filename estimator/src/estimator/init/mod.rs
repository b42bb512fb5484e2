//! Initialization: the first gravity-aligned attitude, stereo+IMU visual-inertial alignment,
//! and the initial prior that pins the unobservable directions.

mod alignment;
mod stereo;

pub(super) use alignment::gravity_aligned_rotation;
pub(super) use stereo::{initial_prior, initialize_stereo_inertial};
