//! A model a scenario key names instead of writing it out: a built-in one from the catalog by
//! its name, or a `.toml` file relative to the scenario (`rig.imu.error_model`,
//! `rig.cameras[i].tracker_error`; at the table stage, before there is a `Scenario`,
//! `estimator.imu_noise` and the sensors' `preset`).

use super::{Origin, Scenario, SpecError};

/// Whether a value names a built-in model rather than a file (no `.toml`, no `/`).
pub(super) fn is_preset_name(value: &str) -> bool {
    !value.ends_with(".toml") && !value.contains('/') && !value.contains('\\')
}

/// Where a built-in model of one kind is found: its name in errors, the catalog lookup, the
/// names to list when one is unknown.
pub(super) struct BuiltIn {
    /// What the model is, for errors ("IMU error model").
    pub kind: &'static str,
    /// The model's text by name.
    pub get: fn(&str) -> Option<&'static str>,
    /// Every built-in name.
    pub names: fn() -> Vec<&'static str>,
}

/// The source (`preset:NAME` or the file's path) and text of the model `value` names: a
/// built-in one, or a file read through `origin`; the message says why not.
pub(super) fn model_text(
    origin: &Origin,
    value: &str,
    built_in: &BuiltIn,
) -> Result<(String, String), String> {
    if is_preset_name(value) {
        let text = (built_in.get)(value).ok_or_else(|| {
            format!(
                "no built-in {} `{value}` (built in: {}; or name a .toml file)",
                built_in.kind,
                (built_in.names)().join(", ")
            )
        })?;
        Ok((format!("preset:{value}"), text.to_string()))
    } else {
        Ok((
            origin.path_of(value).display().to_string(),
            origin.read(value)?,
        ))
    }
}

impl Scenario {
    /// [`model_text`] for `value` at `key`, its error naming the key.
    pub(super) fn named_model_text(
        &self,
        key: &str,
        value: &str,
        built_in: &BuiltIn,
    ) -> Result<(String, String), SpecError> {
        model_text(&self.origin, value, built_in).map_err(|m| self.error(key, m))
    }
}
