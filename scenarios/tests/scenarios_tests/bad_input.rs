//! Every malformed or extreme input the reliability issue lists, as a named regression test:
//! `vio run` exits 2 with the file and the key named (and writes nothing), never a panic or an
//! abort. Inputs that are valid but hopeless (no usable vision) run and report it: see the
//! workspace's `tests/scenario_tests/reliability.rs`.

use crate::common;

use common::{assert_bad, default_text, scratch, vio, write};
use std::path::Path;

fn with_fault(fault: &str) -> String {
    default_text(2.0) + "\n[[faults]]\n" + fault + "\n"
}

fn with_estimator(keys: &str) -> String {
    default_text(2.0) + "\n[estimator]\n" + keys + "\n"
}

#[test]
fn td_nan_and_inf_are_refused() {
    // Panicked in the estimator (`finite: NonFinite`, exit 101).
    assert_bad(
        "td-nan",
        &with_estimator("td_s = nan"),
        "estimator.td_s",
        &["NaN"],
    );
    assert_bad(
        "td-inf",
        &with_estimator("td_s = inf"),
        "estimator.td_s",
        &["inf"],
    );
}

#[test]
fn saturation_ranges_must_be_positive() {
    // Panicked in `f64::clamp` (exit 101).
    for (tag, v) in [("sat-nan", "nan"), ("sat-neg", "-1.0")] {
        let f = format!(
            "kind = \"imu_saturation\"\nstart_s = 1.0\nend_s = 1.5\ngyro_range_rad_s = {v}\naccel_range_m_s2 = 100.0"
        );
        assert_bad(tag, &with_fault(&f), "faults[0].gyro_range_rad_s", &["> 0"]);
    }
}

#[test]
fn rates_and_densities_that_exhaust_memory_are_refused_before_allocation() {
    // 6.7 GB, 2.3 GB and 2 GB before.
    let text = default_text(2.0).replacen("rate_hz = 20.0", "rate_hz = 1e9", 1);
    assert_bad("rig-rate", &text, "rig.rate_hz", &["1000000000"]);
    let text = default_text(2.0).replace("rate_hz = 200.0", "rate_hz = 1e9");
    assert_bad("imu-rate", &text, "rig.imu.rate_hz", &["a physical IMU"]);
    let text = default_text(2.0).replace("seed = 1", "seed = 1\nlandmark_density = 1e5");
    assert_bad(
        "density",
        &text,
        "world.landmark_density",
        &["landmarks", "limit"],
    );
    let text = default_text(2.0).replace("duration_s = 2.0", "duration_s = 1e9");
    assert_bad("duration", &text, "trajectory.duration_s", &["one day"]);
}

