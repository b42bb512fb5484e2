//! An outside estimator in the harness (`estimator_adapter`, `vio run --estimator`): the test
//! estimator `fixtures/outside_estimator/perturbed_truth.py` (the ground truth at the frames'
//! times, perturbed by 5 mm; 50 mm in mode `worse`) is scored like ours; one that crashes, hangs,
//! writes nothing, writes NaN, writes cam0's frame or exits non-zero FAILs (exit 1) naming the
//! cause with its log kept; it runs as a sweep axis beside ours and under `vio regress`, where a
//! deliberate regression of it is caught.

use std::path::{Path, PathBuf};

use crate::common;

use common::{default_text, scratch, vio, write};

/// The test estimator's adapter in `mode`.
fn adapter(mode: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/outside_estimator")
        .join(format!("{mode}.toml"))
}

/// `vio run` of the default scenario (4 s) with the test estimator in `mode`: exit code,
/// stdout, `report.json`, the output folder.
fn run(mode: &str, dir: &Path) -> (Option<i32>, String, serde_json::Value) {
    let out = dir.join(mode);
    let o = vio(&[
        "run",
        "--duration",
        "4",
        "--estimator",
        adapter(mode).to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    let report = std::fs::read_to_string(out.join("report.json")).unwrap_or_else(|e| {
        panic!(
            "{mode}: no report ({e}): {stdout} {}",
            String::from_utf8_lossy(&o.stderr)
        )
    });
    (
        o.status.code(),
        stdout,
        serde_json::from_str(&report).unwrap(),
    )
}

#[test]
fn an_outside_estimator_is_scored_like_ours() {
    let dir = scratch("outside-good");
    let (code, stdout, report) = run("good", dir.path());
    assert_eq!(code, Some(0), "{stdout}");
    assert!(stdout.contains("PASS"), "{stdout}");
    let est = &report["estimator"];
    assert_eq!(est["name"], "perturbed-truth-good");
    assert_eq!(est["exit"], "exited with status 0");
    assert!(est["failure"].is_null());
    // 4 s at 20 Hz, every frame a pose.
    assert!(est["poses"].as_u64().unwrap() >= 79, "{est}");
    assert_eq!(report["frames"], est["poses"]);
    // A 5 mm perturbation, aligned by position+yaw (the suite's alignment, as for ours).
    assert_eq!(report["alignment"], "position_yaw");
    let ate = report["ate_rmse_m"].as_f64().unwrap();
    assert!((0.001..0.008).contains(&ate), "ATE {ate}");
    // Its timing file: 1 ms a frame.
    assert!((report["timing_ms"]["backend"]["median"].as_f64().unwrap() - 1.0).abs() < 1e-6);
    // Its biases are not reported: unknown, not zero.
    assert!(report["gyro_bias_error_rad_s"].is_null());
    let log = dir.path().join("good/estimator/estimator.log");
    assert!(
        std::fs::read_to_string(log)
            .unwrap()
            .contains("mode good, seed 1")
    );
    // The same command twice: the same estimate.
    let again = scratch("outside-good-again");
    run("good", again.path());
    let tum = |d: &Path| std::fs::read(d.join("good/estimate.tum")).unwrap();
    assert_eq!(tum(dir.path()), tum(again.path()));
}

#[test]
fn an_outside_estimator_that_fails_fails_naming_the_cause() {
    let dir = scratch("outside-bad");
    for (mode, cause) in [
        ("crash", "the estimator was killed by signal 11 (SIGSEGV)"),
        ("hang", "ran past its time limit of 2 s and was killed"),
        ("nothing", "wrote no trajectory"),
        ("nan", "tx: `NaN` is not a finite number"),
        (
            "camera",
            "wrote the poses of cam0, not of the body (IMU) frame",
        ),
        ("fail", "the estimator exited with status 3"),
    ] {
        let (code, stdout, report) = run(mode, dir.path());
        assert_eq!(code, Some(1), "{mode}: {stdout}");
        let result = stdout.lines().find(|l| l.starts_with("result")).unwrap();
        assert!(result.contains("FAIL"), "{mode}: {result}");
        let failure = report["estimator"]["failure"].as_str().unwrap_or_default();
        assert!(
            failure.to_lowercase().contains(&cause.to_lowercase()),
            "{mode}: {failure}"
        );
        assert_eq!(report["passed"], false);
        // The log is kept, and its end is in the report.
        assert!(
            dir.path()
                .join(mode)
                .join("estimator/estimator.log")
                .exists()
        );
        assert!(
            report["estimator"]["log_tail"]
                .as_str()
                .unwrap()
                .contains(&format!("mode {mode}")),
            "{mode}: {report}"
        );
    }
}

#[test]
fn a_bad_adapter_is_refused_at_the_door() {
    let dir = scratch("outside-adapter");
    let bad = write(
        dir.path(),
        "bad.toml",
        "name = \"x\"\ncommand = [\"run\", \"{dataset}\", \"{outt}\"]\ninput = \"asl_features\"\n",
    );
    let o = vio(&[
        "run",
        "--duration",
        "2",
        "--estimator",
        bad.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("bad.toml:2") && e.contains("unknown placeholder `{outt}`"),
        "{e}"
    );
    // An adapter of images on feature-level cameras.
    let o = vio(&["run", "--duration", "2", "--estimator", "openvins-images"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("camera.mode = \"rendered\""));
}

#[test]
fn an_outside_estimator_sweeps_beside_ours() {
    let dir = scratch("outside-sweep");
    let sweep = write(
        dir.path(),
        "estimators.toml",
        &format!(
            "description = \"ours against the test estimator\"\nscenario = \"room_figure8_stereo_imu\"\nduration_s = 4.0\nseeds = [1, 2]\nmetrics = [\"ate_rmse_m\"]\n\n[[axes]]\nname = \"estimator\"\nkeys = [\"estimator_adapter\"]\nvalues = [\"ours\", {:?}]\nlabels = [\"ours\", \"perturbed\"]\n",
            adapter("good").display().to_string()
        ),
    );
    let out = dir.path().join("out");
    let o = vio(&[
        "sweep",
        sweep.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        "2",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 4, "{csv}");
    assert!(
        csv.starts_with("run,point,seed,estimator,ate_rmse_m\n"),
        "{csv}"
    );
    // The estimator column holds the axis value's index: 0 ours, 1 the test estimator.
    for index in ["0", "1"] {
        let of: Vec<&&str> = rows
            .iter()
            .filter(|r| r.split(',').nth(3) == Some(index))
            .collect();
        assert_eq!(of.len(), 2, "{index}: {csv}");
        for r in of {
            let ate: f64 = r
                .rsplit(',')
                .next()
                .unwrap()
                .parse()
                .unwrap_or_else(|_| panic!("{r}"));
            assert!(ate > 0.0 && ate < 0.05, "{r}");
        }
    }
}

#[test]
fn a_regression_of_an_outside_estimator_is_caught() {
    let dir = scratch("outside-regress");
    let catalog = dir.path().join("catalog");
    std::fs::create_dir_all(&catalog).unwrap();
    write(&catalog, "short.toml", &default_text(4.0));
    let cat = catalog.to_str().unwrap();
    let good = adapter("good");
    let o = vio(&[
        "regress",
        "--catalog",
        cat,
        "--estimator",
        good.to_str().unwrap(),
        "--update-baseline",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // Its own baseline, beside ours.
    let baseline = catalog.join("baseline.good.json");
    assert!(baseline.exists() && !catalog.join("baseline.json").exists());
    let o = vio(&[
        "regress",
        "--catalog",
        cat,
        "--estimator",
        good.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let junit = dir.path().join("junit.xml");
    let o = vio(&[
        "regress",
        "--catalog",
        cat,
        "--estimator",
        adapter("worse").to_str().unwrap(),
        "--baseline",
        baseline.to_str().unwrap(),
        "--junit",
        junit.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("ate_rmse_m"));
    let xml = std::fs::read_to_string(junit).unwrap();
    assert!(
        xml.contains(
            "classname=\"perturbed-truth-worse.short\" name=\"ate_rmse_m\">\n      <failure"
        ),
        "{xml}"
    );
}

/// `vio nees` of the default scenario (4 s, 6 seeds) with the test estimator in `mode`: exit
/// code, stdout and stderr, `nees.json` when written.
fn nees(mode: &str, dir: &Path) -> (Option<i32>, String, Option<serde_json::Value>) {
    let out = dir.join(mode);
    let o = vio(&[
        "nees",
        "--seeds",
        "6",
        "--duration",
        "4",
        "--estimator",
        adapter(mode).to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let report = std::fs::read_to_string(out.join("nees.json"))
        .ok()
        .map(|t| serde_json::from_str(&t).unwrap());
    (o.status.code(), said, report)
}

#[test]
fn an_outside_estimators_covariance_is_tested_by_vio_nees() {
    let dir = scratch("outside-nees");
    // Every state off by a draw of the covariance it states: every NEES inside its band.
    let (code, said, report) = nees("consistent", dir.path());
    assert_eq!(code, Some(0), "{said}");
    let report = report.expect("nees.json");
    let metrics = report["metrics"].as_array().unwrap();
    let names: Vec<&str> = metrics
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    // The relative pose's covariance is ours only: not tested, not failed.
    assert_eq!(names, ["velocity", "accel_bias", "gyro_bias", "roll_pitch"]);
    for m in metrics {
        let (nees, dof) = (
            m["time_average"].as_f64().unwrap(),
            m["dof"].as_f64().unwrap(),
        );
        assert!(m["inside"].as_bool().unwrap(), "{m}");
        // Within 15 % of its degrees of freedom: 6 seeds × ~80 frames of χ² draws.
        assert!((nees / dof - 1.0).abs() < 0.15, "{}: {nees}", m["name"]);
    }
    // The same draws, a covariance 25× too small: every NEES about 25× its dof, FAIL.
    let (code, said, report) = nees("overconfident", dir.path());
    assert_eq!(code, Some(1), "{said}");
    assert!(said.contains("FAIL"), "{said}");
    for m in report.expect("nees.json")["metrics"].as_array().unwrap() {
        let (nees, dof) = (
            m["time_average"].as_f64().unwrap(),
            m["dof"].as_f64().unwrap(),
        );
        assert!(!m["inside"].as_bool().unwrap(), "{m}");
        assert!(
            (nees / dof / 25.0 - 1.0).abs() < 0.15,
            "{}: {nees}",
            m["name"]
        );
    }
    // An adapter with no covariance file is refused naming the key.
    let (code, said, report) = nees("good", dir.path());
    assert_eq!(code, Some(2), "{said}");
    assert!(said.contains("names no covariance file"), "{said}");
    assert!(report.is_none());
}
