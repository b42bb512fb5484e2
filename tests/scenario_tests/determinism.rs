//! Determinism: two runs of the same scenario and seed write byte-identical `estimate.tum` and
//! `groundtruth.tum` files; a different seed gives a different estimate.

use crate::common;

use scenarios::report;
use scenarios::run::RunOptions;
use scenarios::spec::Scenario;
use tempfile::TempDir;

/// Runs catalog scenario `name` for `duration_s` with `seed` (None: its own), writes its files
/// into a fresh folder and returns the folder and the report.
fn run_into(name: &str, duration_s: f64, seed: Option<u64>) -> (TempDir, report::Report) {
    let scenario = Scenario::load(name).unwrap();
    let options = RunOptions {
        seed,
        duration_s: Some(duration_s),
        ..Default::default()
    };
    let done = common::run_with(scenario, &options);
    let dir = common::scratch();
    done.write_outputs(dir.path()).unwrap();
    (dir, done.run.report)
}

#[test]
fn two_runs_write_identical_trajectories() {
    let default = scenarios::catalog::DEFAULT;
    let a = run_into(default, 6.0, None).0;
    let b = run_into(default, 6.0, None).0;
    let c = run_into(default, 6.0, Some(12345)).0;
    for name in ["estimate.tum", "groundtruth.tum"] {
        let fa = std::fs::read(a.path().join(name)).unwrap();
        let fb = std::fs::read(b.path().join(name)).unwrap();
        assert!(fa.len() > 1000, "{name} is too short");
        assert!(fa == fb, "{name} differs between two identical runs");
    }
    let ea = std::fs::read(a.path().join("estimate.tum")).unwrap();
    let ec = std::fs::read(c.path().join("estimate.tum")).unwrap();
    assert!(ea != ec, "another seed gives the same estimate");
}

#[test]
fn aiding_sensors_keep_runs_identical() {
    // GNSS fixes (aligned after about 4 s) and wheel readings enter the window: the same bytes,
    // and the same GNSS block and events in the report.
    for name in [
        "outdoor_figure8_gnss_stereo_imu",
        "hall_ground_vehicle_wheel_mono_imu",
    ] {
        let (a, ra) = run_into(name, 8.0, None);
        let (b, rb) = run_into(name, 8.0, None);
        let fa = std::fs::read(a.path().join("estimate.tum")).unwrap();
        let fb = std::fs::read(b.path().join("estimate.tum")).unwrap();
        assert!(fa.len() > 1000, "{name}: estimate.tum is too short");
        assert!(
            fa == fb,
            "{name}: estimate.tum differs between two identical runs"
        );
        assert_eq!(format!("{:?}", ra.gnss), format!("{:?}", rb.gnss), "{name}");
        assert_eq!(
            format!("{:?}", ra.events),
            format!("{:?}", rb.events),
            "{name}"
        );
        if name.contains("gnss") {
            assert!(ra.gnss.is_some(), "{name}: never aligned");
        }
        for d in [a, b] {
            let _ = std::fs::remove_dir_all(d);
        }
    }
}
