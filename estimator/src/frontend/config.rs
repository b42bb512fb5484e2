//! The tracker's settings and errors.

use super::klt::KltParams;

/// Tracker settings (defaults after VINS-Fusion's EuRoC configuration).
///
/// Deserializable (a scenario's `[camera.tracker]`): missing keys take the defaults; `seed` is
/// not read (the caller seeds RANSAC).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackerConfig {
    /// Features kept per frame on the primary camera.
    pub max_features: usize,
    /// Minimum distance between features (px).
    pub min_distance_px: f64,
    /// Shi–Tomasi quality level (fraction of the strongest response).
    pub quality_level: f64,
    /// Shi–Tomasi absolute floor (see [`CornerParams::min_response`](super::corners::CornerParams::min_response)).
    pub min_corner_response: f64,
    /// Grid `[columns, rows]` for bucketing new corners (`[1, 1]`: none).
    pub grid: [usize; 2],
    /// Pyramid level Shi–Tomasi runs on (0 = full resolution; 1 = half, each corner then placed
    /// on the strongest full-resolution response it covers: a quarter of the work).
    pub detect_level: usize,
    /// New corners keep this far from the image border (px); tracks whose window leaves the
    /// image are lost anyway, so at least half the window plus one.
    pub border_px: u32,
    /// KLT window side (odd, px): 21 → 21×21.
    pub window_px: usize,
    /// Coarsest pyramid level (level 0 is full size; 3 → four levels, OpenCV's `maxLevel`).
    pub max_level: usize,
    /// KLT iteration cap per level.
    pub max_iterations: usize,
    /// KLT convergence threshold (px).
    pub epsilon_px: f64,
    /// KLT minimum structure (see [`KltParams::min_eigen`]).
    pub min_eigen: f64,
    /// Match patches up to gain and offset (robust to exposure changes).
    pub normalize_patches: bool,
    /// Equalize each image's histogram before tracking.
    pub equalize: bool,
    /// Refine every frame-to-frame result by an affine alignment of the track's *anchor* patch
    /// (its first observation, see [`super::affine`]) so errors do not accumulate along the
    /// track; when the refinement fails or moves the point by more than `anchor_max_shift_px`,
    /// the track is re-anchored at its current patch.
    pub anchor_refinement: bool,
    /// Largest refinement step accepted (px).
    pub anchor_max_shift_px: f64,
    /// Track back and require to land within `flow_back_px` of the start (on the finest level,
    /// from the start position: the step to recover is sub-pixel when the track is right).
    pub flow_back: bool,
    /// Flow-back tolerance (px).
    pub flow_back_px: f64,
    /// Match features into the other cameras.
    pub stereo: bool,
    /// Largest distance of a stereo match from its epipolar line (px).
    pub epipolar_px: f64,
    /// Reject temporal outliers by RANSAC.
    pub ransac: bool,
    /// RANSAC inlier threshold (px, Sampson distance).
    pub ransac_threshold_px: f64,
    /// RANSAC confidence.
    pub ransac_confidence: f64,
    /// RANSAC hypothesis cap.
    pub ransac_max_iterations: usize,
    /// Start temporal KLT where the gyro rotation predicts each feature.
    pub gyro_prediction: bool,
    /// Seed of the per-frame RANSAC streams (mixed with the frame stamp).
    #[serde(skip)]
    pub seed: u64,
}

impl Default for TrackerConfig {
    fn default() -> Self {
        Self {
            max_features: 150,
            min_distance_px: 30.0,
            quality_level: 0.01,
            min_corner_response: 4.0,
            grid: [1, 1],
            detect_level: 1,
            border_px: 11,
            window_px: 21,
            max_level: 3,
            max_iterations: 30,
            epsilon_px: 0.01,
            min_eigen: 1.0,
            normalize_patches: true,
            equalize: false,
            anchor_refinement: true,
            anchor_max_shift_px: 1.0,
            flow_back: true,
            flow_back_px: 0.5,
            stereo: true,
            epipolar_px: 1.5,
            ransac: true,
            ransac_threshold_px: 1.0,
            ransac_confidence: 0.99,
            ransac_max_iterations: 200,
            gyro_prediction: true,
            seed: 0,
        }
    }
}

