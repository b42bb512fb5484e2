//! What an export writes into: the sink every format implements, its summary and its errors.

use estimator::frontend::FeatureFrame;
use estimator::imu::ImuSample;
use estimator::{GnssSample, WheelSample};
use sim::render::ImageFrame;

use crate::dataset::{DatasetError, GroundTruthState};
use crate::run::RunError;

/// What an export wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct ExportSummary {
    /// IMU samples written.
    pub imu_samples: usize,
    /// Camera frames written.
    pub frames: usize,
    /// Feature observations written.
    pub observations: usize,
    /// Ground-truth rows written.
    pub groundtruth: usize,
    /// Rendered images written (rendered scenarios).
    pub images: usize,
    /// The camera stamps (ns) of the frames written, images or feature frames, in order.
    pub frame_stamps_ns: Vec<i64>,
}

/// Errors from [`super::export`] and [`super::export_bag`].
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The scenario could not be simulated.
    #[error(transparent)]
    Run(#[from] RunError),
    /// A dataset file could not be written.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// An image could not be written.
    #[error("{0}")]
    Image(String),
    /// Another file (a calibration, the bag) could not be written.
    #[error("{0}")]
    Write(String),
}

/// Where the measurements go, in stream order; the feature tracks come last, renumbered.
pub(super) trait ExportSink {
    /// An IMU sample and the ground truth at its time.
    fn imu(&mut self, s: &ImuSample, truth: Option<&GroundTruthState>) -> Result<(), ExportError>;
    /// A rendered capture.
    fn images(&mut self, frame: &ImageFrame) -> Result<(), ExportError>;
    /// A GNSS fix (formats without a place for it drop it).
    fn gnss(&mut self, _fix: &GnssSample) -> Result<(), ExportError> {
        Ok(())
    }
    /// A wheel-odometry reading (formats without a place for it drop it).
    fn wheel(&mut self, _reading: &WheelSample) -> Result<(), ExportError> {
        Ok(())
    }
    /// The feature tracks of the whole run, then whatever closes the output.
    fn finish(self: Box<Self>, frames: &[FeatureFrame]) -> Result<(), ExportError>;
}
