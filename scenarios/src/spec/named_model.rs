//! A model a scenario key names instead of writing it out: a built-in one from the catalog by
//! its name, or a `.toml` file relative to the scenario (`rig.imu.error_model`,
//! `rig.cameras[i].tracker_error`; `estimator.imu_noise` resolves the same way at the table
//! stage).

use super::{Scenario, SpecError};

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

impl Scenario {
    /// The source (`preset:NAME` or the file's path) and text of the model `value` names at
    /// `key`: a built-in one, or a file read through the scenario's data files.
    pub(super) fn named_model_text(
        &self,
        key: &str,
        value: &str,
        built_in: &BuiltIn,
    ) -> Result<(String, String), SpecError> {
        if is_preset_name(value) {
            let text = (built_in.get)(value).ok_or_else(|| {
                self.error(
                    key,
                    format!(
                        "no built-in {} `{value}` (built in: {}; or name a .toml file)",
                        built_in.kind,
                        (built_in.names)().join(", ")
                    ),
                )
            })?;
            Ok((format!("preset:{value}"), text.to_string()))
        } else {
            Ok((
                self.data_path(value).display().to_string(),
                self.data_file(key, value)?,
            ))
        }
    }
}
