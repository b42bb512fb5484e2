//! `--set KEY=VALUE` on `vio run` and `vio export`: a scenario key set for one run, checked like
//! the file's own keys.

use crate::common;

use common::{scratch, vio, vio_ok};

#[test]
fn a_set_key_changes_the_run_and_a_wrong_one_is_refused() {
    let dir = scratch("set");
    let out = dir.path().join("run");
    let out_s = out.to_str().unwrap();
    // A run (3 s may miss the default scenario's expectations: exit 0 or 1, not 2).
    let o = vio(&[
        "run",
        "--duration",
        "3",
        "--out",
        out_s,
        "--set",
        "rig.imu.rate_hz=100",
    ]);
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    // 100 Hz for 3 s: half the default scenario's 200 Hz samples (the IMU count is in the export).
    let export = dir.path().join("export");
    let o = vio_ok(&[
        "export",
        "--duration",
        "3",
        "--out",
        export.to_str().unwrap(),
        "--set",
        "rig.imu.rate_hz=100",
    ]);
    let imu = std::fs::read_to_string(export.join("mav0/imu0/data.csv")).unwrap();
    let samples = imu.lines().filter(|l| !l.starts_with('#')).count();
    assert!(
        (295..=305).contains(&samples),
        "{samples}: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(report["ate_rmse_m"].as_f64().is_some());
    for (arg, expect) in [
        ("rig.imu.rate_hzz=100", "unknown field `rate_hzz`"),
        ("rig.imu.rate_hz=-5", "rate_hz"),
        ("rig.imu.rate_hz", "expected KEY=VALUE"),
    ] {
        let o = vio(&["run", "--duration", "3", "--out", out_s, "--set", arg]);
        assert_eq!(o.status.code(), Some(2), "{arg}");
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains(expect), "{arg}: {e}");
    }
}