#[test]
fn replay_knot_spacings_outside_their_range_are_refused() {
    // 1e-7 tried to allocate 11 GB; 100 departed 1.48 m from the file.
    let base = scenarios::catalog::get("room_replay_v2_02_stereo_imu")
        .unwrap()
        .text;
    for (tag, v) in [("knots-tiny", "1e-7"), ("knots-huge", "100.0")] {
        let text = base.replace("knot_spacing_s = 0.04", &format!("knot_spacing_s = {v}"));
        let dir = scratch(tag);
        let dir = dir.path();
        std::fs::create_dir_all(dir.join("data")).unwrap();
        std::fs::write(
            dir.join("data/euroc_V2_02_medium_20s.txt"),
            scenarios::catalog::data("data/euroc_V2_02_medium_20s.txt").unwrap(),
        )
        .unwrap();
        let p = write(dir, "bad.toml", &text);
        let out = vio(&[
            "run",
            p.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{tag}: {err}");
        assert!(
            err.contains("trajectory.replay.knot_spacing_s"),
            "{tag}: {err}"
        );
        let _ = std::fs::remove_dir_all(dir);
    }
}

#[test]
fn impossible_cameras_are_refused() {
    let t = default_text(2.0);
    let both = |a: &str, b: &str| t.replace(a, b);
    let depth = both(
        "pixel_sigma_px = 1.0",
        "pixel_sigma_px = 1.0\nmin_depth_m = 10.0\nmax_depth_m = 1.0",
    );
    assert_bad(
        "depth",
        &depth,
        "rig.cameras[0].max_depth_m",
        &["min_depth_m < max_depth_m"],
    );
    let focal = both(
        "intrinsics = [458.654, 457.296,",
        "intrinsics = [1e-6, 1e-6,",
    );
    assert_bad("focal", &focal, "rig.cameras[0].intrinsics", &["≥ 1 px"]);
    let tiny = both("resolution = [752, 480]", "resolution = [1, 1]");
    assert_bad(
        "res-1x1",
        &tiny,
        "rig.cameras[0].resolution",
        &["[16, 16384]"],
    );
    let three = both("resolution = [752, 480]", "resolution = [752, 480, 3]");
    assert_bad(
        "res-3",
        &three,
        "rig.cameras[0].resolution",
        &["invalid length 3"],
    );
    let sigma = both("pixel_sigma_px = 1.0", "pixel_sigma_px = 1e6");
    assert_bad("sigma", &sigma, "rig.cameras[0].pixel_sigma_px", &["tenth"]);
    let baseline = both(
        "translation_m = [0.0, 0.055, 0.0]",
        "translation_m = [0.0, 0.0, 0.0]",
    )
    .replace(
        "translation_m = [0.0, -0.055, 0.0]",
        "translation_m = [0.0, 0.0, 0.0]",
    );
    assert_bad("baseline", &baseline, "rig.cameras[1].T_b_c", &["baseline"]);
    let names = t.replace("name = \"cam1\"", "name = \"cam0\"");
    assert_bad("names", &names, "rig.cameras[1].name", &["two cameras"]);
}

#[test]
fn non_finite_numbers_are_refused_where_they_are_written() {
    let t = default_text(2.0);
    let bias = t.replace(
        "initial_gyro_bias_rad_s = [0.003, -0.002, 0.0015]",
        "initial_gyro_bias_rad_s = [nan, -0.002, 0.0015]",
    );
    assert_bad("bias", &bias, "rig.imu.initial_gyro_bias_rad_s", &["NaN"]);
    let center = t.replace("center = [-0.5, 0.5, 1.5]", "center = [nan, 0.5, 1.5]");
    assert_bad(
        "center",
        &center,
        "trajectory.figure_eight.center",
        &["NaN"],
    );
    let expect = t.replace("ate_rmse_m = { max = 0.15 }", "ate_rmse_m = { min = nan }");
    assert_bad("expect", &expect, "expectations.ate_rmse_m.min", &["NaN"]);
    let order = t.replace(
        "ate_rmse_m = { max = 0.15 }",
        "ate_rmse_m = { min = 1, max = 0.1 }",
    );
    assert_bad("order", &order, "expectations.ate_rmse_m", &["min ≤ max"]);
    let jitter = "kind = \"timestamp_jitter\"\nstart_s = 1.0\nend_s = 1.5\nimu_sigma_s = nan";
    assert_bad(
        "jitter-nan",
        &with_fault(jitter),
        "faults[0].imu_sigma_s",
        &["NaN"],
    );
    let jitter = "kind = \"timestamp_jitter\"\nstart_s = 1.0\nend_s = 1.5\ncamera_sigma_s = -0.001";
    assert_bad(
        "jitter-neg",
        &with_fault(jitter),
        "faults[0].camera_sigma_s",
        &["-0.001"],
    );
    let spikes = "kind = \"imu_spikes\"\nstart_s = 1.0\nend_s = 1.5\nprobability = 0.01\ngyro_rad_s = nan\naccel_m_s2 = 30.0";
    assert_bad(
        "spikes",
        &with_fault(spikes),
        "faults[0].gyro_rad_s",
        &["NaN"],
    );
}

#[test]
fn a_trajectory_outside_the_scene_or_through_a_box_is_refused() {
    let t = default_text(2.0);
    let outside = t.replace("center = [-0.5, 0.5, 1.5]", "center = [50.0, 0.5, 1.5]");
    assert_bad(
        "outside",
        &outside,
        "trajectory.figure_eight",
        &["leaves the scene at t = 0.00 s"],
    );
    // Around the inside of the pillar in the room's corner (−4.5..−4.1, −3.5..−3.1).
    let through = t.replace(
        "figure_eight = { center = [-0.5, 0.5, 1.5], half_width_m = 2.0, half_height_m = 1.0, period_s = 20.0 }",
        "circle = { center = [-4.3, -3.3, 1.5], radius_m = 0.1, period_s = 20.0 }",
    );
    assert_bad(
        "box",
        &through,
        "trajectory.circle",
        &["passes through a solid box"],
    );
}

#[test]
fn a_glitchy_replay_is_refused_naming_the_line_and_a_latin1_comment_is_read() {
    let dir = scratch("glitchy");
    let dir = dir.path();
    std::fs::create_dir_all(dir.join("data")).unwrap();
    let name = "data/euroc_V2_02_medium_20s_glitchy.txt";
    let bytes = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("catalog")
            .join(name),
    )
    .unwrap();
    assert!(
        std::str::from_utf8(&bytes).is_err(),
        "the fixture holds a Latin-1 byte"
    );
    std::fs::write(dir.join(name), bytes).unwrap();
    let text = scenarios::catalog::get("room_replay_v2_02_glitchy_stereo_imu")
        .unwrap()
        .text
        .replace(", repair = true", "");
    let p = write(dir, "bad.toml", &text);
    let out = vio(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        dir.join("o").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("trajectory.replay.file") && err.contains("line 582"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn an_unwritable_out_is_found_before_the_run() {
    let dir = scratch("unwritable");
    let dir = dir.path();
    let blocker = write(dir, "file", "not a folder");
    let p = write(dir, "ok.toml", &default_text(2.0));
    let out = vio(&[
        "run",
        p.to_str().unwrap(),
        "--out",
        blocker.join("sub").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--out"), "{err}");
    // Nothing ran: no summary on stdout.
    assert!(
        out.stdout.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_huge_duration_override_is_refused() {
    let out = vio(&["run", "--duration", "1e9", "--out", "/nonexistent/never"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--duration"), "{err}");
}

#[test]
fn calibration_errors_out_of_range_are_refused() {
    for (tag, value, key) in [
        (
            "calib-rot",
            "{ rotation_deg = [40.0, 0.0, 0.0] }",
            "rig.cameras[0].calibration_error.rotation_deg",
        ),
        (
            "calib-nan",
            "{ translation_m = [nan, 0.0, 0.0] }",
            "rig.cameras[0].calibration_error.translation_m",
        ),
        (
            "calib-len",
            "{ translation_m = [0.0, 0.0] }",
            "rig.cameras[0].calibration_error.translation_m",
        ),
    ] {
        let text = default_text(2.0).replacen(
            "pixel_sigma_px = 1.0",
            &format!("pixel_sigma_px = 1.0\ncalibration_error = {value}"),
            1,
        );
        assert_bad(tag, &text, key, &[]);
    }
}

#[test]
fn camera_realism_keys_out_of_range_are_refused() {
    for (tag, value, key) in [
        (
            "focal",
            "intrinsics_error = { focal_percent = [25.0, 0.0] }",
            "rig.cameras[0].intrinsics_error.focal_percent",
        ),
        (
            "principal",
            "intrinsics_error = { principal_point_px = [0.0, 60.0] }",
            "rig.cameras[0].intrinsics_error.principal_point_px",
        ),
        (
            "distortion-len",
            "intrinsics_error = { distortion = [0.01] }",
            "rig.cameras[0].intrinsics_error.distortion",
        ),
        (
            "distortion-nan",
            "intrinsics_error = { distortion = [nan, 0.0, 0.0, 0.0] }",
            "rig.cameras[0].intrinsics_error.distortion",
        ),
        (
            "readout-long",
            "rolling_shutter = { readout_ms = 60.0 }",
            "rig.cameras[0].rolling_shutter.readout_ms",
        ),
        (
            "readout-negative",
            "rolling_shutter = { readout_ms = -1.0 }",
            "rig.cameras[0].rolling_shutter.readout_ms",
        ),
        (
            "readout-direction",
            "rolling_shutter = { readout_ms = 10.0, direction = \"left_to_right\" }",
            "rig.cameras[0].rolling_shutter",
        ),
        (
            "tracker-fraction",
            "tracker_error = { white_px = 0.1, drift_px = 0.01, sliding_fraction = 1.5, \
             sliding_drift_px = 0.1, stereo_px = 0.1 }",
            "rig.cameras[0].tracker_error.sliding_fraction",
        ),
        (
            "tracker-white",
            "tracker_error = { white_px = 50.0, drift_px = 0.01, sliding_fraction = 0.1, \
             sliding_drift_px = 0.1, stereo_px = 0.1 }",
            "rig.cameras[0].tracker_error.white_px",
        ),
        (
            "tracker-unknown-key",
            "tracker_error = { white_px = 0.1, drift_px = 0.01, sliding_fraction = 0.1, \
             sliding_drift_px = 0.1, stereo_px = 0.1, jitter = 1.0 }",
            "rig.cameras[0].tracker_error",
        ),
        (
            "tracker-missing-key",
            "tracker_error = { white_px = 0.1 }",
            "rig.cameras[0].tracker_error",
        ),
        (
            "tracker-unknown-name",
            "tracker_error = \"euroc_render\"",
            "rig.cameras[0].tracker_error",
        ),
        (
            "tracker-number",
            "tracker_error = 0.5",
            "rig.cameras[0].tracker_error",
        ),
    ] {
        let text = default_text(2.0).replacen(
            "pixel_sigma_px = 1.0",
            &format!("pixel_sigma_px = 1.0\n{value}"),
            1,
        );
        assert_bad(tag, &text, key, &[]);
    }
    // The renderer's texture and optics keys (checked in feature-level scenarios too: `vio
    // render` uses them).
    for (tag, table, value, key) in [
        (
            "contrast",
            "render",
            "texture_contrast = 0.0",
            "camera.render.texture_contrast",
        ),
        (
            "density",
            "render",
            "texture_density = 9.0",
            "camera.render.texture_density",
        ),
        (
            "blur",
            "photometric",
            "optical_blur_px = -0.5",
            "camera.photometric.optical_blur_px",
        ),
    ] {
        let text = format!("{}\n[camera.{table}]\n{value}\n", default_text(2.0));
        assert_bad(tag, &text, key, &[]);
    }
    // The image front end tracking rendered images makes its own errors.
    let text = format!(
        "{}\n[camera]\nmode = \"rendered\"\n",
        default_text(2.0).replacen(
            "pixel_sigma_px = 1.0",
            "pixel_sigma_px = 1.0\ntracker_error = \"euroc_rendered\"",
            1
        )
    );
    assert_bad(
        "tracker-rendered",
        &text,
        "rig.cameras[0].tracker_error",
        &["feature-level"],
    );
}

#[test]
fn aiding_sensor_keys_are_checked_with_their_names() {
    let with_gnss = |g: &str| default_text(2.0) + "\n[rig.gnss]\n" + g + "\n";
    assert_bad(
        "gnss-sigma",
        &with_gnss("rate_hz = 10.0\nsigma_m = [0.3, 0.0, 0.5]"),
        "rig.gnss.sigma_m[1]",
        &["> 0"],
    );
    assert_bad(
        "gnss-rate",
        &with_gnss("rate_hz = 3.0\nsigma_m = [0.3, 0.3, 0.5]"),
        "rig.gnss.rate_hz",
        &["whole number of nanoseconds"],
    );
    let wheel = default_text(2.0) + "\n[rig.wheel]\nrate_hz = 50.0\nsigma_m_s = -0.1\n";
    assert_bad("wheel-sigma", &wheel, "rig.wheel.sigma_m_s", &["≥ 0"]);
    assert_bad(
        "slip",
        &with_fault("kind = \"wheel_slip\"\nstart_s = 1.0\nend_s = 1.5\nslip_ratio = 20.0"),
        "faults[0].slip_ratio",
        &["[-1, 10]"],
    );
    assert_bad(
        "jump-key",
        &with_fault(
            "kind = \"gnss_bias_jump\"\nat_s = 1.0\noffset_m = [1.0, 0.0, 0.0]\nslip_ratio = 0.1",
        ),
        "faults[0].slip_ratio",
        &["not used by a gnss_bias_jump fault"],
    );
    assert_bad(
        "gnss-gate",
        &with_estimator("[estimator.gnss]\ngate_sigmas = 0.0"),
        "gnss.gate_sigmas",
        &["> 0"],
    );
}

/// Runs `vio args`; a run still going after `limit_s` is killed and the test fails (a FIFO read
/// blocks forever: the guard turns that hang into a failure instead of a stuck CI).
fn vio_within(args: &[&str], limit_s: u64) -> std::process::Output {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vio"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run vio");
    for _ in 0..limit_s * 10 {
        if child.try_wait().expect("wait for vio").is_some() {
            return child.wait_with_output().expect("vio's output");
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    let _ = child.kill();
    panic!("vio {args:?} still running after {limit_s} s: it blocked on its input");
}

#[test]
fn fifos_and_folders_are_refused_at_the_door_not_read() {
    let dir = common::scratch("fifo");
    let mkfifo = |p: &Path| {
        let ok = std::process::Command::new("mkfifo")
            .arg(p)
            .status()
            .expect("mkfifo")
            .success();
        assert!(ok, "mkfifo {}", p.display());
    };
    // A scenario that is a FIFO.
    let fifo = dir.path().join("scenario.toml");
    mkfifo(&fifo);
    let out = vio_within(
        &["run", fifo.to_str().unwrap(), "--out", "/nonexistent/never"],
        60,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("scenario.toml") && err.contains("not a regular file"),
        "{err}"
    );
    // A scenario that is a folder.
    let out = vio_within(
        &[
            "run",
            dir.path().to_str().unwrap(),
            "--out",
            "/nonexistent/never",
        ],
        60,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("a folder"), "{err}");
    // A EuRoC folder one of whose images is a FIFO.
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("catalog/data/euroc_V1_01_easy_excerpt");
    let copy = dir.path().join("excerpt");
    let status = std::process::Command::new("cp")
        .arg("-r")
        .arg(&src)
        .arg(&copy)
        .status()
        .expect("cp");
    assert!(status.success());
    let images = copy.join("mav0/cam0/data");
    let mut names: Vec<_> = std::fs::read_dir(&images)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    names.sort();
    let victim = names[names.len() / 2].clone();
    std::fs::remove_file(&victim).unwrap();
    mkfifo(&victim);
    let out_dir = dir.path().join("out");
    let out = vio_within(
        &[
            "euroc",
            copy.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
        ],
        120,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let name = victim.file_name().unwrap().to_string_lossy();
    assert!(
        err.contains(name.as_ref()) && err.contains("not a regular file"),
        "{err}"
    );
}

/// Units mistakes by 10³ (millimetres typed as metres, a focal length in millimetres, mg as
/// m/s², a period for a rate) are refused at the door with the key, the value and the physical
/// range (`sim::plausible`), where they used to run to a meaningless PASS or FAIL.
#[test]
fn physically_impossible_values_are_refused_with_their_range() {
    let base = default_text(2.0);
    let cases = [
        (
            "camera-55m",
            base.replacen(
                "translation_m = [0.0, 0.055, 0.0]",
                "translation_m = [0.0, 55.0, 0.0]",
                1,
            ),
            "rig.cameras[0].T_b_c.translation_m",
            &["55 m from the IMU", "[0, 5] m"][..],
        ),
        (
            "accel-density-2",
            base.replacen(
                "accelerometer_noise_density = 2.0e-3",
                "accelerometer_noise_density = 2.0",
                1,
            ),
            "rig.imu.accelerometer_noise_density",
            &["2 m/s²/√Hz", "[1e-6, 1]"][..],
        ),
        (
            "camera-0.05hz",
            base.replacen("rate_hz = 20.0", "rate_hz = 0.05", 1),
            "rig.rate_hz",
            &["0.05 Hz", "[1, 1000] Hz"][..],
        ),
        (
            "focal-mm",
            base.replacen(
                "intrinsics = [458.654, 457.296, 367.215, 248.375]",
                "intrinsics = [4.58, 4.57, 367.215, 248.375]",
                1,
            ),
            "rig.cameras[0].intrinsics",
            &["focal length 4.58 px", "[0.05, 100]"][..],
        ),
    ];
    for (tag, text, key, expect) in &cases {
        assert_ne!(text, &base, "{tag}: the replacement did not apply");
        assert_bad(tag, text, key, expect);
    }
}
