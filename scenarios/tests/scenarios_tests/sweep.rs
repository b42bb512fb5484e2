//! `vio sweep`: shards merged equal one process's output byte for byte (results, definition,
//! plots), the thread count changes nothing, and a bad sweep file exits 2 naming the key.

use crate::common;

use std::path::Path;

use common::{scratch, vio, write};

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
    let run = |args: &[&str]| {
        let out = vio(args);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    };
    let one = dir.join("one");
    run(&["sweep", f, "--out", one.to_str().unwrap(), "--jobs", "2"]);
    let mut shards = Vec::new();
    for i in 0..3 {
        let d = dir.join(format!("shard{i}"));
        let shard = format!("{i}/3");
        run(&[
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
    run(&args);
    let (a, b) = (files(&one), files(&merged));
    let names_a: Vec<&String> = a.iter().map(|f| &f.0).collect();
    assert_eq!(
        names_a,
        vec![
            "ate_rmse_m_vs_features.png",
            "ate_rmse_m_vs_pixel_sigma.png",
            "results.csv",
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
