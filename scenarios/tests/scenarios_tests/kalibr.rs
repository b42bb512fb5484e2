//! Kalibr rigs: the EuRoC calibration as Kalibr files (`tests/fixtures/kalibr`, written from
//! the dataset's own `sensor.yaml` files) gives the same rig as the catalog's hand-written EuRoC
//! scenario, and malformed files give file, key and line.

use crate::common;

use std::path::{Path, PathBuf};

use scenarios::spec::Scenario;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/kalibr")
}

/// The replay catalog scenario with its rig replaced by `rig.kalibr`, written next to copies of
/// the fixtures (`camchain` text given).
fn scenario_with(tag: &str, camchain: &str, imu_keys: &str) -> Result<Scenario, String> {
    // Kept: the scenario reads its rig files from there.
    let dir = common::scratch(&format!("kalibr-{tag}")).keep();
    std::fs::create_dir_all(dir.join("data")).unwrap();
    std::fs::write(dir.join("camchain.yaml"), camchain).unwrap();
    std::fs::copy(fixtures().join("euroc-imu.yaml"), dir.join("imu.yaml")).unwrap();
    std::fs::write(
        dir.join("data/euroc_V2_02_medium_20s.txt"),
        scenarios::catalog::data("data/euroc_V2_02_medium_20s.txt").unwrap(),
    )
    .unwrap();
    let base = scenarios::catalog::get("room_replay_v2_02_stereo_imu")
        .unwrap()
        .text;
    let head = &base[..base.find("# EuRoC's calibration").unwrap()];
    let tail = &base[base.find("[expectations]").unwrap()..];
    let text = format!("{head}kalibr = {{ camchain = \"camchain.yaml\"{imu_keys} }}\n\n{tail}");
    let file = dir.join("kalibr.toml");
    std::fs::write(&file, text).unwrap();
    let s = Scenario::load(file.to_str().unwrap()).map_err(|e| e.to_string());
    let _ = std::fs::remove_dir_all(dir);
    s
}

/// The `imu` key of `rig.kalibr`.
const IMU: &str = ", imu = \"imu.yaml\"";

fn camchain() -> String {
    std::fs::read_to_string(fixtures().join("euroc-camchain-imucam.yaml")).unwrap()
}

#[test]
fn the_euroc_kalibr_files_give_the_catalog_rig() {
    let k = scenario_with("ok", &camchain(), ", imu = \"imu.yaml\"").unwrap();
    let c = Scenario::load("room_replay_v2_02_stereo_imu").unwrap();
    let (ek, ec) = (k.estimator_config().unwrap(), c.estimator_config().unwrap());
    assert_eq!(ek.cameras.len(), 2);
    for i in 0..2 {
        let (a, b) = (&ek.cameras[i], &ec.cameras[i]);
        // T_cam_imu inverted back to T_b_c.
        assert!(
            (a.T_b_c.p - b.T_b_c.p).norm() < 1e-9,
            "{i}: {} vs {}",
            a.T_b_c.p,
            b.T_b_c.p
        );
        assert!(a.T_b_c.q.angle_to(&b.T_b_c.q) < 1e-9);
        for p in [
            nalgebra::Vector3::new(0.1, -0.2, 1.0),
            nalgebra::Vector3::new(-0.4, 0.3, 1.0),
        ] {
            let (u, v) = (a.model.project(&p).unwrap(), b.model.project(&p).unwrap());
            assert!((u - v).norm() < 1e-9, "{i}: {u} vs {v}");
        }
        assert_eq!(a.pixel_sigma, b.pixel_sigma);
    }
    assert_eq!(ek.imu_noise, ec.imu_noise);
    assert_eq!(k.spec.rig.imu.rate_hz, 200.0);
}

