//! `vio eval` end to end: evo's ATE on the fixture, exit code 2 with `file:line` on bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn vio(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_vio"))
        .args(args)
        .output()
        .expect("run vio")
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
    // Default alignment is SE3 (evo -a); posyaw also runs.
    let out = vio(&[
        "eval",
        "--gt",
        gt.to_str().unwrap(),
        "--est",
        est.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8(out.stdout).unwrap();
    let evo = evo_value(&dir, "ape_se3_trans", "rmse");
    assert!((printed_rmse(&stdout, "ATE trans (m)") - evo).abs() <= 1e-6);
    let out = vio(&[
        "eval",
        "--gt",
        gt.to_str().unwrap(),
        "--est",
        est.to_str().unwrap(),
        "--align",
        "posyaw",
    ]);
    assert_eq!(out.status.code(), Some(0));
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
