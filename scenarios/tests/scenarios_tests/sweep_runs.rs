//! `vio sweep --plan` (the runs listed, every point checked, nothing written), `--keep-runs`
//! (each run's folder, which runs again to the same bytes) and data paths beside the sweep
//! file on a catalog scenario.

use crate::common;

use std::path::Path;

use common::{scratch, vio, vio_ok, write};

const SWEEP: &str = r#"
description = "plan test"
scenario = "room_figure8_stereo_imu"
duration_s = 2.0
seeds = [1, 2]
metrics = ["ate_rmse_m"]

[[axes]]
name = "pixel_sigma"
keys = ["rig.cameras[0].pixel_sigma_px", "rig.cameras[1].pixel_sigma_px"]
values = [0.5, 1.5]
labels = ["half", "one and a half"]
"#;

/// The file names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn a_plan_lists_the_shards_runs_checks_every_point_and_writes_nothing() {
    let dir = scratch("sweep-plan");
    let file = write(dir.path(), "s.toml", SWEEP);
    let out = vio_ok(&["sweep", file.to_str().unwrap(), "--plan", "--shard", "1/2"]).stdout;
    let out = String::from_utf8_lossy(&out);
    let rows: Vec<&str> = out.lines().filter(|l| l.split('\t').count() == 5).collect();
    assert_eq!(
        rows,
        [
            "run\tpoint\tseed\tsimulated_s\tpixel_sigma",
            "1\t0\t2\t2\thalf",
            "3\t1\t2\t2\tone and a half",
        ],
        "{out}"
    );
    assert!(
        out.contains("2 points × 2 seeds = 4 runs, 2 in shard 1/2"),
        "{out}"
    );
    assert!(out.contains("4 simulated seconds in all"), "{out}");
    assert!(out.contains("estimated wall time ≈"), "{out}");
    assert_eq!(names(dir.path()), ["s.toml"], "a plan writes nothing");

    // A point whose scenario cannot be built fails the plan before any run, naming the point.
    let bad = SWEEP.replace("values = [0.5, 1.5]", "values = [0.5, -1.0]");
    let file = write(dir.path(), "bad.toml", &bad);
    let o = vio(&["sweep", file.to_str().unwrap(), "--plan"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("pixel_sigma=one and a half"), "{stderr}");
    assert!(stderr.contains("pixel_sigma_px"), "{stderr}");

    // A duration beyond a replayed motion is found by the plan too.
    let replay = SWEEP
        .replace(
            "room_figure8_stereo_imu",
            "euroc_v1_01_realistic_stereo_imu",
        )
        .replace("duration_s = 2.0", "duration_s = 5000.0");
    let file = write(dir.path(), "long.toml", &replay);
    let o = vio(&["sweep", file.to_str().unwrap(), "--plan"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("beyond the end of the scenario's motion"),
        "{stderr}"
    );
}

#[test]
fn kept_runs_hold_each_runs_files_and_run_again_to_the_same_bytes() {
    let dir = scratch("sweep-keep");
    let one_point = SWEEP
        .replace("values = [0.5, 1.5]", "values = [1.5]")
        .replace(
            "labels = [\"half\", \"one and a half\"]",
            "labels = [\"one and a half\"]",
        );
    let file = write(dir.path(), "s.toml", &one_point);
    let out = dir.path().join("out");
    vio_ok(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--keep-runs",
        "--jobs",
        "2",
    ]);
    assert_eq!(names(&out.join("runs")), ["run-0", "run-1"]);
    let run1 = out.join("runs/run-1");
    for f in [
        "scenario.toml",
        "report.json",
        "estimate.tum",
        "groundtruth.tum",
    ] {
        assert!(run1.join(f).is_file(), "{f} in {}", run1.display());
    }
    let text = std::fs::read_to_string(run1.join("scenario.toml")).unwrap();
    assert!(
        text.starts_with("# Sweep \"plan test\", point 0 (pixel_sigma=one and a half), seed 2: `vio run scenario.toml --seed 2 --duration 2` runs it again."),
        "{text}"
    );
    // The kept run's metric is its row's, and the command in its header reruns it exactly.
    let results = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(run1.join("report.json")).unwrap()).unwrap();
    let row = results.lines().find(|l| l.starts_with("1,")).unwrap();
    assert_eq!(
        row.rsplit(',').next().unwrap(),
        report["ate_rmse_m"].as_f64().unwrap().to_string()
    );
    let again = dir.path().join("again");
    // Exit 0 or 1 (a 2 s run may miss the scenario's expectations), not 2: it ran.
    let o = vio(&[
        "run",
        run1.join("scenario.toml").to_str().unwrap(),
        "--seed",
        "2",
        "--duration",
        "2",
        "--out",
        again.to_str().unwrap(),
    ]);
    assert_ne!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(
        std::fs::read(again.join("estimate.tum")).unwrap(),
        std::fs::read(run1.join("estimate.tum")).unwrap()
    );

    // A folder holding kept runs is a previous sweep's: refused without --force, cleared with.
    let o = vio(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    vio_ok(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--force",
    ]);
    assert!(!out.join("runs").exists(), "--force clears the kept runs");
}

/// On a catalog scenario, a value naming a file the catalog does not embed reads it beside the
/// sweep file (before, "no embedded catalog data file").
#[test]
fn a_sweep_on_a_catalog_scenario_reads_a_values_file_beside_the_sweep_file() {
    let dir = scratch("sweep-beside");
    let noise = scenarios::catalog::estimator_imu_noise("euroc_mav").unwrap();
    write(dir.path(), "noise.toml", noise);
    let sweep = r#"
description = "a file beside the sweep"
scenario = "room_figure8_stereo_imu"
seeds = [1]

[[axes]]
name = "estimator_imu"
keys = ["estimator.imu_noise"]
values = ["noise.toml", "euroc_mav"]
"#;
    let file = write(dir.path(), "s.toml", sweep);
    let s = scenarios::studies::sweep::Sweep::load(&file).unwrap_or_else(|e| panic!("{e}"));
    let assumed = |i: usize| {
        s.scenario(&[i])
            .unwrap_or_else(|e| panic!("{e}"))
            .estimator_config()
            .unwrap()
            .assumed_imu_noise()
    };
    assert_eq!(assumed(0), assumed(1));
    // A file that is not there is named with where it was looked for.
    let missing = sweep.replace("\"noise.toml\"", "\"absent.toml\"");
    let file = write(dir.path(), "m.toml", &missing);
    let e = scenarios::studies::sweep::Sweep::load(&file)
        .unwrap_err()
        .to_string();
    assert!(e.contains("estimator_imu=absent.toml"), "{e}");
    assert!(
        e.contains("absent.toml") && e.contains("relative to the sweep file"),
        "{e}"
    );
}
