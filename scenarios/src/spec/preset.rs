//! `preset = "NAME"`: a built-in sensor preset (`catalog/presets/NAME.toml`) laid under the
//! scenario file. The preset is a partial scenario; every key it sets that the file does not
//! set is taken from it, table by table, so a file can override any part of a preset. A file
//! without `preset` is read as it always was.

use super::SpecError;
use super::error::deserialize_toml;
use super::overlay::lay_over;
use crate::catalog;

/// The file's table with its preset laid under it; `None` without a `preset` key.
pub(super) fn expand(text: &str, file: &str) -> Result<Option<toml::Table>, SpecError> {
    let root: toml::Table = deserialize_toml(text, file)?;
    let name = match root.get("preset") {
        None => return Ok(None),
        Some(toml::Value::String(name)) => name,
        Some(other) => {
            return Err(SpecError::at(
                file,
                text,
                "preset",
                format!("expected a preset name, got a {}", other.type_str()),
            ));
        }
    };
    let body = catalog::preset(name).ok_or_else(|| {
        SpecError::at(
            file,
            text,
            "preset",
            format!(
                "no preset `{name}` (built in: {})",
                catalog::preset_names().join(", ")
            ),
        )
    })?;
    let mut merged: toml::Table = deserialize_toml(body, &format!("preset:{name}"))?;
    lay_over(&mut merged, &root);
    Ok(Some(merged))
}

#[cfg(test)]
mod tests {
    use super::super::{Origin, Scenario};
    use super::*;

    #[test]
    fn a_preset_fills_what_the_file_leaves_and_the_file_wins() {
        let text = catalog::get("room_replay_v2_02_stereo_imu").unwrap().text;
        let with = format!("preset = \"euroc_realistic\"\n{text}");
        let s = Scenario::parse("t", Origin::Catalog, &with).unwrap_or_else(|e| panic!("{e}"));
        assert!(s.spec.rig.imu.error_model.is_some());
        assert!(s.spec.rig.calibration_draw.is_some());
        let c = s.estimator_config().unwrap();
        assert!(!c.imu_noise_model.is_empty());
        // The file's own keys stay: its IMU densities and its seed.
        assert_eq!(s.spec.rig.imu.gyroscope_noise_density, 1.6968e-4);
        assert_eq!(s.spec.world.seed, 4);
        let e = Scenario::parse("t", Origin::Catalog, &format!("preset = \"nope\"\n{text}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("preset") && e.contains("euroc_realistic"), "{e}");
    }

    /// The estimator is told the calibration's uncertainty the preset draws its error at: the
    /// extrinsics estimated, each prior at the draw's σ (the pair against the IMU; the second
    /// camera against the first).
    #[test]
    fn the_realistic_preset_tells_the_estimator_the_calibrations_uncertainty() {
        let text = catalog::get("euroc_v1_01_realistic_stereo_imu")
            .unwrap()
            .text;
        let s = Scenario::parse("t", Origin::Catalog, text).unwrap_or_else(|e| panic!("{e}"));
        let draw = s.spec.rig.calibration_draw.as_ref().expect("a draw");
        let c = s.estimator_config().unwrap();
        assert!(c.estimate_extrinsics);
        assert_eq!(c.extrinsic_prior_sigma_deg, draw.camera_imu_rotation_deg);
        assert_eq!(c.extrinsic_prior_sigma_m, draw.camera_imu_translation_m);
        assert_eq!(
            c.extrinsic_relative_prior_sigma_deg,
            draw.stereo_rotation_deg
        );
        assert_eq!(
            c.extrinsic_relative_prior_sigma_m,
            draw.stereo_translation_m
        );
        let sigma = c.pixel_sigma_px.expect("the front end's measured pixel σ");
        assert!(sigma > 0.1 && sigma < 0.3, "{sigma}");
    }
}
