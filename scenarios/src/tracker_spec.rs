//! `[camera.tracker]` and `camera.frontend`: the image front end's settings in a scenario file.

use estimator::frontend::{TrackerConfig, TrackerError};
use serde::Deserialize;

/// Which features the estimator gets in a rendered scenario.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FrontendSpec {
    /// The image front end (`estimator::frontend::FeatureTracker`) on the rendered images
    /// (the default when images are rendered).
    #[default]
    Klt,
    /// The simulator's ideal feature tracks of the same captures (for comparison).
    Truth,
}

/// `[camera.tracker]`: every key optional, defaults from `TrackerConfig::default()` (VINS-like:
/// 150 features, 30 px apart, 21×21 window, pyramid levels 0..=3).
///
/// ```toml
/// [camera.tracker]
/// max_features = 150
/// min_distance_px = 30.0
/// window_px = 21
/// max_level = 3
/// equalize = false
/// ```
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrackerSpec {
    /// Features kept per frame.
    pub max_features: Option<usize>,
    /// Minimum distance between features (px).
    pub min_distance_px: Option<f64>,
    /// Shi–Tomasi quality level.
    pub quality_level: Option<f64>,
    /// Shi–Tomasi absolute floor.
    pub min_corner_response: Option<f64>,
    /// Bucketing grid `[columns, rows]`.
    #[serde(default, deserialize_with = "crate::spec::exact::option")]
    pub grid: Option<[usize; 2]>,
    /// Pyramid level of corner detection.
    pub detect_level: Option<usize>,
    /// Detection border (px).
    pub border_px: Option<u32>,
    /// KLT window side (odd, px).
    pub window_px: Option<usize>,
    /// Coarsest pyramid level.
    pub max_level: Option<usize>,
    /// KLT iterations per level.
    pub max_iterations: Option<usize>,
    /// KLT convergence threshold (px).
    pub epsilon_px: Option<f64>,
    /// KLT minimum structure.
    pub min_eigen: Option<f64>,
    /// Gain/offset-invariant patch matching.
    pub normalize_patches: Option<bool>,
    /// Histogram equalization.
    pub equalize: Option<bool>,
    /// Refinement against each track's first patch.
    pub anchor_refinement: Option<bool>,
    /// Largest refinement step (px).
    pub anchor_max_shift_px: Option<f64>,
    /// Flow-back check.
    pub flow_back: Option<bool>,
    /// Flow-back tolerance (px).
    pub flow_back_px: Option<f64>,
    /// Stereo matching.
    pub stereo: Option<bool>,
    /// Epipolar tolerance (px).
    pub epipolar_px: Option<f64>,
    /// RANSAC.
    pub ransac: Option<bool>,
    /// RANSAC threshold (px).
    pub ransac_threshold_px: Option<f64>,
    /// RANSAC confidence.
    pub ransac_confidence: Option<f64>,
    /// RANSAC hypothesis cap.
    pub ransac_max_iterations: Option<usize>,
    /// Gyro-predicted KLT starts.
    pub gyro_prediction: Option<bool>,
}

impl TrackerSpec {
    /// The tracker configuration (RANSAC seeded from the scenario seed); on a bad value, the
    /// field's name and why.
    pub fn config(&self, seed: u64) -> Result<TrackerConfig, (&'static str, String)> {
        let d = TrackerConfig::default();
        let c = TrackerConfig {
            max_features: self.max_features.unwrap_or(d.max_features),
            min_distance_px: self.min_distance_px.unwrap_or(d.min_distance_px),
            quality_level: self.quality_level.unwrap_or(d.quality_level),
            min_corner_response: self.min_corner_response.unwrap_or(d.min_corner_response),
            grid: self.grid.unwrap_or(d.grid),
            detect_level: self.detect_level.unwrap_or(d.detect_level),
            border_px: self.border_px.unwrap_or(d.border_px),
            window_px: self.window_px.unwrap_or(d.window_px),
            max_level: self.max_level.unwrap_or(d.max_level),
            max_iterations: self.max_iterations.unwrap_or(d.max_iterations),
            epsilon_px: self.epsilon_px.unwrap_or(d.epsilon_px),
            min_eigen: self.min_eigen.unwrap_or(d.min_eigen),
            normalize_patches: self.normalize_patches.unwrap_or(d.normalize_patches),
            equalize: self.equalize.unwrap_or(d.equalize),
            anchor_refinement: self.anchor_refinement.unwrap_or(d.anchor_refinement),
            anchor_max_shift_px: self.anchor_max_shift_px.unwrap_or(d.anchor_max_shift_px),
            flow_back: self.flow_back.unwrap_or(d.flow_back),
            flow_back_px: self.flow_back_px.unwrap_or(d.flow_back_px),
            stereo: self.stereo.unwrap_or(d.stereo),
            epipolar_px: self.epipolar_px.unwrap_or(d.epipolar_px),
            ransac: self.ransac.unwrap_or(d.ransac),
            ransac_threshold_px: self.ransac_threshold_px.unwrap_or(d.ransac_threshold_px),
            ransac_confidence: self.ransac_confidence.unwrap_or(d.ransac_confidence),
            ransac_max_iterations: self
                .ransac_max_iterations
                .unwrap_or(d.ransac_max_iterations),
            gyro_prediction: self.gyro_prediction.unwrap_or(d.gyro_prediction),
            seed,
        };
        match c.validate() {
            Ok(()) => Ok(c),
            Err(TrackerError::Config { field, message }) => Err((field, message)),
            Err(e) => Err(("tracker", e.to_string())),
        }
    }
}
