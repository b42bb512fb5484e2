//! Reports: metrics that cannot be computed are `null`, not failures; the numbers equal
//! `metrics::evaluate` on the TUM files the report writes.

use scenarios::dataset::read_tum;
use scenarios::metrics::{Alignment, EvalOptions, RpeOptions, evaluate};
use scenarios::report;
use scenarios::run::{RunOptions, run};
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
    let output = run(&scenario, &options, &mut |_| {}).unwrap();
    let eval = report::evaluate(&output, scenario.spec.suite);
    let rep = report::build_report(&scenario, &output, &eval);
    assert_eq!(eval.alignment, Alignment::PosYaw);
    assert!(!eval.evaluated.is_empty(), "no tracking frames in 1 s");
    assert!(eval.rpe.is_err());
    assert_eq!(rep.rpe_trans_rmse_m, None);
    assert!(report::summary(&rep, None).contains("RPE (1 m)     n/a"));
    let ate = rep.ate_rmse_m.expect("ATE with tracking frames");

    let dir = std::env::temp_dir().join(format!("vio-report-test-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    report::write_outputs(&dir, &scenario, &output, &eval, &rep).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap();
    assert!(json["rpe_trans_rmse_m"].is_null());
    assert_eq!(json["rpe_delta_m"], 1.0);
    assert_eq!(json["alignment"], "position_yaw");

    // The files hold the exact values, so evaluating them gives the report's numbers.
    let gt = read_tum(dir.join("groundtruth.tum")).unwrap();
    let est = read_tum(dir.join("estimate.tum")).unwrap();
    assert_eq!(est.len(), eval.evaluated.len());
    assert_eq!(gt.len(), output.frames.len());
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
