//! The `vio` binary: `list`, `run` on a short scenario (files, exit codes), `export`, `render`,
//! `euroc`, and malformed scenario files (missing key, wrong type, unknown key, bad path), which
//! must exit 2 naming the key.

use crate::common;

use std::path::Path;

use common::{assert_bad, default_text, scratch, vio, write};

/// `vio run FILE --out OUT` with `extra` arguments after them.
fn run_file(file: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "run",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    vio(&args)
}

#[test]
fn list_names_every_catalog_scenario() {
    let out = vio(&["list"]);
    assert_eq!(out.status.code(), Some(0));
    let stdout = String::from_utf8_lossy(&out.stdout);
    for name in scenarios::catalog::names() {
        assert!(stdout.contains(name), "{name} missing from: {stdout}");
    }
    assert!(stdout.contains("[default]"));
}

#[test]
fn missing_key_exits_2_naming_it() {
    let text = default_text(2.0).replace("duration_s = 2.0\n", "");
    assert_bad("missing", &text, "trajectory", &["duration_s", "missing"]);
}

#[test]
fn wrong_type_exits_2_naming_the_key_and_line() {
    let text = default_text(2.0).replace("rate_hz = 20.0", "rate_hz = \"fast\"");
    let line = text.lines().position(|l| l.contains("\"fast\"")).unwrap() + 1;
    let err = assert_bad("type", &text, "rig.rate_hz", &["invalid type", "f64"]);
    assert!(
        err.contains(&format!(":{line}:")),
        "line {line} not named: {err}"
    );
}

#[test]
fn unknown_key_exits_2_naming_it() {
    let text = default_text(2.0).replace("seed = 1", "seed = 1\nsead = 2");
    assert_bad("unknown", &text, "sead", &["world", "unknown field"]);
    let text = default_text(2.0).replace("[expectations]", "[expectations]\nate_m = { max = 1 }");
    assert_bad("unknown-expectation", &text, "ate_m", &["expectations"]);
}

#[test]
fn bad_replay_path_exits_2_naming_the_key() {
    let text = scenarios::catalog::get("room_replay_v2_02_stereo_imu")
        .unwrap()
        .text
        .replace("data/euroc_V2_02_medium_20s.txt", "data/no_such_file.txt");
    assert_bad(
        "path",
        &text,
        "trajectory.replay.file",
        &["no_such_file.txt", "relative to the scenario file"],
    );
}

#[test]
fn semantic_errors_exit_2_naming_the_key() {
    let text = default_text(2.0).replace("pixel_sigma_px = 1.0", "pixel_sigma_px = -1.0");
    assert_bad(
        "negative",
        &text,
        "rig.cameras[0].pixel_sigma_px",
        &["[0, 48]"],
    );
    let text = default_text(2.0).replace(
        "distortion = [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]",
        "distortion = [-0.28340811]",
    );
    assert_bad(
        "distortion",
        &text,
        "rig.cameras[0].distortion",
        &["4 coefficients"],
    );
    let text = default_text(2.0).replace("suite = \"stereo_imu\"", "suite = \"mono\"");
    assert_bad("suite", &text, "suite", &["stereo_imu"]);
}

#[test]
fn unknown_scenario_name_exits_2() {
    let out = vio(&["run", "no_such_scenario"]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("no_such_scenario") && stderr.contains("room_figure8_stereo_imu"));
}

/// `--batch-reference` writes the batch, the frames as they left the window and the filter's
/// checkpoints as TUM files in time order (frames leave out of order), and a run that never
/// tracked has no batch instead of a panic.
#[test]
fn batch_reference_writes_its_trajectories() {
    let dir = scratch("batch");
    let dir = dir.path();
    let file = write(dir, "short.toml", &default_text(3.0));
    let out_dir = dir.join("out");
    let out = run_file(&file, &out_dir, &["--batch-reference"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("batch ref"), "{stdout}");
    let stamps = |name: &str| -> Vec<f64> {
        std::fs::read_to_string(out_dir.join(name))
            .unwrap()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| l.split_whitespace().next().unwrap().parse().unwrap())
            .collect()
    };
    let (batch, window) = (stamps("batch.tum"), stamps("window.tum"));
    // 3 s: some keyframes have left the window, and the batch holds them and the window's.
    assert!(
        window.len() >= 10 && batch.len() > 10,
        "{window:?} {batch:?}"
    );
    for t in [&batch, &window] {
        assert!(t.windows(2).all(|w| w[0] < w[1]), "{t:?}");
    }
    // The filter's checkpoints (every 0.3 s of a 3 s run once tracking): frames the window
    // estimated too, in time order.
    let (filter, estimate) = (stamps("filter.tum"), stamps("estimate.tum"));
    assert!(filter.len() >= 5, "{filter:?}");
    assert!(filter.windows(2).all(|w| w[0] < w[1]), "{filter:?}");
    assert!(filter.iter().all(|t| estimate.contains(t)), "{filter:?}");
    // A plain run into the same folder leaves none of the earlier run's files behind, and
    // keeps a file of the user's.
    std::fs::write(out_dir.join("notes.txt"), "mine").unwrap();
    let out = run_file(&file, &out_dir, &[]);
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    assert!(out_dir.join("estimate.tum").exists());
    for name in ["batch.tum", "window.tum", "filter.tum"] {
        assert!(!out_dir.join(name).exists(), "{name}");
    }
    assert!(out_dir.join("notes.txt").exists());
    // Initialization takes 0.45 s: 0.3 s never tracks, and the batch reference is absent.
    let never = write(dir, "never.toml", &default_text(0.3));
    let out = run_file(&never, &dir.join("never"), &["--batch-reference"]);
    assert_ne!(out.status.code(), Some(101), "{out:?}");
    assert!(!dir.join("never/batch.tum").exists());
}

