//! `vio regress`: a baseline written from a run passes against the same run (the metrics are
//! deterministic), a deliberately degraded setting fails naming the metric in the table, on
//! stderr and in the JUnit XML, and a missing baseline is bad input.

use crate::common;

use common::{default_text, scratch, vio, write};

#[test]
fn a_degraded_setting_fails_naming_the_metric() {
    let dir = scratch("regress");
    let dir = dir.path();
    let catalog = dir.join("catalog");
    std::fs::create_dir_all(&catalog).unwrap();
    let text = default_text(6.0);
    write(&catalog, "short.toml", &text);
    let cat = catalog.to_str().unwrap();
    let junit = dir.join("junit.xml");

    // No baseline yet: exit 2 saying how to make one.
    let out = vio(&["regress", "--catalog", cat]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--update-baseline"));

    let out = vio(&["regress", "--catalog", cat, "--update-baseline"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(catalog.join("baseline.json").exists());

    let out = vio(&[
        "regress",
        "--catalog",
        cat,
        "--junit",
        junit.to_str().unwrap(),
    ]);
    let table = String::from_utf8_lossy(&out.stdout).into_owned();
    assert_eq!(out.status.code(), Some(0), "{table}");
    assert!(table.contains("7 checks, 0 regressed"), "{table}");
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains("tests=\"7\" failures=\"0\""), "{xml}");

    // A frame must see more observations than any frame has to be called tracked: nothing
    // tracks.
    write(
        &catalog,
        "short.toml",
        &(text + "\n[estimator]\nmin_tracking_observations = 100000\n"),
    );
    let out = vio(&[
        "regress",
        "--catalog",
        cat,
        "--junit",
        junit.to_str().unwrap(),
    ]);
    let table = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{table}");
    let row = table
        .lines()
        .find(|l| l.contains("tracking_fraction"))
        .unwrap();
    assert!(row.contains("REGRESSED"), "{table}");
    assert!(
        stderr.contains("short tracking_fraction: value 0.000000"),
        "{stderr}"
    );
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains("<testcase classname=\"short\" name=\"tracking_fraction\">\n      <failure message=\"short tracking_fraction: value 0.000000, baseline"),
        "{xml}"
    );
    // The ATE that can no longer be computed is a failure too.
    assert!(xml.contains("ate_rmse_m: value n/a"), "{xml}");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_baseline_that_compares_nothing_or_an_unwritable_junit_is_refused_before_running() {
    let dir = scratch("regress-refusals");
    let dir = dir.path();
    let catalog = dir.join("catalog");
    std::fs::create_dir_all(&catalog).unwrap();
    write(&catalog, "short.toml", &default_text(6.0));
    let cat = catalog.to_str().unwrap();
    let cases = [
        ("{\"scenarios\": {}}", "compares nothing"),
        (
            "{\"scenarios\": {\"other_catalogs_scenario\": {\"ate_rmse_m\": {\"value\": 0.01, \"rel\": 0.1, \"abs\": 0.001}}}}",
            "key `scenarios.other_catalogs_scenario`",
        ),
        (
            "{\"scenarios\": {\"short\": {\"ate_rmse_m\": {\"value\": 0.01, \"rel\": -1.0, \"abs\": 0.001}}}}",
            "key `scenarios.short.ate_rmse_m.rel`",
        ),
    ];
    for (text, expect) in cases {
        write(&catalog, "baseline.json", text);
        let out = vio(&["regress", "--catalog", cat]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{text}: {stderr}");
        assert!(stderr.contains("baseline.json"), "{stderr}");
        assert!(stderr.contains(expect), "{text}: {stderr}");
        // Refused before any scenario ran.
        assert!(!stderr.contains("running short"), "{stderr}");
    }
    write(
        &catalog,
        "baseline.json",
        "{\"scenarios\": {\"short\": {\"ate_rmse_m\": {\"value\": 0.01, \"rel\": 0.1, \"abs\": 0.001}}}}",
    );
    let junit = dir.join("no-such-folder").join("junit.xml");
    let out = vio(&[
        "regress",
        "--catalog",
        cat,
        "--junit",
        junit.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--junit"), "{stderr}");
    assert!(!stderr.contains("running short"), "{stderr}");
    let _ = std::fs::remove_dir_all(dir);
}
