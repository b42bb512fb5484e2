//! The `vio` binary: `eval` against evo's numbers on the fixtures (exit 2 with `file:line` on
//! bad input), `list`, `run` on a short scenario (files, exit codes), and malformed scenario files
//! (missing key, wrong type, unknown key, bad path), which must exit 2 naming the key.

use crate::common;

use std::path::{Path, PathBuf};

use common::{assert_bad, default_text, scratch, vio, vio_ok, write};

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

fn evo_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/evo")
        .join(name)
}

/// evo's value of `<name> <stat>` in the fixture's expected.txt.
fn evo_value(dir: &Path, name: &str, stat: &str) -> f64 {
    let text = std::fs::read_to_string(dir.join("expected.txt")).unwrap();
    let prefix = format!("{name} {stat} ");
    let line = text.lines().find(|l| l.starts_with(&prefix)).unwrap();
    line[prefix.len()..].parse().unwrap()
}

/// The `rmse` column of the table row starting with `row`.
fn printed_rmse(stdout: &str, row: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(row))
        .unwrap_or_else(|| panic!("no `{row}` in\n{stdout}"));
    let fields: Vec<&str> = line[row.len()..].split_whitespace().collect();
    fields[1].parse().unwrap()
}

#[test]
fn eval_prints_evo_ate() {
    let dir = evo_dir("mh01");
    let (gt, est) = (dir.join("gt.tum"), dir.join("est.tum"));
    for (align, name) in [
        ("se3", "ape_se3_trans"),
        ("sim3", "ape_sim3_trans"),
        ("none", "ape_none_trans"),
    ] {
        let out = vio(&[
            "eval",
            "--gt",
            gt.to_str().unwrap(),
            "--est",
            est.to_str().unwrap(),
            "--align",
            align,
        ]);
        let stdout = String::from_utf8(out.stdout).unwrap();
        assert_eq!(out.status.code(), Some(0), "{stdout}");
        let ours = printed_rmse(&stdout, "ATE trans (m)");
        let evo = evo_value(&dir, name, "rmse");
        assert!(
            (ours - evo).abs() <= 1e-6,
            "{align}: printed {ours}, evo {evo}"
        );
        assert!(stdout.contains("RPE trans (m) Δ=1 m"), "{stdout}");
    }
    // The default alignment is the suite's, as `vio run` scores: SE(3) (evo -a) for stereo,
    // position+yaw with an IMU (the default suite), and the output says which.
    let run = |extra: &[&str]| {
        let mut args = vec![
            "eval",
            "--gt",
            gt.to_str().unwrap(),
            "--est",
            est.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        String::from_utf8(vio_ok(&args).stdout).unwrap()
    };
    let stereo = run(&["--suite", "stereo"]);
    assert!(
        stereo.contains("alignment: se3 (the stereo default, as vio run uses)"),
        "{stereo}"
    );
    let evo = evo_value(&dir, "ape_se3_trans", "rmse");
    assert!((printed_rmse(&stereo, "ATE trans (m)") - evo).abs() <= 1e-6);
    let default = run(&[]);
    assert!(
        default.contains("alignment: posyaw (the stereo_imu default"),
        "{default}"
    );
    assert_eq!(
        printed_rmse(&default, "ATE trans (m)"),
        printed_rmse(&run(&["--align", "posyaw"]), "ATE trans (m)")
    );
}

/// `vio eval --json` carries the figures the table prints; `--max-ate` / `--max-rot` turn them
/// into a verdict: exit 1 naming the bound that fails, 0 when both hold; a bound that is no
/// bound is bad input.
#[test]
fn eval_gives_json_and_fails_past_its_thresholds() {
    let dir = evo_dir("mh01");
    let (gt, est) = (dir.join("gt.tum"), dir.join("est.tum"));
    let base = [
        "eval",
        "--gt",
        gt.to_str().unwrap(),
        "--est",
        est.to_str().unwrap(),
    ];
    let with = |extra: &[&str]| {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        vio(&args)
    };
    let out = with(&["--json", "--suite", "stereo"]);
    assert_eq!(out.status.code(), Some(0));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let ate = v["tables"][0]["metrics"]["ATE trans (m)"]["rmse"]
        .as_f64()
        .unwrap();
    assert!((ate - evo_value(&dir, "ape_se3_trans", "rmse")).abs() <= 1e-6);
    assert_eq!(v["passed"], true);
    let rot = v["tables"][0]["metrics"]["ATE rot (deg)"]["rmse"]
        .as_f64()
        .unwrap();
    let (ate_s, rot_s) = (format!("{}", ate * 1.01), format!("{}", rot * 1.01));
    let out = with(&[
        "--suite",
        "stereo",
        "--max-ate",
        &ate_s,
        "--max-rot",
        &rot_s,
    ]);
    assert_eq!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stdout).contains("result PASS"));
    let (ate_s, rot_s) = (format!("{}", ate * 0.99), format!("{}", rot * 0.99));
    let out = with(&["--suite", "stereo", "--max-ate", &ate_s]);
    assert_eq!(out.status.code(), Some(1));
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        stdout.contains("result FAIL: ATE") && stdout.contains("> --max-ate"),
        "{stdout}"
    );
    let out = with(&["--suite", "stereo", "--max-rot", &rot_s, "--json"]);
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["passed"], false);
    assert!(v["failures"][0].as_str().unwrap().contains("--max-rot"));
    let out = with(&["--max-ate", "-1"]);
    assert_eq!(out.status.code(), Some(2));
}

