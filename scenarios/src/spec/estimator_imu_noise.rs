//! `[estimator] imu_noise = "NAME"` or `"FILE.toml"`: the estimator's IMU noise model named
//! instead of written out. A name is a built-in model (`catalog/estimator_imu_noise/`), a path
//! a file relative to the scenario, such as the `estimator_imu_noise.toml` that `vio imu-model
//! --gt` writes. The file holds the keys of `[estimator.imu_noise]`; the table it gives stands
//! where the string stood, so the estimator's own checks apply to it as to a written table.

use super::named_model::{BuiltIn, model_text};
use super::{Origin, SpecError};
use crate::catalog;

/// The key this module resolves.
const KEY: &str = "estimator.imu_noise";

/// `estimator` with a string `imu_noise` replaced by the table it names (anything else left
/// as it is, for the estimator's settings to check).
pub(crate) fn resolve(
    estimator: &toml::Table,
    origin: &Origin,
    text: &str,
    file: &str,
) -> Result<toml::Table, SpecError> {
    let mut out = estimator.clone();
    let Some(toml::Value::String(value)) = estimator.get("imu_noise") else {
        return Ok(out);
    };
    let err = |m: String| SpecError::at(file, text, KEY, m);
    let built_in = BuiltIn {
        kind: "estimator IMU noise model",
        get: catalog::estimator_imu_noise,
        names: catalog::estimator_imu_noise_names,
    };
    let (source, body) = model_text(origin, value, &built_in).map_err(err)?;
    let table: toml::Table = body
        .parse()
        .map_err(|e: toml::de::Error| err(format!("{source}: {}", e.message().trim())))?;
    // Checked here so that a bad key or value names the file it is in.
    let model: estimator::ImuNoiseModel =
        serde_path_to_error::deserialize(toml::Value::Table(table.clone())).map_err(|e| {
            let key = e.path().to_string();
            err(format!(
                "{source}: {key}: {}",
                e.into_inner().message().trim()
            ))
        })?;
    for (key, v) in model.entries() {
        if let Some(v) = v
            && !(v.is_finite() && v > 0.0)
        {
            return Err(err(format!("{source}: {key} = {v}: expected a number > 0")));
        }
    }
    out.insert("imu_noise".into(), toml::Value::Table(table));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::super::Scenario;
    use super::*;

    fn with_estimator(table: &str) -> String {
        let text = catalog::get(catalog::DEFAULT).unwrap().text;
        format!("{text}\n[estimator]\n{table}\n")
    }

    fn in_file(dir: &Path, name: &str, text: &str) -> Origin {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        Origin::File(p)
    }

    #[test]
    fn a_name_a_file_and_a_table_give_the_same_model() {
        let dir = tempfile::tempdir().unwrap();
        let keys = catalog::estimator_imu_noise("euroc_mav").unwrap();
        std::fs::write(dir.path().join("noise.toml"), keys).unwrap();
        let assumed = |table: &str| {
            let text = with_estimator(table);
            let origin = in_file(dir.path(), "s.toml", &text);
            let s = Scenario::parse("s", origin, &text).unwrap_or_else(|e| panic!("{e}"));
            let c = s.estimator_config().unwrap();
            c.assumed_imu_noise()
        };
        let named = assumed("imu_noise = \"euroc_mav\"");
        assert_eq!(named, assumed("imu_noise = \"noise.toml\""));
        let table: toml::Table = keys.parse().unwrap();
        let written: String = table
            .iter()
            .map(|(k, v)| format!("imu_noise.{k} = {v}\n"))
            .collect();
        assert_eq!(named, assumed(&written));
        // The model is the flight's, far above the datasheet the rig states.
        let sheet = assumed("");
        assert!(named.gyroscope_noise_density > 5.0 * sheet.gyroscope_noise_density);
        assert!(named.accelerometer_noise_density > 5.0 * sheet.accelerometer_noise_density);
        // A key left out keeps the sensor's.
        let one = assumed("imu_noise = { gyroscope_random_walk = 1e-3 }");
        assert_eq!(one.gyroscope_random_walk, 1e-3);
        assert_eq!(one.gyroscope_noise_density, sheet.gyroscope_noise_density);
    }

    #[test]
    fn a_bad_model_is_refused_naming_the_file_and_the_key() {
        let dir = tempfile::tempdir().unwrap();
        let refused = |table: &str, file: Option<&str>| {
            if let Some(f) = file {
                std::fs::write(dir.path().join("noise.toml"), f).unwrap();
            }
            let text = with_estimator(table);
            let origin = in_file(dir.path(), "s.toml", &text);
            Scenario::parse("s", origin, &text).unwrap_err().to_string()
        };
        let e = refused("imu_noise = \"nope\"", None);
        assert!(
            e.contains("estimator.imu_noise") && e.contains("euroc_mav"),
            "{e}"
        );
        let e = refused("imu_noise = \"missing.toml\"", None);
        assert!(
            e.contains("missing.toml") && e.contains("cannot read"),
            "{e}"
        );
        let e = refused(
            "imu_noise = \"noise.toml\"",
            Some("gyroscope_noise_densty = 1e-3\n"),
        );
        assert!(
            e.contains("noise.toml") && e.contains("gyroscope_noise_densty"),
            "{e}"
        );
        let e = refused(
            "imu_noise = \"noise.toml\"",
            Some("accelerometer_noise_density = -1.0\n"),
        );
        assert!(e.contains("noise.toml") && e.contains("> 0"), "{e}");
        let e = refused("imu_noise = { gyroscope_noise_density = 0.0 }", None);
        assert!(e.contains("imu_noise.gyroscope_noise_density"), "{e}");
    }
}
