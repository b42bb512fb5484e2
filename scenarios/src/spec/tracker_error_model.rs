//! `rig.cameras[i].tracker_error`: a feature-level camera's pixel error drawn as an image
//! tracker errs in motion (`sim::tracker_error`), in place of the Gaussian of `pixel_sigma_px`.
//! The value is a built-in model's name (`catalog/tracker_error/`, fitted by the run summary's
//! `tracker error` line on rendered flights), a `.toml` file relative to the scenario, or the
//! table itself:
//!
//! ```toml
//! tracker_error = { white_px = 0.07, drift_px = 0.017, sliding_fraction = 0.04,
//!                   sliding_drift_px = 0.13, stereo_px = 0.11 }
//! ```
//!
//! Checked at the door: unknown keys, wrong types and values out of range are refused naming
//! the file the model is in and the scenario key that named it.

use serde::Deserialize;
use sim::tracker_error::TrackerErrorModel;

use super::error::deserialize_toml;
use super::imu_error_model::is_preset_name;
use super::schema::{CameraMode, FrontendSpec};
use super::{Scenario, SpecError};
use crate::catalog;

/// A tracker error model as written (all σ per axis, px).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TrackerErrorSpec {
    /// White jitter on every observation.
    white_px: f64,
    /// A slow track's random-walk drift per frame (px/√frame).
    drift_px: f64,
    /// Fraction of tracks that slide.
    sliding_fraction: f64,
    /// A sliding track's drift per frame (px/√frame).
    sliding_drift_px: f64,
    /// A stereo match's own error on top of the feature it follows.
    stereo_px: f64,
}

/// A model file: the model's keys and what it is.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TrackerErrorFile {
    #[allow(dead_code)]
    description: String,
    white_px: f64,
    drift_px: f64,
    sliding_fraction: f64,
    sliding_drift_px: f64,
    stereo_px: f64,
}

impl Scenario {
    /// Camera `i`'s tracker error model, read and checked; `None` without one.
    pub(super) fn tracker_error_model(
        &self,
        i: usize,
    ) -> Result<Option<TrackerErrorModel>, SpecError> {
        let Some(value) = &self.spec.rig.cameras[i].tracker_error else {
            return Ok(None);
        };
        let key = format!("rig.cameras[{i}].tracker_error");
        let cm = &self.spec.camera;
        if cm.mode == CameraMode::Rendered && cm.frontend == FrontendSpec::Klt {
            return Err(self.error(
                &key,
                "the image front end tracking rendered images makes its own errors: \
                 tracker_error is for feature-level tracks (camera.mode = \"features\", or \
                 camera.frontend = \"truth\")",
            ));
        }
        let (source, spec) = match value {
            toml::Value::String(name) => {
                let (file, text) = if is_preset_name(name) {
                    let text = catalog::tracker_error(name).ok_or_else(|| {
                        self.error(
                            &key,
                            format!(
                                "no built-in tracker error model `{name}` (built in: {}; or name \
                                 a .toml file)",
                                catalog::tracker_error_names().join(", ")
                            ),
                        )
                    })?;
                    (format!("preset:{name}"), text.to_string())
                } else {
                    (
                        self.data_path(name).display().to_string(),
                        self.data_file(&key, name)?,
                    )
                };
                let f: TrackerErrorFile = deserialize_toml(&text, &file)
                    .map_err(|e| self.error(&key, format!("in the tracker error model: {e}")))?;
                let spec = TrackerErrorSpec {
                    white_px: f.white_px,
                    drift_px: f.drift_px,
                    sliding_fraction: f.sliding_fraction,
                    sliding_drift_px: f.sliding_drift_px,
                    stereo_px: f.stereo_px,
                };
                (format!("{file}: "), spec)
            }
            toml::Value::Table(t) => {
                let spec: TrackerErrorSpec = serde_path_to_error::deserialize(toml::Value::Table(
                    t.clone(),
                ))
                .map_err(|e| {
                    let path = e.path().to_string();
                    let at = if path == "." {
                        key.clone()
                    } else {
                        format!("{key}.{path}")
                    };
                    self.error(&at, e.into_inner().message().trim().to_string())
                })?;
                (String::new(), spec)
            }
            other => {
                return Err(self.error(
                    &key,
                    format!(
                        "expected a model's name, a .toml file or a table, got a {}",
                        other.type_str()
                    ),
                ));
            }
        };
        let model = TrackerErrorModel {
            white_px: spec.white_px,
            drift_px: spec.drift_px,
            sliding_fraction: spec.sliding_fraction,
            sliding_drift_px: spec.sliding_drift_px,
            stereo_px: spec.stereo_px,
        };
        model.check().map_err(|(k, m)| {
            let at = if source.is_empty() {
                format!("{key}.{k}")
            } else {
                key.clone()
            };
            self.error(&at, format!("{source}{k} = {m}"))
        })?;
        Ok(Some(model))
    }
}