/// An RPE step that is no step (0, negative, NaN, or not whole in frames) is refused with exit
/// 2 naming the option, where `--rpe-delta 0` used to exit 0.
#[test]
fn eval_refuses_an_rpe_delta_that_is_no_step() {
    let (gt, est) = (
        evo_dir("synthetic").join("gt.tum"),
        evo_dir("synthetic").join("est.tum"),
    );
    for (delta, unit) in [
        ("0", "m"),
        ("-1", "m"),
        ("nan", "m"),
        ("inf", "m"),
        ("0", "f"),
        ("1.5", "f"),
    ] {
        let out = vio(&[
            "eval",
            "--gt",
            gt.to_str().unwrap(),
            "--est",
            est.to_str().unwrap(),
            &format!("--rpe-delta={delta}"),
            "--rpe-unit",
            unit,
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{delta} {unit}: {stderr}");
        assert!(
            stderr.contains("vio eval: error"),
            "{delta} {unit}: {stderr}"
        );
        assert!(stderr.contains("--rpe-delta"), "{delta} {unit}: {stderr}");
    }
}

/// `--gt` also reads a EuRoC ground-truth file (`state_groundtruth_estimate0/data.csv`, as
/// `vio export` and the EuRoC datasets write it): the same poses give the same printed metrics
/// as their TUM file, and a bad row is refused with its file and line.
#[test]
fn eval_reads_euroc_ground_truth_as_its_tum_twin() {
    use scenarios::dataset::{GroundTruthState, read_tum, write_groundtruth_csv};
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scenarios-cli-euroc-gt");
    std::fs::create_dir_all(&dir).unwrap();
    let (gt_tum, est) = (
        evo_dir("synthetic").join("gt.tum"),
        evo_dir("synthetic").join("est.tum"),
    );
    let states: Vec<GroundTruthState> = read_tum(&gt_tum)
        .unwrap()
        .into_iter()
        .map(|p| GroundTruthState {
            t_ns: p.t_ns,
            pose: p.pose,
            velocity: Default::default(),
            gyro_bias: Default::default(),
            accel_bias: Default::default(),
        })
        .collect();
    let gt_csv = dir.join("data.csv");
    write_groundtruth_csv(&gt_csv, &states).unwrap();
    let printed = |gt: &Path| {
        let out = vio(&[
            "eval",
            "--gt",
            gt.to_str().unwrap(),
            "--est",
            est.to_str().unwrap(),
        ]);
        assert_eq!(out.status.code(), Some(0));
        String::from_utf8(out.stdout).unwrap()
    };
    let (from_tum, from_csv) = (printed(&gt_tum), printed(&gt_csv));
    let metrics = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| l.starts_with("ATE") || l.starts_with("RPE"))
            .map(String::from)
            .collect()
    };
    assert!(!metrics(&from_tum).is_empty(), "{from_tum}");
    assert_eq!(metrics(&from_tum), metrics(&from_csv));

    let text = std::fs::read_to_string(&gt_csv).unwrap();
    let bad = dir.join("bad.csv");
    let mut lines: Vec<&str> = text.lines().collect();
    lines[2] = "not,a,row";
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();
    let out = vio(&[
        "eval",
        "--gt",
        bad.to_str().unwrap(),
        "--est",
        est.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(stderr.contains(&format!("{}:3", bad.display())), "{stderr}");
}

#[test]
fn eval_exits_2_naming_file_and_line_on_bad_input() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scenarios-cli");
    std::fs::create_dir_all(&dir).unwrap();
    let good = evo_dir("synthetic").join("gt.tum");
    let bad = dir.join("bad.tum");
    std::fs::write(
        &bad,
        "# t x y z qx qy qz qw\n1 0 0 0 0 0 0 1\n2 0 0 0 0 0 1\n",
    )
    .unwrap();
    let out = vio(&[
        "eval",
        "--gt",
        good.to_str().unwrap(),
        "--est",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8(out.stderr).unwrap();
    assert!(
        stderr.contains(&format!("{}:3:", bad.display())),
        "{stderr}"
    );

    // Missing file.
    let missing = dir.join("missing.tum");
    let out = vio(&[
        "eval",
        "--gt",
        missing.to_str().unwrap(),
        "--est",
        good.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8(out.stderr)
            .unwrap()
            .contains("missing.tum")
    );

    // No overlapping timestamps.
    let far = dir.join("far.tum");
    std::fs::write(
        &far,
        "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n3 0 1 0 0 0 0 1\n4 0 0 1 0 0 0 1\n",
    )
    .unwrap();
    let out = vio(&[
        "eval",
        "--gt",
        good.to_str().unwrap(),
        "--est",
        far.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        String::from_utf8(out.stderr)
            .unwrap()
            .contains("no matching timestamps")
    );

    // Bad option value (clap also exits 2).
    let out = vio(&[
        "eval",
        "--gt",
        good.to_str().unwrap(),
        "--est",
        good.to_str().unwrap(),
        "--align",
        "xyz",
    ]);
    assert_eq!(out.status.code(), Some(2));
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

/// A trajectory that does not move is scored from its first pose: the alignment's rotation
/// would be noise. The estimate's world is turned by 40° of yaw and shifted; it drifts 2 mm
/// along its own x and its last pose is tilted by 0.5° more than the truth.
#[test]
fn eval_scores_a_static_trajectory_from_its_first_pose() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("scenarios-cli-static");
    std::fs::create_dir_all(&dir).unwrap();
    let (c, s) = (40f64.to_radians().cos(), 40f64.to_radians().sin());
    let (mut gt, mut est) = (String::new(), String::new());
    for i in 0..21 {
        let t = 1.0 + 0.05 * i as f64;
        // ±0.2 mm of motion-capture jitter; the body faces yaw 0.
        let jitter = if i % 2 == 0 { 2e-4 } else { -2e-4 };
        gt.push_str(&format!("{t:.3} {:.6} 2.0 1.0 0 0 0 1\n", 1.0 + jitter));
        let (x, y) = (1.0 + jitter + 1e-4 * i as f64, 2.0);
        let (ex, ey) = (c * x - s * y + 3.0, s * x + c * y - 1.0);
        // The estimate's body: yaw 40°, and on the last pose 0.5° of roll more.
        let half_roll = if i == 20 { 0.25f64.to_radians() } else { 0.0 };
        let (hc, hs) = (20f64.to_radians().cos(), 20f64.to_radians().sin());
        let (rc, rs) = (half_roll.cos(), half_roll.sin());
        // q = q_yaw(40°) · q_roll: (x, y, z, w).
        let q = [hc * rs, hs * rs, hs * rc, hc * rc];
        est.push_str(&format!(
            "{t:.3} {ex:.9} {ey:.9} 1.0 {:.12} {:.12} {:.12} {:.12}\n",
            q[0], q[1], q[2], q[3]
        ));
    }
    let (g, e) = (dir.join("gt.tum"), dir.join("est.tum"));
    std::fs::write(&g, gt).unwrap();
    std::fs::write(&e, est).unwrap();
    let out = vio(&[
        "eval",
        "--gt",
        g.to_str().unwrap(),
        "--est",
        e.to_str().unwrap(),
        "--align",
        "posyaw",
    ]);
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("too short or static"), "{stdout}");
    assert!(!stdout.contains("ATE rot"), "{stdout}");
    let max_of = |row: &str| -> f64 {
        let line = stdout.lines().find(|l| l.starts_with(row)).unwrap();
        line[row.len()..]
            .split_whitespace()
            .last()
            .unwrap()
            .parse()
            .unwrap()
    };
    assert!((max_of("drift trans (m)") - 2e-3).abs() < 1e-6, "{stdout}");
    assert!((max_of("tilt error (deg)") - 0.5).abs() < 1e-6, "{stdout}");
}

/// Starts `vio args` (stderr piped), sends it Ctrl-C (SIGINT) once `ready` says so of what it
/// has printed to stderr so far, and returns its exit code and stderr.
fn ctrl_c(args: &[&str], ready: impl Fn(&str) -> bool) -> (Option<i32>, String) {
    signal(args, "-INT", ready)
}

/// [`ctrl_c`] with another signal (`-TERM`, …).
fn signal(args: &[&str], which: &str, ready: impl Fn(&str) -> bool) -> (Option<i32>, String) {
    use std::io::Read;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vio"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while let Ok(n) = stderr.read(&mut buf) {
            if n == 0 || tx.send(buf[..n].to_vec()).is_err() {
                break;
            }
        }
    });
    let mut text = String::new();
    let started = std::time::Instant::now();
    while !ready(&text) {
        assert!(
            started.elapsed().as_secs() < 300,
            "{args:?}: not ready: {text}"
        );
        if let Ok(b) = rx.recv_timeout(std::time::Duration::from_millis(50)) {
            text.push_str(&String::from_utf8_lossy(&b));
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "{args:?} ended before Ctrl-C: {text}"
        );
    }
    let kill = std::process::Command::new("kill")
        .args([which, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let code = child.wait().unwrap().code();
    while let Ok(b) = rx.recv_timeout(std::time::Duration::from_secs(5)) {
        text.push_str(&String::from_utf8_lossy(&b));
    }
    (code, text)
}

/// SIGTERM (a scheduler's or `kill`'s) stops `vio run` as Ctrl-C does: exit 130 with the
/// files of what finished written, where it used to end the process with nothing written.
#[test]
fn sigterm_stops_a_run_like_ctrl_c_and_writes_what_finished() {
    let dir = scratch("run-sigterm");
    let out = dir.path().join("run");
    let (code, err) = signal(
        &["run", "--duration", "60", "--out", out.to_str().unwrap()],
        "-TERM",
        |e| e.contains("% of its time"),
    );
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    let report = std::fs::read_to_string(out.join("report.json")).unwrap();
    assert!(report.contains("\"resets\""), "{report}");
    assert!(out.join("estimate.tum").exists());
}

#[test]
fn ctrl_c_stops_regress_nees_and_bench_with_130_saying_what_finished() {
    // regress: once its first scenario is under way; the baseline is not touched.
    let catalog = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("regress");
    let baseline = std::fs::read(catalog.join("baseline.json")).unwrap();
    let (code, err) = ctrl_c(&["regress", "--catalog", catalog.to_str().unwrap()], |e| {
        e.contains("running")
    });
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("interrupted after"), "{err}");
    assert_eq!(
        std::fs::read(catalog.join("baseline.json")).unwrap(),
        baseline
    );
    // nees: a second after it starts (no seed may have finished: then nothing is written).
    let dir = scratch("nees-ctrl-c");
    let out = dir.path().join("nees");
    let started = std::time::Instant::now();
    let (code, err) = ctrl_c(
        &[
            "nees",
            "--seeds",
            "6",
            "--duration",
            "4",
            "--threads",
            "1",
            "--out",
            out.to_str().unwrap(),
        ],
        |_| started.elapsed().as_secs_f64() > 1.0,
    );
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("vio nees: interrupted"), "{err}");
    // bench: during its first scenario (a child process; a terminal's Ctrl-C reaches it too,
    // here only the parent is told): the table and bench.json hold what finished.
    let out = dir.path().join("bench");
    let (code, err) = ctrl_c(&["bench", "--quick", "--out", out.to_str().unwrap()], |e| {
        e.contains("bench ")
    });
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("vio bench: interrupted after"), "{err}");
    let json = std::fs::read_to_string(out.join("bench.json")).unwrap();
    assert!(json.contains("\"rows\""), "{json}");
}

