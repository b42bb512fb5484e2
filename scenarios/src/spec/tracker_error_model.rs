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

use sim::tracker_error::TrackerErrorModel;

use super::error::deserialize_table;
use super::named_model::BuiltIn;
use super::schema::{CameraMode, FrontendSpec};
use super::{Scenario, SpecError};
use crate::catalog;

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
        let (source, model) = match value {
            toml::Value::String(name) => {
                let (file, text) = self.named_model_text(
                    &key,
                    name,
                    &BuiltIn {
                        kind: "tracker error model",
                        get: catalog::tracker_error,
                        names: catalog::tracker_error_names,
                    },
                )?;
                // A model file is the table plus the `description` saying what it is.
                let mut table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
                    self.error(&key, format!("{file}: {}", e.message().trim()))
                })?;
                if !matches!(table.remove("description"), Some(toml::Value::String(_))) {
                    return Err(self.error(
                        &key,
                        format!("{file}: expected a `description` saying what the model is"),
                    ));
                }
                let model: TrackerErrorModel = deserialize_table(table, &text, &file)
                    .map_err(|e| self.error(&key, format!("in the tracker error model: {e}")))?;
                (format!("{file}: "), model)
            }
            toml::Value::Table(t) => {
                let model: TrackerErrorModel = serde_path_to_error::deserialize(
                    toml::Value::Table(t.clone()),
                )
                .map_err(|e| {
                    let path = e.path().to_string();
                    let at = if path == "." {
                        key.clone()
                    } else {
                        format!("{key}.{path}")
                    };
                    self.error(&at, e.into_inner().message().trim().to_string())
                })?;
                (String::new(), model)
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
