//! Initialization: the first gravity-aligned attitude, stereo+IMU and mono+IMU
//! visual-inertial alignment, and the initial prior that pins the unobservable directions.

mod alignment;
pub(crate) mod five_point;
mod mono;
pub(crate) mod sfm;
mod stereo;

pub(super) use alignment::gravity_aligned_rotation;
pub(super) use mono::initialize_mono_inertial;
pub(super) use stereo::{initial_prior, initialize_stereo_inertial};
