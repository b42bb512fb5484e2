//! `vio sweep`: shards merged equal one process's output byte for byte (results, definition,
//! plots), the thread count changes nothing, and a bad sweep file exits 2 naming the key.

use crate::common;

use std::path::Path;

use common::{scratch, vio, vio_ok, write};

const SWEEP: &str = r#"
description = "test sweep"
scenario = "room_figure8_stereo_imu"
duration_s = 2.0
seeds = [1, 2]
metrics = ["ate_rmse_m", "tracking_fraction"]

[[axes]]
name = "pixel_sigma"
keys = ["rig.cameras[0].pixel_sigma_px", "rig.cameras[1].pixel_sigma_px"]
values = [0.5, 1.5]

[[axes]]
name = "features"
keys = ["rig.cameras[0].max_features", "rig.cameras[1].max_features"]
values = [60, 150]
"#;

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap() != ".vio-write-check")
        .map(|p| {
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn merged_shards_equal_one_process_byte_for_byte() {
    let dir = scratch("sweep");
    let dir = dir.path();
    let file = write(dir, "s.toml", SWEEP);
    let f = file.to_str().unwrap();
    let one = dir.join("one");
    vio_ok(&["sweep", f, "--out", one.to_str().unwrap(), "--jobs", "2"]);
    let mut shards = Vec::new();
    for i in 0..3 {
        let d = dir.join(format!("shard{i}"));
        let shard = format!("{i}/3");
        vio_ok(&[
            "sweep",
            f,
            "--out",
            d.to_str().unwrap(),
            "--shard",
            &shard,
            "--jobs",
            "1",
        ]);
        shards.push(d);
    }
    let merged = dir.join("merged");
    let mut args = vec!["sweep-merge"];
    let names: Vec<String> = shards
        .iter()
        .map(|d| d.to_string_lossy().into_owned())
        .collect();
    args.extend(names.iter().map(String::as_str));
    args.extend(["--out", merged.to_str().unwrap()]);
    vio_ok(&args);
    let (a, b) = (files(&one), files(&merged));
    let names_a: Vec<&String> = a.iter().map(|f| &f.0).collect();
    assert_eq!(
        names_a,
        vec![
            "ate_rmse_m_vs_features.png",
            "ate_rmse_m_vs_pixel_sigma.png",
            "results.csv",
            "summary.csv",
            "summary.md",
            "sweep.json",
            "tracking_fraction_vs_features.png",
            "tracking_fraction_vs_pixel_sigma.png",
        ]
    );
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert!(
            x.1 == y.1,
            "{} differs between one process and merged shards",
            x.0
        );
    }
    // 2 × 2 points × 2 seeds, in run order, every metric present.
    let csv =
        String::from_utf8(a.iter().find(|f| f.0 == "results.csv").unwrap().1.clone()).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "run,point,seed,pixel_sigma,features,ate_rmse_m,tracking_fraction"
    );
    assert_eq!(lines.len(), 9);
    assert!(lines[1].starts_with("0,0,1,0.5,60,"), "{}", lines[1]);
    assert!(lines[8].starts_with("7,3,2,1.5,150,"), "{}", lines[8]);
    // A missing shard is an error, not a short result.
    let out = vio(&[
        "sweep-merge",
        &names[0],
        &names[1],
        "--out",
        dir.join("m2").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing"));
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_bad_sweep_file_exits_2_naming_the_key() {
    let dir = scratch("sweep-bad");
    let dir = dir.path();
    for (tag, text, key) in [
        (
            "seeds",
            SWEEP.replace("seeds = [1, 2]", "seeds = []"),
            "seeds",
        ),
        (
            "key",
            SWEEP.replace("rig.cameras[1].max_features", "rig.cameras[5].max_features"),
            "axes[1].keys[1]",
        ),
        (
            "value",
            SWEEP.replace("values = [0.5, 1.5]", "values = [0.5, -1.5]"),
            "rig.cameras[0].pixel_sigma_px",
        ),
        (
            "metric",
            SWEEP.replace("\"tracking_fraction\"]", "\"speed\"]"),
            "metrics",
        ),
        (
            "nan",
            SWEEP.replace("values = [0.5, 1.5]", "values = [0.5, nan]"),
            "axes[0].values[1]",
        ),
        (
            "inf-in-array",
            SWEEP.replace("values = [0.5, 1.5]", "values = [[0.5, 0.5], [1.5, inf]]"),
            "axes[0].values[1]",
        ),
        (
            "scale",
            SWEEP.replace(
                "values = [0.5, 1.5]",
                "scale = [1.0, -inf]\nvalues = [0.5, 1.5]",
            ),
            "axes[0].scale[1]",
        ),
        (
            "duplicate-name",
            SWEEP.replace("name = \"features\"", "name = \"pixel_sigma\""),
            "axes[1].name",
        ),
        (
            "target-metric",
            SWEEP.replacen(
                "[[axes]]",
                "[target]\nmetric = \"rpe_trans_rmse_m\"\nmax = 0.1\n\n[[axes]]",
                1,
            ),
            "target.metric",
        ),
        (
            "target-two-bounds",
            SWEEP.replacen(
                "[[axes]]",
                "[target]\nmetric = \"ate_rmse_m\"\nmax = 0.1\nmin = 0.0\n\n[[axes]]",
                1,
            ),
            "target",
        ),
        (
            "cost-negative",
            SWEEP.replace("values = [60, 150]", "values = [60, 150]\ncost = [1, -2]"),
            "axes[1].cost[1]",
        ),
        (
            "cost-length",
            SWEEP.replace("values = [60, 150]", "values = [60, 150]\ncost = [1]"),
            "axes[1].cost",
        ),
        (
            // 65 axes of 2 values: 2^65 points overflow a 64-bit count.
            "overflow",
            {
                let mut t = SWEEP.to_string();
                for i in 0..65 {
                    t += &format!(
                        "\n[[axes]]\nname = \"a{i}\"\nkeys = [\"world.seed\"]\nvalues = [1, 2]\n"
                    );
                }
                t
            },
            "more than the limit",
        ),
    ] {
        let f = write(dir, &format!("{tag}.toml"), &text);
        let out = vio(&[
            "sweep",
            f.to_str().unwrap(),
            "--out",
            dir.join("o").to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{tag}: {err}");
        assert!(err.contains(key), "{tag}: `{key}` not named: {err}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_whole_number_is_scaled_like_its_float_twin() {
    let dir = scratch("sweep-int-scale");
    let dir = dir.path();
    let base = SWEEP.replace(
        "values = [0.5, 1.5]",
        "scale = [0.5, 0.5]\nvalues = [VALUE]",
    );
    let pixel = |value: &str| {
        let f = write(dir, "s.toml", &base.replace("VALUE", value));
        let sweep = scenarios::studies::sweep::Sweep::load(&f).unwrap_or_else(|e| panic!("{e}"));
        let s = sweep.scenario(&[0, 0]).unwrap();
        s.spec.rig.cameras[0].pixel_sigma_px
    };
    assert_eq!(pixel("3"), 1.5);
    assert_eq!(pixel("3.0"), 1.5);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_merge_refuses_shard_results_it_cannot_trust_naming_file_and_line() {
    let dir = scratch("sweep-merge-bad");
    let dir = dir.path();
    let file = write(
        dir,
        "s.toml",
        &SWEEP.replace("seeds = [1, 2]", "seeds = [1]"),
    );
    let shard = dir.join("shard");
    let out = vio(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        shard.to_str().unwrap(),
        "--jobs",
        "1",
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(shard.join("results.csv")).unwrap();
    let json = std::fs::read_to_string(shard.join("sweep.json")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 5, "{csv}");
    // The last cell of row 2 (file line 3) replaced, a row beyond the sweep, a cut last row.
    let with_cell = |cell: &str| {
        let mut r: Vec<String> = rows.iter().map(|s| s.to_string()).collect();
        let mut cells: Vec<&str> = rows[2].split(',').collect();
        *cells.last_mut().unwrap() = cell;
        r[2] = cells.join(",");
        r.join("\n") + "\n"
    };
    let beyond = csv.clone() + &rows[4].replacen('3', "7", 1) + "\n";
    let cut = csv[..csv.len() - 3].to_string();
    for (tag, text, expect) in [
        (
            "nan",
            with_cell("NaN"),
            "results.csv:3: `NaN` is not a finite number",
        ),
        (
            "inf",
            with_cell("inf"),
            "results.csv:3: `inf` is not a finite number",
        ),
        (
            "beyond",
            beyond,
            "results.csv:6: run 7 is beyond the sweep's 4 runs",
        ),
        ("cut", cut, "truncated"),
    ] {
        let d = dir.join(tag);
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("results.csv"), text).unwrap();
        std::fs::write(d.join("sweep.json"), &json).unwrap();
        let out = vio(&[
            "sweep-merge",
            d.to_str().unwrap(),
            "--out",
            dir.join(format!("m-{tag}")).to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{tag}: {err}");
        assert!(err.contains(expect), "{tag}: `{expect}` not in: {err}");
        assert!(
            !dir.join(format!("m-{tag}")).exists(),
            "{tag}: wrote output"
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// Starts `vio sweep FILE --out OUT --shard SHARD --jobs 1`, waits until it has kept its first
/// finished run, then sends it `signal` (`INT`: Ctrl-C; `KILL`: a preempted batch job); returns
/// its exit code (None: killed) and how many runs it had kept.
fn interrupt_sweep(file: &str, out: &Path, shard: &str, signal: &str) -> (Option<i32>, usize) {
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vio"))
        .args(["sweep", file, "--out", out.to_str().unwrap()])
        .args(["--shard", shard, "--jobs", "1"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let kept = |out: &Path| {
        std::fs::read_dir(out.join("partial")).map_or(0, |d| {
            d.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".csv"))
            })
            .count()
        })
    };
    let started = std::time::Instant::now();
    while kept(out) == 0 {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the sweep ended before it could be interrupted"
        );
        assert!(
            started.elapsed().as_secs() < 300,
            "no run finished in 300 s"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let status = std::process::Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let code = child.wait().unwrap().code();
    (code, kept(out))
}

#[test]
fn an_interrupted_then_resumed_sharded_sweep_merges_byte_identical_to_an_uninterrupted_one() {
    let dir = scratch("sweep-resume");
    let dir = dir.path();
    // Longer runs than the other tests' (4 s): time to interrupt after the first of four.
    let file = write(
        dir,
        "s.toml",
        &SWEEP.replace("duration_s = 2.0", "duration_s = 4.0"),
    );
    let f = file.to_str().unwrap();
    let one = dir.join("one");
    vio_ok(&["sweep", f, "--out", one.to_str().unwrap(), "--jobs", "2"]);

    // Shard 0 gets Ctrl-C: it stops at once (130) keeping what finished.
    let s0 = dir.join("s0");
    let (code, kept) = interrupt_sweep(f, &s0, "0/2", "INT");
    assert_eq!(code, Some(130));
    assert!((1..4).contains(&kept), "{kept} of 4 runs kept");
    assert!(!s0.join("results.csv").exists());
    // Shard 1 is killed outright, as a preempted job is.
    let s1 = dir.join("s1");
    let (code, kept) = interrupt_sweep(f, &s1, "1/2", "KILL");
    assert_eq!(code, None);
    assert!((1..4).contains(&kept), "{kept} of 4 runs kept");
    // Without --resume the folders are refused, not mixed; --resume finishes them.
    let again = vio(&["sweep", f, "--out", s0.to_str().unwrap(), "--shard", "0/2"]);
    assert_eq!(again.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&again.stderr).contains("--resume"));
    for (d, shard) in [(&s0, "0/2"), (&s1, "1/2")] {
        let d = d.to_str().unwrap();
        vio_ok(&["sweep", f, "--out", d, "--shard", shard, "--resume"]);
    }
    assert!(!s0.join("partial").exists());
    let merged = dir.join("merged");
    vio_ok(&[
        "sweep-merge",
        s0.to_str().unwrap(),
        s1.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    let (a, b) = (files(&one), files(&merged));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.0, y.0);
        assert!(
            x.1 == y.1,
            "{} differs after interruption and resumption",
            x.0
        );
    }
    // A kept run that is not this sweep's is refused naming the file; --force starts over.
    let other = write(
        dir,
        "other.toml",
        &SWEEP.replace("seeds = [1, 2]", "seeds = [1, 3]"),
    );
    let wrong = vio(&[
        "sweep",
        other.to_str().unwrap(),
        "--out",
        one.to_str().unwrap(),
        "--resume",
    ]);
    assert_eq!(wrong.status.code(), Some(2));
    assert!(
        String::from_utf8_lossy(&wrong.stderr).contains("another sweep"),
        "{}",
        String::from_utf8_lossy(&wrong.stderr)
    );
    let tampered = dir.join("tampered");
    std::fs::create_dir_all(tampered.join("partial")).unwrap();
    std::fs::write(tampered.join("partial/run-3.csv"), "run,point\n3,1\n").unwrap();
    let out = vio(&["sweep", f, "--out", tampered.to_str().unwrap(), "--resume"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("partial/run-3.csv:1"), "{err}");
    vio_ok(&["sweep", f, "--out", tampered.to_str().unwrap(), "--force"]);
    assert!(!tampered.join("partial").exists());
}

/// The documented Slurm job array on a real single-node Slurm (Debian's slurm-wlm and munge,
/// installed and started by the script; root only): two shards submitted with `sbatch --array`,
/// merged, and byte-identical to the single-process sweep. Measured here: job 1, 42 s, 5 files
/// identical (`bash docs/sweeps/slurm/run-local.sh`).
#[test]
#[ignore = "starts slurmctld/slurmd as root and runs an 18-run sweep twice (~80 s)"]
fn the_slurm_job_array_runs_on_a_real_slurm_and_merges_to_the_single_process_bytes() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = std::process::Command::new("bash")
        .arg("docs/sweeps/slurm/run-local.sh")
        .current_dir(&root)
        .output()
        .expect("bash runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("cmp: merged Slurm array == single process"),
        "{stdout}"
    );
}

/// A sweep asking "which IMU grade and camera rate give 1 cm?" answers it: a table per point
/// (mean, worst seed, runs without a value, cost, pass) printed and written, the cheapest
/// passing point named; the 1 Hz camera never initializes in 4 s, and its runs count as
/// failed, not dropped. A log gets plain progress lines, not carriage returns.
#[test]
fn a_sweep_with_a_target_names_the_cheapest_passing_point_and_counts_runs_that_never_tracked() {
    let dir = scratch("sweep-target");
    let dir = dir.path();
    let file = write(
        dir,
        "design.toml",
        r#"
description = "IMU grade x camera rate for 1 cm"
scenario = "room_figure8_stereo_imu"
duration_s = 4.0
seeds = [1, 2]
metrics = ["ate_rmse_m", "tracking_fraction"]

[target]
metric = "ate_rmse_m"
max = 0.01

[[axes]]
name = "imu_grade"
keys = ["rig.imu.gyroscope_noise_density", "rig.imu.accelerometer_noise_density"]
scale = [1.6968e-4, 2.0e-3]
values = [30.0, 1.0]
labels = ["consumer", "ADIS16448"]
cost = [5, 500]

[[axes]]
name = "camera_rate_hz"
keys = ["rig.rate_hz"]
values = [1.0, 10.0, 20.0]
cost = [0, 10, 20]
"#,
    );
    let out = dir.join("out");
    let run = vio(&[
        "sweep",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(0));
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!stderr.contains('\r'), "{stderr}");
    assert!(
        stderr.contains("6/12 runs after ") && stderr.contains("12/12 runs after "),
        "{stderr}"
    );
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(stdout.contains(&md), "the table is printed: {stdout}");
    // Measured: the consumer grade misses 1 cm at 10 and 20 Hz (0.013, 0.011 m mean), the
    // ADIS16448 meets it at both (0.0051, 0.0056 m): 10 Hz is the cheaper.
    assert!(
        md.contains("cheapest point meeting ate_rmse_m ≤ 0.01: imu_grade = ADIS16448, camera_rate_hz = 10 (cost 510)"),
        "{md}"
    );
    assert!(
        md.contains("| consumer | 1 | — | — | 0 | 0 | ate_rmse_m 2 | 5 | FAIL |"),
        "the 1 Hz runs are counted: {md}"
    );
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 7, "{csv}");
    assert!(lines[1].starts_with("0,consumer,1,2,0,,,"), "{csv}");
    assert!(lines[1].ends_with(",false,5"), "{csv}");
    assert!(lines[5].ends_with(",true,510"), "{csv}");
}

/// Every example sweep the book names loads: its base scenario, keys and values check out.
#[test]
fn every_example_sweep_file_loads() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps");
    let mut n = 0;
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "toml") {
            scenarios::studies::sweep::Sweep::load(&p).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    assert!(n >= 9, "{n} sweep files in {}", dir.display());
}

/// An axis over the whole `rig.imu` table by module name gives each point that module's
/// densities, with the scenario's own keys it carries beside the name.
#[test]
fn a_sweep_over_imu_presets_gives_each_point_its_module() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/imu_presets.toml");
    let sweep = scenarios::studies::sweep::Sweep::load(&p).unwrap_or_else(|e| panic!("{e}"));
    let imu = |i: usize| sweep.scenario(&[i]).unwrap().spec.rig.imu;
    let (bmi160, adis16448) = (imu(0), imu(1));
    // TUM VI's BMI160 model and EuRoC's ADIS16448 sensor.yaml.
    assert_eq!(bmi160.accelerometer_noise_density, 2.8e-3);
    assert_eq!(adis16448.accelerometer_noise_density, 2.0e-3);
    assert_eq!(bmi160.initial_accel_bias_m_s2, [0.05, -0.04, 0.08]);
    assert!((bmi160.gyro_range_rad_s.unwrap() - 2000f64.to_radians()).abs() < 1e-9);
}
