//! Settings tables embedded whole: a scenario's `[estimator]` or `[camera.tracker]` table laid
//! over the owning crate's serialized defaults, then deserialized into that crate's type.
//!
//! Serde fills a missing key from the type's own default, which for a nested table
//! (`[estimator.solver]`) is the nested type's default rather than the value the outer
//! configuration starts from. Laying the file's keys over the serialized defaults, table by
//! table, keeps every unset key at the configuration's default at any depth, and the type's
//! `deny_unknown_fields` still rejects a misspelt key.

use estimator::EstimatorConfig;
use estimator::frontend::TrackerConfig;
use serde::Serialize;
use serde::de::DeserializeOwned;

use super::error::path_string;
use super::{Origin, SpecError, estimator_imu_noise};

/// `defaults` with the keys of `table` laid over them; `key` is the table's path in the
/// scenario (`estimator`), `text` and `file` locate an error.
pub(crate) fn overlay<T: Serialize + DeserializeOwned>(
    defaults: &T,
    table: &toml::Table,
    key: &str,
    text: &str,
    file: &str,
) -> Result<T, SpecError> {
    let mut merged = toml::Table::try_from(defaults).map_err(|e| SpecError {
        file: file.into(),
        key: key.into(),
        line: None,
        message: format!("cannot serialize the defaults: {e}"),
    })?;
    lay_over(&mut merged, table);
    serde_path_to_error::deserialize(toml::Value::Table(merged)).map_err(|e| {
        let path = path_string(e.path());
        let full = if path.is_empty() {
            key.to_string()
        } else {
            format!("{key}.{path}")
        };
        SpecError::at(file, text, &full, e.into_inner().message().trim())
    })
}

/// The estimator's and the image front end's settings: the `[estimator]` and
/// `[camera.tracker]` tables laid over their defaults (a scenario's, or `vio euroc --settings`;
/// `origin` resolves a named `estimator.imu_noise` model).
pub(crate) fn estimator_and_tracker(
    estimator: &toml::Table,
    tracker: &toml::Table,
    origin: &Origin,
    text: &str,
    file: &str,
) -> Result<(EstimatorConfig, TrackerConfig), SpecError> {
    let estimator = estimator_imu_noise::resolve(estimator, origin, text, file)?;
    Ok((
        overlay(
            &EstimatorConfig::settings_default(),
            &estimator,
            "estimator",
            text,
            file,
        )?,
        overlay(
            &TrackerConfig::default(),
            tracker,
            "camera.tracker",
            text,
            file,
        )?,
    ))
}

/// Replaces the values of `base` by those of `top`, descending into tables present in both.
pub(super) fn lay_over(base: &mut toml::Table, top: &toml::Table) {
    for (k, v) in top {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(t)) => lay_over(b, t),
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}