#[test]
fn malformed_kalibr_files_name_file_key_and_line() {
    let no_t = camchain().replacen("  T_cam_imu:", "  T_cam_imu_x:", 2);
    let e = scenario_with("no-t", &no_t, "").unwrap_err();
    assert!(
        e.contains("camchain.yaml") && e.contains("cam0.T_cam_imu"),
        "{e}"
    );
    let eucm = camchain().replacen("camera_model: pinhole", "camera_model: eucm", 1);
    let e = scenario_with("eucm", &eucm, "").unwrap_err();
    let line = eucm.lines().position(|l| l.contains("eucm")).unwrap() + 1;
    assert!(
        e.contains(&format!("camchain.yaml:{line}")) && e.contains("cam0.camera_model"),
        "{e}"
    );
    let skew = camchain().replacen("[0.0148655429818,", "[0.5,", 1);
    let e = scenario_with("skew", &skew, "").unwrap_err();
    assert!(e.contains("not a rotation matrix"), "{e}");
    // A last row other than [0, 0, 0, 1] is no rigid transform, named at its own line.
    let projective = camchain().replacen("  - [0.0, 0.0, 0.0, 1.0]", "  - [5.0, 6.0, 7.0, 8.0]", 1);
    let e = scenario_with("projective", &projective, "").unwrap_err();
    let line = projective
        .lines()
        .position(|l| l.contains("[5.0, 6.0, 7.0, 8.0]"))
        .unwrap()
        + 1;
    assert!(
        e.contains(&format!("camchain.yaml:{line}"))
            && e.contains("cam0.T_cam_imu")
            && e.contains("[0, 0, 0, 1]"),
        "{e}"
    );
    let short = camchain().replacen(
        "intrinsics: [458.654, 457.296, 367.215, 248.375]",
        "intrinsics: [458.654]",
        1,
    );
    let e = scenario_with("short", &short, "").unwrap_err();
    assert!(
        e.contains("cam0.intrinsics") && e.contains("needs 4"),
        "{e}"
    );
    // Values the scenario's own checks refuse are reported at the Kalibr file's line, quoted
    // as written there (not at a line of the scenario file that does not exist, not as 0).
    let at = |text: &str, needle: &str| text.lines().position(|l| l.contains(needle)).unwrap() + 1;
    let negative = camchain().replacen("resolution: [752, 480]", "resolution: [-752, 480]", 1);
    let e = scenario_with("negative", &negative, IMU).unwrap_err();
    let line = at(&negative, "-752");
    assert!(
        e.contains(&format!("camchain.yaml:{line}: key `cam0.resolution`")) && e.contains("-752"),
        "{e}"
    );
    let focal = camchain().replacen("intrinsics: [458.654,", "intrinsics: [0.5,", 1);
    let e = scenario_with("focal", &focal, IMU).unwrap_err();
    let line = at(&focal, "[0.5,");
    assert!(
        e.contains(&format!("camchain.yaml:{line}: key `cam0.intrinsics`")) && e.contains("0.5"),
        "{e}"
    );
    // The exact keys `vio export` writes beside T_cam_imu: checked against it, located.
    let exported = {
        let s = Scenario::load("room_figure8_stereo_imu").unwrap();
        scenarios::export::kalibr_files(&s).unwrap().0
    };
    let key = "vio_T_b_c_translation_m: [";
    let line = exported.lines().find(|l| l.contains(key)).unwrap();
    let x = &line[line.find('[').unwrap() + 1..line.find(',').unwrap()];
    let shifted = format!("{:?}", x.parse::<f64>().unwrap() + 0.5);
    let moved = exported.replacen(line, &line.replacen(x, &shifted, 1), 1);
    let e = scenario_with("moved", &moved, IMU).unwrap_err();
    let line = at(&moved, key);
    assert!(
        e.contains(&format!(
            "camchain.yaml:{line}: key `cam0.vio_T_b_c_translation_m`"
        )) && e.contains("disagrees with `T_cam_imu` by 5.000e-1 m"),
        "{e}"
    );
    let two = exported.replacen(key, &format!("{key}1.0, 2.0]  # "), 1);
    let e = scenario_with("two", &two, IMU).unwrap_err();
    assert!(e.contains("expected 3 numbers, got 2"), "{e}");
    // A camera name that would break TOML is a name, not syntax.
    let quoted = camchain().replacen("cam0:", "cam0\"]x:", 1);
    if let Err(e) = scenario_with("quoted", &quoted, IMU) {
        assert!(e.contains("camchain.yaml"), "{e}");
    }
}

