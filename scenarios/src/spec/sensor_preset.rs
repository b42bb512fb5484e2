//! `preset = "NAME"` inside `[rig.imu]` or a `[[rig.cameras]]` entry: a built-in sensor model
//! (`catalog/sensors/imu/NAME.toml`, `catalog/sensors/camera/NAME.toml`, each with its sources)
//! or a `.toml` file relative to the scenario, laid under that one sensor's table: every key
//! the preset sets that the table does not is taken from it, so the table can override any of
//! them (its own rate, a camera's `T_b_c`). A sweep changes the sensor by setting the whole
//! table (`keys = ["rig.imu"]`, `values = [{ preset = "bmi160" }, …]`); a file without a
//! sensor `preset` is read as it always was.

use super::error::{deserialize_toml, line_of_key};
use super::named_model::{BuiltIn, model_text};
use super::overlay::lay_over;
use super::{Origin, SpecError};
use crate::catalog;

const IMU: BuiltIn = BuiltIn {
    kind: "IMU model",
    get: catalog::imu_preset,
    names: catalog::imu_preset_names,
};

const CAMERA: BuiltIn = BuiltIn {
    kind: "camera module",
    get: catalog::camera_preset,
    names: catalog::camera_preset_names,
};

/// `root` (the file's table, preset-expanded, or `None` to read `text`) with every sensor
/// preset laid under its table; `None` when `root` was `None` and no sensor names a preset.
pub(super) fn expand(
    root: Option<toml::Table>,
    origin: &Origin,
    text: &str,
    file: &str,
) -> Result<Option<toml::Table>, SpecError> {
    let mut table = match root {
        Some(t) => t,
        None => {
            let t: toml::Table = deserialize_toml(text, file)?;
            if !has_sensor_preset(&t) {
                return Ok(None);
            }
            t
        }
    };
    let Some(toml::Value::Table(rig)) = table.get_mut("rig") else {
        return Ok(Some(table));
    };
    if let Some(toml::Value::Table(imu)) = rig.get_mut("imu") {
        expand_one(imu, &IMU, "rig.imu", origin, text, file)?;
    }
    if let Some(toml::Value::Array(cams)) = rig.get_mut("cameras") {
        for (i, c) in cams.iter_mut().enumerate() {
            if let toml::Value::Table(c) = c {
                expand_one(c, &CAMERA, &format!("rig.cameras[{i}]"), origin, text, file)?;
            }
        }
    }
    Ok(Some(table))
}

/// Whether any sensor table of `t` names a preset.
fn has_sensor_preset(t: &toml::Table) -> bool {
    let Some(rig) = t.get("rig").and_then(toml::Value::as_table) else {
        return false;
    };
    let names = |v: Option<&toml::Value>| {
        v.and_then(toml::Value::as_table)
            .is_some_and(|s| s.contains_key("preset"))
    };
    names(rig.get("imu"))
        || rig
            .get("cameras")
            .and_then(toml::Value::as_array)
            .is_some_and(|cams| cams.iter().any(|c| names(Some(c))))
}

/// One sensor's table with its preset laid under it (the `preset` key kept, for the record).
fn expand_one(
    sensor: &mut toml::Table,
    kind: &BuiltIn,
    key: &str,
    origin: &Origin,
    text: &str,
    file: &str,
) -> Result<(), SpecError> {
    let at = |m: String| SpecError {
        file: file.into(),
        key: format!("{key}.preset"),
        line: line_of_key(text, &format!("{key}.preset")),
        message: m,
    };
    let name = match sensor.get("preset") {
        None => return Ok(()),
        Some(toml::Value::String(n)) => n.clone(),
        Some(other) => {
            return Err(at(format!(
                "expected the name of a built-in {} or a .toml file, got a {}",
                kind.kind,
                other.type_str()
            )));
        }
    };
    let (source, body) = model_text(origin, &name, kind).map_err(at)?;
    let mut merged: toml::Table = deserialize_toml(&body, &source)?;
    if merged.contains_key("preset") {
        return Err(at(format!(
            "{source}: a sensor preset cannot name another preset"
        )));
    }
    lay_over(&mut merged, sensor);
    *sensor = merged;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::{Origin, Scenario};
    use crate::catalog;

    fn with_imu_table(table: &str) -> String {
        let text = catalog::get("room_figure8_stereo_imu").unwrap().text;
        let start = text.find("[rig.imu]").expect("an imu table");
        let end = text[start + 1..]
            .find("\n[")
            .map_or(text.len(), |e| start + 1 + e);
        format!("{}{table}{}", &text[..start], &text[end..])
    }

    /// A named IMU model fills the table; the table's own keys win; every built-in one
    /// loads and validates.
    #[test]
    fn an_imu_preset_fills_the_table_and_the_table_wins() {
        for name in catalog::imu_preset_names() {
            let text = with_imu_table(&format!("[rig.imu]\npreset = \"{name}\"\n"));
            let s = Scenario::parse("t", Origin::Catalog, &text)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(s.spec.rig.imu.gyro_range_rad_s.is_some(), "{name}");
        }
        let text = with_imu_table("[rig.imu]\npreset = \"bmi160\"\nrate_hz = 400.0\n");
        let s = Scenario::parse("t", Origin::Catalog, &text).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.spec.rig.imu.rate_hz, 400.0);
        assert_eq!(s.spec.rig.imu.gyroscope_noise_density, 1.6e-4);
        assert_eq!(
            s.spec.rig.imu.accel_range_m_s2,
            Some(16.0 * super::super::units::STANDARD_GRAVITY)
        );
        let e = Scenario::parse(
            "t",
            Origin::Catalog,
            &with_imu_table("[rig.imu]\npreset = \"bmi16\"\n"),
        )
        .unwrap_err();
        assert_eq!(e.key, "rig.imu.preset");
        assert!(e.message.contains("adis16448, bmi160"), "{e}");
    }

    /// Every built-in camera module loads under a camera that gives only its pose (and, for
    /// a module without a lens, its intrinsics).
    #[test]
    fn every_camera_preset_loads_by_name() {
        let base = catalog::get("room_figure8_stereo_imu").unwrap().text;
        for name in catalog::camera_preset_names() {
            let body = catalog::camera_preset(name).unwrap();
            let module: toml::Table = body.parse().unwrap();
            let lens = if module.contains_key("intrinsics") {
                String::new()
            } else {
                "intrinsics = [900.0, 900.0, 640.0, 512.0]\ndistortion = [0.0, 0.0, 0.0, 0.0]\n"
                    .into()
            };
            let mut doc: toml::Table = base.parse().unwrap();
            let cams = doc["rig"]["cameras"].as_array_mut().unwrap();
            for c in cams.iter_mut() {
                let pose = c["T_b_c"].clone();
                let mut t: toml::Table = format!("preset = \"{name}\"\n{lens}").parse().unwrap();
                t.insert("T_b_c".into(), pose);
                *c = toml::Value::Table(t);
            }
            let text = toml::to_string(&doc).unwrap();
            let s = Scenario::parse("t", Origin::Catalog, &text)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            let w = s
                .world_config(None, Some(1.0))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(w.rig.map(|r| r.cameras.len()), Some(2), "{name}");
        }
    }
}