#[test]
fn run_writes_the_report_files_and_exits_by_expectations() {
    let dir = scratch("run");
    let dir = dir.path();
    // Passing expectations: exit 0 and every file.
    let ok = write(dir, "short.toml", &default_text(3.0));
    let out_ok = dir.join("ok");
    let out = run_file(&ok, &out_ok, &[]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("ATE") && stdout.contains("PASS"),
        "{stdout}"
    );
    for f in [
        "estimate.tum",
        "groundtruth.tum",
        "report.json",
        "trajectory.png",
    ] {
        assert!(out_ok.join(f).is_file(), "{f} missing");
    }
    let png = std::fs::read(out_ok.join("trajectory.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_ok.join("report.json")).unwrap())
            .unwrap();
    for k in [
        "scenario",
        "suite",
        "seed",
        "frames",
        "duration_s",
        "ate_rmse_m",
        "ate_rot_rmse_deg",
        "rpe_trans_rmse_m",
        "resets",
    ] {
        assert!(json.get(k).is_some(), "report.json lacks {k}");
    }
    assert_eq!(json["scenario"], "short");
    assert_eq!(json["suite"], "stereo_imu");
    assert!(json["ate_rmse_m"].as_f64().unwrap() > 0.0);
    for part in ["frontend", "backend", "total"] {
        for stat in ["median", "p99", "max"] {
            assert!(json["timing_ms"][part][stat].is_number(), "{part}.{stat}");
        }
    }
    assert!(json["timing_ms"]["render"].is_null());
    // An expectation that cannot hold: exit 1, files still written.
    let strict =
        default_text(3.0).replace("ate_rmse_m = { max = 0.15 }", "ate_rmse_m = { max = 1e-9 }");
    let bad = write(dir, "strict.toml", &strict);
    let out_bad = dir.join("bad");
    let out = run_file(&bad, &out_bad, &["--seed", "7"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("FAIL"), "{stdout}");
    assert!(out_bad.join("report.json").is_file());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_bad.join("report.json")).unwrap())
            .unwrap();
    assert_eq!(json["seed"], 7);
    assert_eq!(json["passed"], false);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn export_writes_an_euroc_folder_that_reads_back() {
    let dir = scratch("export");
    let dir = dir.path();
    let out = vio(&["export", "--out", dir.to_str().unwrap(), "--duration", "2"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let data = scenarios::dataset::read_euroc(dir.join("mav0")).unwrap();
    // 2 s at 200 Hz, both ends included; ground truth at every IMU sample; 20 Hz stereo.
    assert_eq!(data.imu.len(), 401);
    assert_eq!(data.groundtruth.len(), data.imu.len());
    assert_eq!(data.cameras.len(), 2);
    // No images in a feature-level export: data.csv lists none (a reader would open them).
    assert!(data.cameras[0].frames.is_empty());
    assert!(!dir.join("mav0/cam0/data").exists());
    let sensor = data.imu_sensor.as_ref().unwrap();
    assert_eq!(sensor.noise, estimator::imu::ImuNoise::euroc());
    let cam = data.cameras[0].sensor.as_ref().unwrap();
    assert_eq!(cam.camera_model, "pinhole");
    assert_eq!(cam.resolution, [752, 480]);
    let frames = scenarios::dataset::read_features_csv(dir.join("features.csv")).unwrap();
    assert_eq!(frames.len(), 41);
    // Ids renumbered densely from 0 (keeping their order): they fit in 31 bits.
    let mut seen = std::collections::BTreeSet::new();
    for f in &frames {
        for c in &f.cameras {
            seen.extend(c.features.iter().map(|o| o.feature_id));
        }
    }
    assert_eq!(seen.first(), Some(&0));
    assert_eq!(seen.last(), Some(&(seen.len() as u64 - 1)), "not dense");
    assert!(seen.len() > 100 && (seen.len() as u64) < (1 << 31));
    assert!(
        frames
            .iter()
            .all(|f| f.cameras.iter().any(|c| !c.features.is_empty()))
    );
    // The ground truth's biases are the scenario's known, non-zero initial biases.
    assert!(
        data.groundtruth[0].gyro_bias.norm() > 0.0 && data.groundtruth[0].accel_bias.norm() > 0.0
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn render_writes_a_stereo_pair_with_depth_and_rejects_a_time_outside_the_run() {
    let dir = scratch("render");
    let dir = dir.path();
    let _ = std::fs::remove_dir_all(dir);
    let d = dir.to_str().unwrap();
    let out = vio(&[
        "render",
        "room_figure8_rendered_stereo_imu",
        "--at",
        "3.5",
        "--out",
        d,
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("rendered room_figure8_rendered_stereo_imu at t = 3.5 s on "),
        "{stdout}"
    );
    for f in ["cam0.png", "cam1.png", "cam0_depth.png", "cam1_depth.png"] {
        let img = image::open(dir.join(f)).unwrap();
        assert_eq!((img.width(), img.height()), (752, 480), "{f}");
    }
    let depth = image::open(dir.join("cam0_depth.png")).unwrap().to_luma16();
    let mm = depth.get_pixel(376, 240).0[0];
    assert!(
        (300..9000).contains(&mm),
        "depth at the centre {mm} mm: inside the room"
    );
    let pair = image::open(dir.join("stereo.png")).unwrap();
    assert_eq!((pair.width(), pair.height()), (752 * 2 + 8, 480));

    let out = vio(&["render", "--at", "1000", "--out", d]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("--at 1000 s is outside"), "{stderr}");
}

#[test]
fn render_tracks_draws_the_front_end_tracks_over_the_stereo_pair() {
    let dir = scratch("tracks");
    let dir = dir.path();
    let _ = std::fs::remove_dir_all(dir);
    let out = vio(&[
        "render",
        "room_figure8_rendered_stereo_imu",
        "--at",
        "3",
        "--out",
        dir.to_str().unwrap(),
        "--tracks",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // 2 s of 20 Hz captures before t = 3 s, both ends included.
    assert!(
        stdout.contains("tracked 41 captures from t = 1.00 s to 3.00 s"),
        "{stdout}"
    );
    assert!(stdout.contains("tracks.png"), "{stdout}");
    let tracks: usize = stdout
        .split(" tracks, ")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no track count in {stdout}"));
    assert!(tracks >= 50, "{tracks} tracks");
    let img = image::open(dir.join("tracks.png")).unwrap().to_rgb8();
    assert_eq!((img.width(), img.height()), (2 * 752, 480));
    let first = *img.get_pixel(0, 0);
    assert!(img.pixels().any(|p| *p != first), "a uniform image");
    // Tracks are drawn in colour over grey images.
    let coloured = img
        .pixels()
        .filter(|p| p.0[0].abs_diff(p.0[1]) > 60 || p.0[1].abs_diff(p.0[2]) > 60)
        .count();
    assert!(coloured > 1000, "{coloured} coloured pixels");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn euroc_runs_an_exported_folder_and_writes_the_run_files() {
    let dir = scratch("euroc");
    let dir = dir.path();
    let exp = dir.join("exp");
    let out = vio(&["export", "--out", exp.to_str().unwrap(), "--duration", "3"]);
    assert!(out.status.success());
    let run_dir = dir.join("run");
    let out = vio(&[
        "euroc",
        exp.to_str().unwrap(),
        "--features",
        exp.join("features.csv").to_str().unwrap(),
        "--out",
        run_dir.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("61 frames from feature tracks"), "{stdout}");
    assert!(stdout.contains("ATE"), "{stdout}");
    for f in [
        "estimate.tum",
        "estimate_source_time.tum",
        "groundtruth.tum",
        "report.json",
        "trajectory.png",
    ] {
        assert!(run_dir.join(f).exists(), "{f} missing");
    }
    // Bad input: exit 2 naming the file; nothing left behind.
    let bad_out = dir.join("bad-out");
    let out = vio(&[
        "euroc",
        dir.join("nowhere").to_str().unwrap(),
        "--out",
        bad_out.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nowhere"));
    assert!(!bad_out.exists());
    let out = vio(&["euroc", exp.to_str().unwrap(), "--suite", "quad"]);
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(dir);
}

/// `--duration` beyond the end of a replayed recording is refused (exit 2, naming the option
/// and the motion's end), where the run used to be cut to the recording silently.
#[test]
fn a_duration_beyond_the_replayed_motion_is_refused() {
    let dir = scratch("duration-beyond-replay");
    let out = dir.path().join("run");
    let run = |d: &str| {
        vio(&[
            "run",
            "room_replay_v2_02_stereo_imu",
            "--duration",
            d,
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let o = run("1000");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--duration") && stderr.contains("beyond the end of the scenario's motion"),
        "{stderr}"
    );
    assert!(!out.join("report.json").exists());
}

/// Output that cannot be written (a full disk: `/dev/full`) is an error, exit 74 saying so,
/// where `vio list > /dev/full` used to exit 0; a reader closing the pipe early is not.
#[test]
fn output_that_cannot_be_written_is_an_error() {
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    let Ok(full) = full else {
        eprintln!("no /dev/full here: skipped");
        return;
    };
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vio"))
        .arg("list")
        .stdout(full)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(74), "{stderr}");
    assert!(stderr.contains("writing to stdout failed"), "{stderr}");
}