/// The `[[rig.cameras]]` and `[rig.imu]` tables the Kalibr reader makes of `vio export`'s files.
fn read_back(camchain: &str, imu: &str) -> (Vec<scenarios::spec::CameraSpec>, toml::Table) {
    let cams =
        scenarios::dataset::kalibr::cameras_toml(camchain, "camchain-imucam.yaml", 1.0).unwrap();
    let cams: toml::Table = toml::from_str(&cams).unwrap();
    let cams = cams["rig"]["cameras"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c.clone().try_into().unwrap())
        .collect();
    let imu: toml::Table =
        toml::from_str(&scenarios::dataset::kalibr::imu_toml(imu, "imu.yaml").unwrap()).unwrap();
    (cams, imu["rig"]["imu"].as_table().unwrap().clone())
}

#[test]
fn exported_kalibr_files_give_back_every_catalog_rig_exactly() {
    let mut cameras = 0;
    for name in scenarios::catalog::names() {
        let s = Scenario::load(name).unwrap();
        let (camchain, imu) = scenarios::export::kalibr_files(&s).unwrap();
        let (cams, imu) = read_back(&camchain, &imu);
        let rig = &s.spec.rig;
        // The cameras the estimator uses (a mono suite: the first), with the calibration error
        // drawn for the scenario's seed (the realistic preset's).
        let est = s.estimator_config_at(s.spec.world.seed).unwrap();
        assert_eq!(cams.len(), est.cameras.len(), "{name}");
        for (i, (got, want)) in cams.iter().zip(&rig.cameras).enumerate() {
            let at = format!("{name} cam{i}");
            assert_eq!(got.model, want.model, "{at}");
            assert_eq!(got.resolution, want.resolution, "{at}");
            assert_eq!(got.intrinsics, want.intrinsics, "{at}");
            assert_eq!(got.distortion, want.distortion, "{at}");
            assert_eq!((got.xi, got.alpha), (want.xi, want.alpha), "{at}");
            // The extrinsic the estimator starts from (a calibration error included), the
            // rotation as the scenario wrote it.
            let t = est.cameras[i].T_b_c.p;
            assert_eq!(got.T_b_c.translation_m, [t.x, t.y, t.z], "{at}");
            let drawn = rig.calibration_draw.is_some();
            match (want.T_b_c.rotation, &want.calibration_error) {
                (Some(rows), None) if !drawn => {
                    assert_eq!(got.T_b_c.rotation, Some(rows), "{at}")
                }
                // The estimator's quaternion, as it is.
                _ => {
                    let q = est.cameras[i].T_b_c.q.quaternion().coords;
                    let q = [q.x, q.y, q.z, q.w];
                    assert_eq!(got.T_b_c.quaternion_xyzw, Some(q), "{at}");
                    assert_eq!(got.T_b_c.rotation, None, "{at}");
                }
            }
            cameras += 1;
        }
        // The noise the estimator assumes: the rig's, or `[estimator.imu_noise]` over it, a
        // bias instability folded into the random walks (a Kalibr file's only way to say it).
        let f = |k: &str| imu[k].as_float().unwrap();
        let n = est.assumed_imu_noise_as_random_walks();
        if est.imu_noise_model.bias_process().is_some() {
            let own = est.assumed_imu_noise();
            assert!(
                n.gyroscope_random_walk > own.gyroscope_random_walk,
                "{name}"
            );
            assert!(
                n.accelerometer_random_walk > own.accelerometer_random_walk,
                "{name}"
            );
        }
        assert_eq!(f("rate_hz"), rig.imu.rate_hz, "{name}");
        assert_eq!(f("gyroscope_noise_density"), n.gyroscope_noise_density);
        assert_eq!(
            f("accelerometer_noise_density"),
            n.accelerometer_noise_density
        );
        assert_eq!(f("gyroscope_random_walk"), n.gyroscope_random_walk);
        assert_eq!(f("accelerometer_random_walk"), n.accelerometer_random_walk);
        if est.imu_noise_model.is_empty() {
            assert_eq!(n.gyroscope_noise_density, rig.imu.gyroscope_noise_density);
        }
    }
    assert!(cameras >= 60, "{cameras} cameras checked");
}

