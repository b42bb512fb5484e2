//! Reports: metrics that cannot be computed are `null`, not failures; the numbers equal
//! `metrics::evaluate` on the TUM files the report writes.

use scenarios::dataset::read_tum;
use scenarios::metrics::{Alignment, EvalOptions, RpeOptions, evaluate};
use scenarios::pipeline::run_scenario;
use scenarios::report;
use scenarios::run::RunOptions;
use scenarios::spec::Scenario;

#[test]
fn short_run_has_no_rpe_and_matches_eval_of_its_files() {
    // 1 s of the default scenario: tracking from ~0.45 s, well under 1 m of path while tracking.
    let scenario = Scenario::load(scenarios::catalog::DEFAULT).unwrap();
    let options = RunOptions {
        seed: None,
        duration_s: Some(1.0),
        ..Default::default()
    };
    let run = run_scenario(&scenario, &options).unwrap();
    let (eval, rep) = (&run.evaluation, &run.report);
    assert_eq!(eval.alignment, Alignment::PosYaw);
    assert!(!eval.evaluated.is_empty(), "no tracking frames in 1 s");
    assert!(eval.rpe.is_err());
    assert_eq!(rep.rpe_trans_rmse_m, None);
    assert!(report::summary(rep, None).contains("RPE (1 m)     n/a"));
    let ate = rep.ate_rmse_m.expect("ATE with tracking frames");

    let dir = tempfile::tempdir().unwrap();

    let dir = dir.path();
    run.write_outputs(dir).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    assert!(json["rpe_trans_rmse_m"].is_null());
    assert_eq!(json["rpe_delta_m"], 1.0);
    assert_eq!(json["alignment"], "position_yaw");

    // The files hold the exact values, so evaluating them gives the report's numbers.
    let gt = read_tum(dir.join("groundtruth.tum")).unwrap();
    let est = read_tum(dir.join("estimate.tum")).unwrap();
    assert_eq!(est.len(), eval.evaluated.len());
    assert_eq!(gt.len(), run.output.frames.len());
    let ev = evaluate(
        &gt,
        &est,
        &EvalOptions {
            alignment: Alignment::PosYaw,
            rpe: vec![RpeOptions::meters(1.0)],
            ..EvalOptions::default()
        },
    )
    .unwrap();
    assert_eq!(ev.matched.pairs.len(), est.len());
    assert!((ev.ate.translation.rmse - ate).abs() < 1e-12);
    assert!(
        (ev.ate.rotation_deg.rmse - rep.ate_rot_rmse_deg.unwrap()).abs() < 1e-9,
        "{} vs {:?}",
        ev.ate.rotation_deg.rmse,
        rep.ate_rot_rmse_deg
    );
    assert!(ev.rpe[0].is_err());
    let _ = std::fs::remove_dir_all(dir);
}

/// A calibration error (`rig.cameras[i].calibration_error`, `rig.time_offset_s`) reaches the
/// estimator, not the simulator, and `report.json` → `calibration` measures it: with online
/// estimation off the errors stay exactly what was configured (|[1.2, −1.2, 1.0]°| = 1.9698°,
/// |[12, −12, 10] mm| = 19.70 mm, −10 ms). Scenarios that do not study calibration have no block.
#[test]
fn calibration_errors_are_reported_against_the_truth() {
    let scenario = Scenario::catalog_edited(scenarios::catalog::DEFAULT, |text| {
        text.replace("time_offset_s = 0.0", "time_offset_s = 0.01")
        // Held at 0: the report's errors are then known exactly.
        .replace(
            "[expectations]",
            "[estimator]\nestimate_td = false\n\n[expectations]",
        )
        .replace(
            "pixel_sigma_px = 1.0",
            "pixel_sigma_px = 1.0\ncalibration_error = { rotation_deg = [1.2, -1.2, 1.0], translation_m = [0.012, -0.012, 0.01] }",
        )
    })
    .unwrap();
    let truth = scenario.calibration_truth().unwrap();
    assert_eq!(truth.td_s, 0.01);
    let est = scenario.estimator_config().unwrap();
    let angle = (truth.T_b_c[0].q.inverse() * est.cameras[0].T_b_c.q)
        .angle()
        .to_degrees();
    assert!((angle - 1.9698).abs() < 1e-3, "{angle}");
    let options = RunOptions {
        duration_s: Some(3.0),
        ..Default::default()
    };
    let run = run_scenario(&scenario, &options).unwrap();
    let rep = &run.report;
    let c = rep.calibration.as_ref().expect("a calibration block");
    assert_eq!(c.td_true_ms, 10.0);
    assert!((c.td_error_ms + 10.0).abs() < 1e-9);
    assert_eq!(c.cameras.len(), 2);
    for cam in &c.cameras {
        assert!((cam.rotation_error_deg - 1.9698).abs() < 1e-3, "{cam:?}");
        assert!((cam.translation_error_mm - 19.698).abs() < 1e-2, "{cam:?}");
    }
    assert_eq!(c.history.len(), 3, "one sample per second");
    assert!(report::summary(rep, None).contains("calibration   final td error -10.000 ms"));

    // Stereo only: no IMU, so no time offset is estimated, and nothing else is studied.
    let plain = Scenario::load("room_figure8_stereo").unwrap();
    assert!(plain.calibration_truth().is_none());
    // The default estimates the offset; a `camera_time_offset` fault steps its truth.
    let default = Scenario::load(scenarios::catalog::DEFAULT).unwrap();
    assert_eq!(default.calibration_truth().unwrap().td_at(0), 0.0);
    let stepped = Scenario::catalog_edited(scenarios::catalog::DEFAULT, |text| {
        text.replace(
            "[rig]",
            "[[faults]]\nkind = \"camera_time_offset\"\nat_s = 10.0\ntd_s = 0.015\n\n[rig]",
        )
    })
    .unwrap();
    let truth = stepped.calibration_truth().unwrap();
    assert_eq!(truth.td_at(9_999_999_999), 0.0);
    assert_eq!(truth.td_at(10_000_000_000), 0.015);
}
