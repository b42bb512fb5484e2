//! Feature frames: what a camera frame contributes to the estimator.

use std::sync::Arc;

use nalgebra::Vector2;

use crate::camera::CameraModel;
use crate::geometry::Pose;

/// One tracked feature in one camera image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureObservation {
    /// Track id, shared by all observations of the same 3-D point (across cameras and time).
    pub feature_id: u64,
    /// Distorted pixel coordinates (OpenCV convention: pixel centres at integers).
    pub uv: Vector2<f64>,
}

/// The features one camera saw in one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraFeatures {
    /// Index of the camera in the rig (0 = left/cam0).
    pub cam_id: usize,
    /// Observations, sorted by `feature_id`.
    pub features: Vec<FeatureObservation>,
}

/// A synchronized multi-camera frame of feature observations.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FeatureFrame {
    /// Frame timestamp (ns), in the camera clock (the estimator corrects it by `td`).
    pub t_ns: i64,
    /// Per-camera observations; a camera with no entry produced no image this frame.
    pub cameras: Vec<CameraFeatures>,
}

/// One camera of the rig as the tracker sees it.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct TrackerCamera {
    /// Projection model.
    pub model: Arc<dyn CameraModel>,
    /// Extrinsic `T_b_c` (camera to body).
    pub T_b_c: Pose,
}