#[test]
fn a_kalibr_rig_written_back_reads_as_the_same_rig() {
    // EuRoC's calibration (generic rotations, translations not round in any frame): Kalibr →
    // scenario → Kalibr → scenario gives the same [[rig.cameras]] text, digit for digit.
    let k = scenario_with("back", &camchain(), IMU).unwrap();
    let first = scenarios::dataset::kalibr::cameras_toml(&camchain(), "c", 1.0).unwrap();
    let (written, imu) = scenarios::export::kalibr_files(&k).unwrap();
    let second = scenarios::dataset::kalibr::cameras_toml(&written, "c", 1.0).unwrap();
    assert_eq!(first, second);
    let fixture_imu = std::fs::read_to_string(fixtures().join("euroc-imu.yaml")).unwrap();
    assert_eq!(
        scenarios::dataset::kalibr::imu_toml(&fixture_imu, "i").unwrap(),
        scenarios::dataset::kalibr::imu_toml(&imu, "i").unwrap()
    );
}

#[test]
fn a_run_on_the_exported_kalibr_rig_gives_the_same_estimate() {
    // The figure-eight with its [[rig.cameras]] replaced by `rig.kalibr` pointing at the
    // camchain `vio export` writes: byte-identical estimates.
    let original = Scenario::load("room_figure8_stereo_imu").unwrap();
    let (camchain, _) = scenarios::export::kalibr_files(&original).unwrap();
    let dir = common::scratch("kalibr-run").keep();
    std::fs::write(dir.join("camchain-imucam.yaml"), &camchain).unwrap();
    let text = scenarios::catalog::get("room_figure8_stereo_imu")
        .unwrap()
        .text;
    let mut table: toml::Table = toml::from_str(text).unwrap();
    let rig = table["rig"].as_table_mut().unwrap();
    rig.remove("cameras");
    rig.insert(
        "kalibr".into(),
        toml::Value::Table(toml::Table::from_iter([
            (
                "camchain".to_string(),
                toml::Value::String("camchain-imucam.yaml".into()),
            ),
            ("pixel_sigma_px".to_string(), toml::Value::Float(1.0)),
        ])),
    );
    let file = dir.join("kalibr_rig.toml");
    std::fs::write(&file, toml::to_string(&table).unwrap()).unwrap();
    let from_kalibr = Scenario::load(file.to_str().unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let options = scenarios::run::RunOptions {
        duration_s: Some(4.0),
        ..Default::default()
    };
    let a = scenarios::pipeline::run_scenario(&original, &options).unwrap();
    let b = scenarios::pipeline::run_scenario(&from_kalibr, &options).unwrap();
    assert!(a.output.frames.len() > 50);
    let poses = |d: &scenarios::pipeline::ReportedRun| {
        d.output
            .frames
            .iter()
            .map(|f| (f.estimate.T_w_b.p, f.estimate.T_w_b.q))
            .collect::<Vec<_>>()
    };
    assert_eq!(poses(&a), poses(&b));
}

#[test]
fn arbitrary_rigs_survive_the_kalibr_round_trip_bit_for_bit() {
    // Generic rotations given as matrices (cam0) and as quaternions (cam1), generic
    // translations, and a rig the estimator starts off the truth (calibration error): exported
    // and read back through `rig.kalibr`, the estimator's extrinsics are the same bits.
    let mut cases = 0;
    for i in 0..24 {
        let a = f64::from(i) * 0.37 + 0.05;
        let mut s = Scenario::load("room_figure8_stereo_imu").unwrap();
        let q0 = nalgebra::UnitQuaternion::from_euler_angles(a, 0.5 * a + 0.1, -a);
        let r0 = nalgebra::Rotation3::from(q0).into_inner();
        let q1 = nalgebra::UnitQuaternion::from_euler_angles(-0.3 * a, a + 0.2, 0.7 * a);
        let c = &mut s.spec.rig.cameras;
        c[0].T_b_c.rotation = Some(std::array::from_fn(|r| std::array::from_fn(|k| r0[(r, k)])));
        c[0].T_b_c.quaternion_xyzw = None;
        c[0].T_b_c.translation_m = [0.0123 * a - 0.1, -0.055 + 0.001 * a, 0.3 / (1.0 + a)];
        c[1].T_b_c.rotation = None;
        let v = q1.quaternion().coords;
        // Written as a person would: not unit to the last bit.
        c[1].T_b_c.quaternion_xyzw = Some([v.x, v.y, v.z, v.w * (1.0 + 1e-12)]);
        c[1].T_b_c.translation_m = [0.11 / (2.0 + a), 1e-3 * a, -0.02 * a];
        if i % 3 == 2 {
            let text = format!(
                "calibration_error = {{ rotation_deg = [{}, -0.4, 0.9], translation_m = [0.01, {}, -0.003] }}",
                0.1 * a,
                -0.001 * a
            );
            c[1].calibration_error = Some(
                toml::from_str::<toml::Table>(&text).unwrap()["calibration_error"]
                    .clone()
                    .try_into()
                    .unwrap(),
            );
        }
        let want = s.estimator_config().unwrap();
        let (camchain, _) = scenarios::export::kalibr_files(&s).unwrap();
        let back = scenario_with(&format!("any-{i}"), &camchain, IMU).unwrap();
        let got = back.estimator_config().unwrap();
        for (g, w) in got.cameras.iter().zip(&want.cameras) {
            let bits = |p: &estimator::geometry::Pose| {
                let q = p.q.quaternion().coords;
                [p.p.x, p.p.y, p.p.z, q.x, q.y, q.z, q.w].map(f64::to_bits)
            };
            assert_eq!(bits(&g.T_b_c), bits(&w.T_b_c), "rig {i}");
            cases += 1;
        }
    }
    assert_eq!(cases, 48);
}

#[test]
fn the_exported_kalibr_files_carry_the_readout_the_noise_and_the_offset() {
    let setting = |s: &str| scenarios::spec::parse_setting(s).unwrap();
    let scenario = Scenario::load_with_settings(
        "room_figure8_stereo_imu",
        &[
            setting("rig.cameras[1].rolling_shutter={ readout_ms = 30.0, direction = \"bottom_to_top\" }"),
            setting("rig.cameras[1].pixel_sigma_px=0.7"),
            setting("rig.time_offset_s=0.004"),
        ],
    )
    .unwrap();
    let (camchain, _) = scenarios::export::kalibr_files(&scenario).unwrap();
    let cam1 = &camchain[camchain.find("cam1:").unwrap()..];
    let cam0 = &camchain[..camchain.find("cam1:").unwrap()];
    // 30 ms over 480 rows: 62.5 µs from a row to the next.
    for line in [
        "  line_delay_nanoseconds: 62500.0\n",
        "  vio_rolling_shutter_readout_s: 0.03\n",
        "  vio_rolling_shutter_direction: bottom_to_top\n",
        "  vio_pixel_sigma_px: 0.7\n",
        "  timeshift_cam_imu: 0.004\n",
    ] {
        assert!(cam1.contains(line), "{line}: {cam1}");
    }
    // A global shutter writes no readout.
    assert!(
        !cam0.contains("line_delay") && !cam0.contains("rolling"),
        "{cam0}"
    );
    // Read back as a rig, the files are still Kalibr files.
    scenarios::dataset::kalibr::camera_sensors(&camchain, "camchain-imucam.yaml").unwrap();
}
