//! The scenario file's camera types, as written: `[[rig.cameras]]` — model, intrinsics,
//! extrinsic, noise, and the errors a real camera has (`calibration_error`, `intrinsics_error`,
//! `rolling_shutter`). Re-exported by [`super::schema`].

use serde::Deserialize;

use super::exact;

/// Camera projection models.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum ModelSpec {
    /// Pinhole with radial-tangential distortion: `distortion = [k1, k2, p1, p2]`.
    PinholeRadtan,
    /// Kannala-Brandt equidistant fisheye: `distortion = [k1, k2, k3, k4]`.
    KannalaBrandt,
    /// Mei unified model: `xi` and `distortion = [k1, k2, p1, p2]`.
    Mei,
    /// Double sphere: `xi` and `alpha`, no distortion.
    DoubleSphere,
}

/// One `[[rig.cameras]]` entry.
#[allow(non_snake_case)]
#[derive(Clone, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// A built-in camera module (`catalog/sensors/camera/`, each with its sources) or a
    /// `.toml` file relative to the scenario, laid under this entry: its keys fill what the
    /// entry leaves unset (`sensor_preset.rs`).
    pub preset: Option<String>,
    /// Sensor name (selects its random streams); default `cam<index>`.
    pub name: Option<String>,
    /// Projection model.
    pub model: ModelSpec,
    /// `[width, height]` (px).
    #[serde(deserialize_with = "exact::array")]
    pub resolution: [u32; 2],
    /// `[fx, fy, cx, cy]` (px).
    #[serde(deserialize_with = "exact::array")]
    pub intrinsics: [f64; 4],
    /// Distortion coefficients (see [`ModelSpec`]).
    #[serde(default)]
    pub distortion: Vec<f64>,
    /// Mei and double-sphere ξ.
    pub xi: Option<f64>,
    /// Double-sphere α.
    pub alpha: Option<f64>,
    /// Extrinsic camera-to-body transform.
    pub T_b_c: ExtrinsicSpec,
    /// Feature noise standard deviation (px): drawn independently per observation by a
    /// feature-level camera without `tracker_error`, and the estimator's default pixel model.
    pub pixel_sigma_px: f64,
    /// A feature-level camera's error drawn as an image tracker's in motion, in place of
    /// the Gaussian of `pixel_sigma_px` (which stays the estimator's default model): a
    /// built-in model's name, a `.toml` file, or the table itself (see
    /// [`super::tracker_error_model`]).
    #[schemars(
        with = "Option<super::key_listing::NameOrTable<sim::tracker_error::TrackerErrorModel>>"
    )]
    pub tracker_error: Option<toml::Value>,
    /// Most features per frame (default 150).
    pub max_features: Option<usize>,
    /// Nearest visible depth (m, default 0.1).
    pub min_depth_m: Option<f64>,
    /// Farthest visible depth (m, default 40).
    pub max_depth_m: Option<f64>,
    /// Longest track (frames; the landmark then rests as many frames in this camera); default
    /// unlimited, as the image front end's tracks (lost only when the feature is).
    pub max_track_length: Option<u32>,
    /// The estimator starts from a wrong extrinsic for this camera (the simulator keeps
    /// `T_b_c`): for online calibration studies (`estimator.estimate_extrinsics`).
    pub calibration_error: Option<CalibrationErrorSpec>,
    /// The estimator starts from wrong intrinsics for this camera (the simulator keeps
    /// `intrinsics` and `distortion`): what a calibration error costs.
    pub intrinsics_error: Option<IntrinsicsErrorSpec>,
    /// A rolling shutter: the rows are read out over `readout_ms` after the frame's stamp
    /// (the first row's time); without it, a global shutter.
    pub rolling_shutter: Option<RollingShutterSpec>,
}

/// `intrinsics_error = { focal_percent = [0.5, 0.5], principal_point_px = [2.0, -1.0],
/// distortion = [0.01, 0.0, 0.0, 0.0] }`: the estimator's focal lengths are the true ones
/// times `1 + percent / 100`, its principal point shifted by the pixels given, its distortion
/// coefficients offset by `distortion` (one per coefficient, or none). Every key defaults to no
/// error.
#[derive(Clone, Debug, Default, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct IntrinsicsErrorSpec {
    /// `[fx, fy]` errors (%).
    #[serde(default, deserialize_with = "exact::array")]
    pub focal_percent: [f64; 2],
    /// `[cx, cy]` shifts (px).
    #[serde(default, deserialize_with = "exact::array")]
    pub principal_point_px: [f64; 2],
    /// Offsets of the distortion coefficients.
    #[serde(default)]
    pub distortion: Vec<f64>,
}

/// `rolling_shutter = { readout_ms = 20.0, direction = "top_to_bottom" }`: row `r` of an image
/// `h` rows tall is exposed `readout_ms · r / h` after the stamp, counted from the top
/// (`top_to_bottom`, the default) or the bottom (`bottom_to_top`). The simulator exposes each
/// row at its time; the estimator models it with `estimator.model_rolling_shutter` (default on).
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RollingShutterSpec {
    /// Time from the first row to one past the last (ms), at most the frame period.
    pub readout_ms: f64,
    /// Which row is read first.
    #[serde(default)]
    #[schemars(with = "String")]
    pub direction: estimator::camera::ReadoutDirection,
}

impl RollingShutterSpec {
    /// The camera's readout.
    pub fn readout(&self) -> estimator::camera::RollingShutter {
        estimator::camera::RollingShutter {
            readout_s: self.readout_ms * 1e-3,
            direction: self.direction,
        }
    }
}

/// `calibration_error = { rotation_deg = [x, y, z], translation_m = [x, y, z] }`: the
/// estimator's `T_b_c` is the true one rotated by the rotation vector (degrees, body frame:
/// `R = Exp(δθ)·R_true`) and shifted by the translation (m, body frame).
#[derive(Clone, Copy, Debug, Default, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CalibrationErrorSpec {
    /// Rotation vector (deg, body frame).
    #[serde(default, deserialize_with = "exact::array")]
    pub rotation_deg: [f64; 3],
    /// Translation (m, body frame).
    #[serde(default, deserialize_with = "exact::array")]
    pub translation_m: [f64; 3],
}

/// A rigid transform: translation plus exactly one of a rotation matrix (rows) or a Hamilton
/// quaternion `[qx, qy, qz, qw]`.
#[derive(Clone, Copy, Debug, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ExtrinsicSpec {
    /// Translation (m).
    #[serde(deserialize_with = "exact::array")]
    pub translation_m: [f64; 3],
    /// Rotation matrix, rows.
    #[serde(default, deserialize_with = "exact::matrix")]
    pub rotation: Option<[[f64; 3]; 3]>,
    /// Rotation quaternion `[qx, qy, qz, qw]`.
    #[serde(default, deserialize_with = "exact::option")]
    pub quaternion_xyzw: Option<[f64; 4]>,
}
