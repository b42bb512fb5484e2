//! Our ATE/RPE equal evo's on the fixtures in `tests/fixtures/evo/{synthetic,mh01}`, whose
//! `expected.txt` holds evo's statistics at full precision (see the README there).

use std::path::{Path, PathBuf};

use scenarios::dataset::read_tum;
use scenarios::metrics::{Alignment, EvalOptions, PairsFrom, RpeOptions, Stats, evaluate};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/evo")
        .join(name)
}

/// `(name, stat, value)` rows of expected.txt.
fn expected(dir: &Path) -> Vec<(String, String, f64)> {
    let text = std::fs::read_to_string(dir.join("expected.txt")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            assert_eq!(f.len(), 3, "bad expected.txt line `{l}`");
            (f[0].to_string(), f[1].to_string(), f[2].parse().unwrap())
        })
        .collect()
}

fn stat(s: &Stats, name: &str) -> f64 {
    match name {
        "rmse" => s.rmse,
        "mean" => s.mean,
        "median" => s.median,
        "std" => s.std,
        "min" => s.min,
        "max" => s.max,
        "sse" => s.sse,
        _ => panic!("unknown statistic {name}"),
    }
}

/// Our statistics for one named evo command of `run_evo.sh`.
fn ours(dir: &Path, name: &str) -> Stats {
    let gt = read_tum(dir.join("gt.tum")).unwrap();
    let est = read_tum(dir.join("est.tum")).unwrap();
    let alignment = if name.starts_with("ape_none") {
        Alignment::None
    } else if name.contains("sim3") {
        Alignment::Sim3
    } else {
        Alignment::Se3
    };
    let rpe = if name.starts_with("rpe_1f") {
        RpeOptions::frames(1)
    } else {
        RpeOptions {
            all_pairs: name.contains("_all_"),
            pairs_from: if name.contains("_est_") {
                PairsFrom::Estimate
            } else {
                PairsFrom::Reference
            },
            ..RpeOptions::meters(1.0)
        }
    };
    let opts = EvalOptions {
        alignment,
        rpe: vec![rpe],
        ..EvalOptions::default()
    };
    let ev = evaluate(&gt, &est, &opts).unwrap();
    let rot = name.ends_with("rot_deg");
    if name.starts_with("ape") {
        if rot {
            ev.ate.rotation_deg
        } else {
            ev.ate.translation
        }
    } else {
        let r = ev.rpe[0].as_ref().unwrap();
        if rot { r.rotation_deg } else { r.translation }
    }
}

fn check(dir_name: &str) {
    let dir = fixture(dir_name);
    let rows = expected(&dir);
    assert!(rows.len() >= 70, "expected.txt looks truncated");
    let mut worst = 0.0f64;
    for (name, s, v) in rows {
        let got = stat(&ours(&dir, &name), &s);
        let diff = (got - v).abs();
        // 1e-6 (m or deg); sums of squares scale with the pose count.
        let tol = if s == "sse" {
            1e-6 * v.abs().max(1.0)
        } else {
            1e-6
        };
        assert!(
            diff <= tol,
            "{dir_name} {name} {s}: ours {got} evo {v} (diff {diff:e})"
        );
        if s != "sse" {
            worst = worst.max(diff);
        }
    }
    eprintln!("{dir_name}: largest difference to evo {worst:e}");
}

#[test]
fn ate_and_rpe_match_evo_on_synthetic_fixture() {
    check("synthetic");
}

#[test]
fn ate_and_rpe_match_evo_on_euroc_mh01_fixture() {
    check("mh01");
}
