//! `vio eval`: against evo's numbers on the fixtures, its JSON and thresholds, EuRoC ground
//! truth read as its TUM twin, static trajectories, `--common-with`, and bad input (exit 2 with
//! `file:line`).

use crate::common;

use std::path::{Path, PathBuf};

use common::{vio, vio_ok};

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
