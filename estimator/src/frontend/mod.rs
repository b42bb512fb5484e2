//! The image front end: what a camera frame contributes to the estimator.
//!
//! [`FeatureTracker`] turns grey images into [`FeatureFrame`]s: Shi–Tomasi corners
//! ([`corners`]), pyramidal inverse-compositional Lucas–Kanade with flow-back ([`klt`]), stereo
//! matching with epipolar checks, RANSAC on normalized coordinates ([`ransac`]). Images are
//! borrowed ([`ImageView`]): the caller keeps its buffers.

pub mod affine;
mod checks;
mod config;
pub mod corners;
pub mod image;
pub mod klt;
mod lanes;
pub mod ransac;
mod statistics;
mod tracker;
mod types;

pub use config::{TrackerConfig, TrackerError};
pub use image::{ImageError, ImageView, OwnedImage, Pyramid};
pub use statistics::{TrackStatistics, TrackSummary};
pub use tracker::{CameraImageView, FeatureTracker, StageTimes, TrackReport, TrackedFeature};
pub use types::{CameraFeatures, FeatureFrame, FeatureObservation, TrackerCamera};