#[test]
fn eval_common_with_scores_both_estimates_on_the_frames_both_produced() {
    let dir = evo_dir("mh01");
    let (gt, est) = (dir.join("gt.tum"), dir.join("est.tum"));
    let scratch = common::scratch("eval-common");
    // An estimator that starts later: the same poses without the first third.
    let text = std::fs::read_to_string(&est).unwrap();
    let poses: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    let late = scratch.path().join("late.tum");
    std::fs::write(&late, poses[poses.len() / 3..].join("\n") + "\n").unwrap();
    let arg = |p: &Path| p.to_str().unwrap().to_string();
    let (gt, est, late) = (arg(&gt), arg(&est), arg(&late));
    let out = vio_ok(&["eval", "--gt", &gt, "--est", &est, "--common-with", &late]);
    let stdout = String::from_utf8(out.stdout).unwrap();
    let n_late = poses.len() - poses.len() / 3;
    assert!(
        stdout.starts_with(&format!("common frames: {n_late} of {} ", poses.len())),
        "{stdout}"
    );
    // Both tables on the same frames: equal here (the same poses), and equal to the late
    // estimate scored alone; the whole estimate scored alone differs.
    let tables: Vec<&str> = stdout.split("ground truth ").skip(1).collect();
    assert_eq!(tables.len(), 2, "{stdout}");
    let ate = |t: &str| printed_rmse(t, "ATE trans (m)");
    assert_eq!(ate(tables[0]), ate(tables[1]));
    let alone = |e: &str| {
        let out = vio_ok(&["eval", "--gt", &gt, "--est", e]);
        ate(&String::from_utf8(out.stdout).unwrap())
    };
    assert_eq!(ate(tables[0]), alone(&late));
    assert_ne!(ate(tables[0]), alone(&est));
    // No common frames: exit 2 saying so.
    let far = scratch.path().join("far.tum");
    std::fs::write(&far, "1e6 0 0 0 0 0 0 1\n1000001 0 0 0 0 0 0 1\n").unwrap();
    let out = vio(&[
        "eval",
        "--gt",
        &gt,
        "--est",
        &est,
        "--common-with",
        &arg(&far),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no common frames"));
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
