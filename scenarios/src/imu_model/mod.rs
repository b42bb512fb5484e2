//! IMU characterization (`vio imu-model`): Allan deviation and noise-model fit (Kalibr `N`, `K`
//! and the bias instability `B`), spectra and vibration lines, and with ground truth the
//! residual against the IMU the ground truth implies, the clock lag and the frame check.

pub mod allan;
pub mod analysis;
pub mod comparison;
pub mod error_model;
pub mod estimator_noise;
pub mod fit;
pub mod input;
pub mod motion;
pub mod options;
pub mod plot;
pub mod report;
pub mod residual;
pub mod spectrum;
pub mod summary;
pub mod synthesis;
pub mod write;

pub use allan::{AllanCurve, allan_deviation};
pub use analysis::{Input, analyze};
pub use error_model::fit_error_model;
pub use estimator_noise::recommend;
pub use fit::{NoiseFit, SlopeReadoff, fit_noise_model, slope_readoff};
pub use input::load;
pub use options::{DEFAULT_ESTIMATOR_INTERVAL_S, DEFAULT_ESTIMATOR_WINDOW_S, MIN_SAMPLES, Options};
pub use report::{EstimatorNoise, FittedErrorModel, ImuModel};
pub use summary::summary;
pub use write::write_outputs;
