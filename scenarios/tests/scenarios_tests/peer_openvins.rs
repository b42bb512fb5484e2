//! The peer harness (`tools/peer/openvins/`): OpenVINS built without ROS from its public source,
//! fed the same exported IMU samples and feature tracks as our estimator, both scored on the
//! frames both produced.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::common::scratch;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn bash(args: &[&str], out_root: &Path) -> String {
    let out = Command::new("bash")
        .args(args)
        .current_dir(root())
        .env("VIO", env!("CARGO_BIN_EXE_vio"))
        .env("OUT_ROOT", out_root)
        .output()
        .expect("bash runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "bash {args:?}: {stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Builds OpenVINS (apt packages and a clone of its repository at the pinned commit when
/// missing, or OPENVINS_SRC), runs the comparison on the first 30 s of the default scenario
/// twice, and checks that both estimators track it, that the comparison is scored on nearly
/// every frame, and that both runs are the same bytes (single-threaded, deterministic).
/// Measured here: 554 common frames (OpenVINS initialized at 2.35 s); ours 0.0067 m / 0.15°,
/// OpenVINS 0.0074 m / 0.26°.
#[test]
#[ignore = "installs Debian packages, clones and builds OpenVINS (~15 min on 2 cores the first time)"]
fn openvins_and_ours_run_on_the_same_exported_tracks_and_are_scored_on_common_frames() {
    bash(&["tools/peer/openvins/build.sh"], &root().join("target"));
    let runs: Vec<tempfile::TempDir> = (0..2).map(|_| scratch("peer")).collect();
    for run in &runs {
        bash(
            &[
                "tools/peer/openvins/compare.sh",
                "room_figure8_stereo_imu",
                "1",
                "30",
            ],
            run.path(),
        );
    }
    let dir = |k: usize| runs[k].path().join("room_figure8_stereo_imu-s1-30s");
    for file in ["openvins.tum", "ours/estimate.tum"] {
        let (a, b) = (
            std::fs::read(dir(0).join(file)).expect("first run's file"),
            std::fs::read(dir(1).join(file)).expect("second run's file"),
        );
        assert!(a == b, "{file} differs between two identical runs");
    }
    let csv = std::fs::read_to_string(runs[0].path().join("results.csv")).expect("results.csv");
    let row: Vec<&str> = csv
        .lines()
        .nth(1)
        .expect("one result row")
        .split(',')
        .collect();
    let num = |k: usize| row[k].parse::<f64>().expect("a number");
    let (common, ours_ate, ours_rot, ov_ate, ov_rot) = (num(3), num(4), num(5), num(6), num(7));
    // 601 frames in 30 s; both initialize within their first 3 s (OpenVINS collects 2 s).
    assert!(common >= 540.0, "only {common} common frames: {csv}");
    // Both track: a few mm on this motion (a diverged or unaligned run is metres off).
    for (who, ate, rot) in [("ours", ours_ate, ours_rot), ("OpenVINS", ov_ate, ov_rot)] {
        assert!(ate < 0.03 && rot < 1.0, "{who}: {ate} m, {rot} deg: {csv}");
    }
}

/// `vio run` with an adapter (`--estimator NAME`): its report.json.
fn run_with(
    estimator: &str,
    scenario: &str,
    seed: &str,
    duration: &str,
    out: &Path,
) -> serde_json::Value {
    let o = Command::new(env!("CARGO_BIN_EXE_vio"))
        .args([
            "run",
            scenario,
            "--seed",
            seed,
            "--duration",
            duration,
            "--estimator",
            estimator,
        ])
        .arg("--out")
        .arg(out)
        .current_dir(root())
        .output()
        .expect("vio runs");
    let report = std::fs::read_to_string(out.join("report.json")).unwrap_or_else(|e| {
        panic!(
            "{estimator}: no report ({e}): {}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )
    });
    serde_json::from_str(&report).expect("report.json")
}

/// The built-in adapter `openvins-tracks` is today's `compare.sh` folded into `vio run`: on the
/// same scenario, seed and duration it writes OpenVINS's trajectory to the same bytes, and
/// scored as compare.sh scores it (SE(3), the frames both produced) it gives compare.sh's
/// OpenVINS figure to 1e-6 m. Its own report uses the suite's alignment, as for ours, and
/// equals `vio eval`'s default on its files. Measured here (20 s, seed 1): 354 poses (one past
/// the ground truth's end), ATE 0.0074 m position+yaw; compare.sh's 0.0059 m on 354 common frames.
#[test]
#[ignore = "builds OpenVINS (tools/peer/openvins/build.sh; ~15 min on 2 cores the first time)"]
fn the_openvins_tracks_adapter_reproduces_compare_sh() {
    bash(&["tools/peer/openvins/build.sh"], &root().join("target"));
    let cmp = scratch("peer-compare");
    bash(
        &[
            "tools/peer/openvins/compare.sh",
            "room_figure8_stereo_imu",
            "1",
            "20",
        ],
        cmp.path(),
    );
    let run = scratch("peer-adapter");
    let report = run_with(
        "openvins-tracks",
        "room_figure8_stereo_imu",
        "1",
        "20",
        run.path(),
    );
    // Scored (its 2 s of initialization keep it under the scenario's 0.9 tracking over 20 s).
    assert!(report["estimator"]["failure"].is_null(), "{report}");
    let dir = cmp.path().join("room_figure8_stereo_imu-s1-20s");
    let theirs = std::fs::read(dir.join("openvins.tum")).unwrap();
    let ours = std::fs::read(run.path().join("estimator/out/estimate.tum")).unwrap();
    assert!(
        theirs == ours,
        "the adapter's trajectory differs from compare.sh's"
    );
    // compare.sh's figure: OpenVINS's SE(3) ATE on the frames both produced.
    let csv = std::fs::read_to_string(cmp.path().join("results.csv")).unwrap();
    let row: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let compare_sh_ate: f64 = row[6].parse().unwrap();
    let eval = |args: &[&Path], extra: &[&str]| -> serde_json::Value {
        let mut c = Command::new(env!("CARGO_BIN_EXE_vio"));
        c.arg("eval")
            .arg("--gt")
            .arg(args[0])
            .arg("--est")
            .arg(args[1]);
        if let Some(other) = args.get(2) {
            c.arg("--common-with").arg(other);
        }
        let o = c.args(extra).arg("--json").output().unwrap();
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let ate = |v: &serde_json::Value, t: usize| {
        v["tables"][t]["metrics"]["ATE trans (m)"]["rmse"]
            .as_f64()
            .unwrap()
    };
    let v = eval(
        &[
            &dir.join("ours/groundtruth.tum"),
            &dir.join("ours/estimate.tum"),
            &run.path().join("estimator/out/estimate.tum"),
        ],
        &["--align", "se3"],
    );
    assert!(
        (ate(&v, 1) - compare_sh_ate).abs() <= 1e-6,
        "{} vs {compare_sh_ate}",
        ate(&v, 1)
    );
    let v = eval(
        &[
            &run.path().join("groundtruth.tum"),
            &run.path().join("estimate.tum"),
        ],
        &[],
    );
    let reported = report["ate_rmse_m"].as_f64().unwrap();
    assert!(
        (ate(&v, 0) - reported).abs() <= 1e-6,
        "{} vs {reported}",
        ate(&v, 0)
    );
}

/// The built-in adapter `openvins-images` runs OpenVINS's own KLT front end and filter on the
/// rendered frames (`ov_image_driver`), scored like ours. Measured here (30 s, seed 1): it
/// initializes at 2.35 s and tracks to 0.01 m; ours on the same frames: see the book.
#[test]
#[ignore = "builds OpenVINS (tools/peer/openvins/build.sh; ~15 min on 2 cores the first time)"]
fn the_openvins_images_adapter_runs_openvins_front_end_on_rendered_frames() {
    bash(&["tools/peer/openvins/build.sh"], &root().join("target"));
    let run = scratch("peer-images");
    let report = run_with(
        "openvins-images",
        "room_figure8_rendered_stereo_imu",
        "1",
        "30",
        run.path(),
    );
    assert_eq!(report["estimator"]["name"], "openvins-images");
    assert!(report["estimator"]["failure"].is_null(), "{report}");
    let ate = report["ate_rmse_m"].as_f64().unwrap();
    let tracking = report["tracking_fraction"].as_f64().unwrap();
    // 601 captures in 30 s; OpenVINS collects 2 s before it initializes.
    assert!(tracking > 0.85, "{tracking}");
    assert!(ate < 0.03, "{ate} m");
    let log = std::fs::read_to_string(run.path().join("estimator/estimator.log")).unwrap();
    assert!(log.contains("ov_image_driver: 601 captures"), "{log}");
}

/// `vio nees` with the built-in adapter `openvins-tracks`: its drivers write the newest state
/// and OpenVINS's own covariance of it in our order (`ov_state_io.h`), and on the default
/// scenario OpenVINS is consistent like ours. Measured here (10 seeds, 20 s): velocity 3.39,
/// accel bias 3.25, gyro bias 3.53, roll/pitch 2.40 (ours 3.15 / 3.31 / 2.82 / 2.21), every one
/// inside its band; on the realistic V1_01 feature stand-in (60 s) its roll/pitch reads 6.82,
/// outside: its configuration holds the drawn calibration fixed (`calib_cam_extrinsics: false`).
#[test]
#[ignore = "builds OpenVINS (tools/peer/openvins/build.sh; ~15 min on 2 cores the first time)"]
fn openvins_is_tested_for_consistency_by_vio_nees() {
    bash(&["tools/peer/openvins/build.sh"], &root().join("target"));
    let out = scratch("peer-nees");
    let o = Command::new(env!("CARGO_BIN_EXE_vio"))
        .args([
            "nees",
            "--estimator",
            "openvins-tracks",
            "--seeds",
            "10",
            "--duration",
            "20",
        ])
        .arg("--out")
        .arg(out.path())
        .current_dir(root())
        .output()
        .expect("vio runs");
    let said = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{said}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.path().join("nees.json")).unwrap())
            .unwrap();
    let metrics = report["metrics"].as_array().unwrap();
    assert_eq!(metrics.len(), 4, "{said}");
    for m in metrics {
        assert!(m["inside"].as_bool().unwrap(), "{m}");
        assert!(m["series"].as_array().unwrap().len() > 300, "{}", m["name"]);
    }
}
