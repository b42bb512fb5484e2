//! Datasheet units in a scenario file: a file whose IMU is written in datasheet units runs to
//! the same bytes as its SI twin, and a unit of the wrong dimension is refused naming the key.

use crate::common;

use common::{default_text, scratch, vio, vio_ok, write};
use scenarios::spec::units::{Quantity, parse};

/// The default scenario with its `[rig.imu]` table replaced by `imu`.
fn with_imu(imu: &str) -> String {
    let text = default_text(3.0);
    let start = text.find("[rig.imu]").expect("an IMU table");
    let end = text[start + 1..]
        .find("\n[")
        .map_or(text.len(), |e| start + 2 + e);
    format!("{}{imu}\n{}", &text[..start], &text[end..])
}

#[test]
fn a_scenario_in_datasheet_units_runs_to_the_same_bytes_as_its_si_twin() {
    let datasheet = [
        ("rate_hz", "200 Hz", Quantity::Frequency),
        (
            "gyroscope_noise_density",
            "0.58 deg/sqrt(h)",
            Quantity::GyroDensity,
        ),
        (
            "accelerometer_noise_density",
            "204 ug/sqrt(Hz)",
            Quantity::AccelDensity,
        ),
        (
            "gyroscope_random_walk",
            "240 deg/h/sqrt(h)",
            Quantity::GyroRandomWalk,
        ),
        (
            "accelerometer_random_walk",
            "0.3 mg/sqrt(s)",
            Quantity::AccelRandomWalk,
        ),
        ("gyro_range_rad_s", "1000 deg/s", Quantity::AngularRate),
        ("accel_range_m_s2", "18 g", Quantity::Acceleration),
    ];
    let mut in_units = String::from("[rig.imu]\n");
    let mut in_si = String::from("[rig.imu]\n");
    for (key, value, q) in datasheet {
        in_units += &format!("{key} = \"{value}\"\n");
        // The twin's number as TOML writes an f64: the shortest text that reads back exact.
        in_si += &format!("{key} = {:?}\n", parse(value, q).unwrap());
    }
    // The SI values are the ones worked by hand (to 1e-12): 0.58 °/√h is 1.687e-4 rad/s/√Hz.
    assert!((parse("0.58 deg/sqrt(h)", Quantity::GyroDensity).unwrap() - 1.68715e-4).abs() < 1e-9);
    let dir = scratch("datasheet-units");
    let mut outputs = Vec::new();
    for (tag, imu) in [("units", &in_units), ("si", &in_si)] {
        let sub = dir.path().join(tag);
        std::fs::create_dir_all(&sub).unwrap();
        let file = write(&sub, "scenario.toml", &with_imu(imu));
        let out = sub.join("out");
        vio_ok(&[
            "run",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let estimate = std::fs::read(out.join("estimate.tum")).unwrap();
        let text = std::fs::read_to_string(out.join("report.json")).unwrap();
        // Everything but the wall-clock timings, which no two runs share.
        let mut report: serde_json::Value = serde_json::from_str(&text).unwrap();
        report.as_object_mut().unwrap().remove("timing_ms");
        outputs.push((estimate, report));
    }
    assert!(!outputs[0].0.is_empty());
    assert_eq!(outputs[0].0, outputs[1].0, "estimate.tum differs");
    assert_eq!(outputs[0].1, outputs[1].1, "report.json differs");
}

#[test]
fn a_unit_of_the_wrong_dimension_is_refused_naming_the_key() {
    let dir = scratch("datasheet-units-bad");
    for (value, want) in [
        ("0.58 deg/h", "this key wants angle·time^-0.5"),
        ("0.58 furlong/sqrt(h)", "unknown unit `furlong`"),
        ("0.58", "a string needs a unit"),
    ] {
        let text = with_imu(&format!(
            "[rig.imu]\nrate_hz = 200.0\ngyroscope_noise_density = \"{value}\"\n\
             accelerometer_noise_density = 2e-3\ngyroscope_random_walk = 1.9e-5\n\
             accelerometer_random_walk = 3e-3\n"
        ));
        let file = write(dir.path(), "bad.toml", &text);
        let out = vio(&[
            "run",
            file.to_str().unwrap(),
            "--out",
            dir.path().join("o").to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{value}: {stderr}");
        assert!(
            stderr.contains("rig.imu.gyroscope_noise_density") && stderr.contains(want),
            "{value}: {stderr}"
        );
        assert!(!dir.path().join("o").exists());
    }
}