impl TrackerConfig {
    /// Checks every setting; the message names the field.
    pub fn validate(&self) -> Result<(), TrackerError> {
        let bad = |field: &'static str, why: &str| {
            Err(TrackerError::Config {
                field,
                message: why.to_string(),
            })
        };
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if self.max_features == 0 || self.max_features > 10_000 {
            return bad("max_features", "must be in 1..=10000");
        }
        if !(self.min_distance_px.is_finite() && (0.0..=1000.0).contains(&self.min_distance_px)) {
            return bad("min_distance_px", "must be finite, in 0..=1000 px");
        }
        if !(self.quality_level.is_finite() && (0.0..1.0).contains(&self.quality_level)) {
            return bad("quality_level", "must be in [0, 1)");
        }
        if !(self.min_corner_response.is_finite() && self.min_corner_response >= 0.0) {
            return bad("min_corner_response", "must be finite and ≥ 0");
        }
        if self.grid[0] == 0 || self.grid[1] == 0 || self.grid[0] * self.grid[1] > 10_000 {
            return bad("grid", "needs ≥ 1 column and row, at most 10000 cells");
        }
        if self.window_px < 5 || self.window_px > 63 || self.window_px.is_multiple_of(2) {
            return bad("window_px", "must be odd, in 5..=63");
        }
        if self.detect_level > 3 {
            return bad("detect_level", "must be in 0..=3");
        }
        if self.max_level > 6 {
            return bad("max_level", "must be in 0..=6");
        }
        if self.max_iterations == 0 || self.max_iterations > 1000 {
            return bad("max_iterations", "must be in 1..=1000");
        }
        if !pos(self.epsilon_px) {
            return bad("epsilon_px", "must be finite and > 0");
        }
        if !(self.min_eigen.is_finite() && self.min_eigen >= 0.0) {
            return bad("min_eigen", "must be finite and ≥ 0");
        }
        if !pos(self.anchor_max_shift_px) {
            return bad("anchor_max_shift_px", "must be finite and > 0");
        }
        if !pos(self.flow_back_px) {
            return bad("flow_back_px", "must be finite and > 0");
        }
        if !pos(self.epipolar_px) {
            return bad("epipolar_px", "must be finite and > 0");
        }
        if !pos(self.ransac_threshold_px) {
            return bad("ransac_threshold_px", "must be finite and > 0");
        }
        if !(self.ransac_confidence > 0.0 && self.ransac_confidence < 1.0) {
            return bad("ransac_confidence", "must be in (0, 1)");
        }
        if self.ransac_max_iterations == 0 || self.ransac_max_iterations > 100_000 {
            return bad("ransac_max_iterations", "must be in 1..=100000");
        }
        Ok(())
    }

    pub(super) fn klt(&self) -> KltParams {
        KltParams {
            half_window: self.window_px / 2,
            max_iterations: self.max_iterations,
            epsilon_px: self.epsilon_px,
            min_eigen: self.min_eigen,
            normalize: self.normalize_patches,
        }
    }
}

/// Errors of the tracker.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrackerError {
    /// A setting is out of range.
    #[error("tracker setting `{field}`: {message}")]
    Config {
        /// The field.
        field: &'static str,
        /// Why.
        message: String,
    },
    /// An image came for a camera the tracker does not know.
    #[error("image for camera {cam_id}, but the rig has {cameras} camera(s)")]
    UnknownCamera {
        /// The camera index.
        cam_id: usize,
        /// Cameras configured.
        cameras: usize,
    },
    /// An image's size differs from its camera model's.
    #[error("camera {cam_id}: image {got_w}×{got_h}, the camera model is {want_w}×{want_h}")]
    ImageSize {
        /// The camera index.
        cam_id: usize,
        /// Image width.
        got_w: u32,
        /// Image height.
        got_h: u32,
        /// Model width.
        want_w: u32,
        /// Model height.
        want_h: u32,
    },
}
