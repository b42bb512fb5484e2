//! Online calibration. The time offset on the default motion (60 s, seed 1): it is estimated
//! through image velocities predicted from the window's motion (`time_offset.rs`); with the
//! track's previous pixel displacement as the velocity it went from −10 to −7.6 ms in 60 s and
//! wandered 2.5 ms from the truth. Extrinsics from the truth after the warm-up, and the issue's
//! whole perturbed start (10 ms, 2°, 2 cm) on a tilting motion.

mod common;

use common::run_scenario;
use scenarios::report::{self, Report};
use scenarios::spec::{Origin, Scenario};

fn run_with_td(true_td_s: f64) -> Report {
    let text = scenarios::catalog::get(scenarios::catalog::DEFAULT)
        .unwrap()
        .text
        .replace(
            "time_offset_s = 0.0",
            &format!("time_offset_s = {true_td_s:?}"),
        );
    let text = text.replace(
        "[expectations]",
        "[estimator]\nestimate_td = true\n\n[expectations]",
    );
    let scenario = Scenario::parse("td", Origin::Catalog, &text).unwrap();
    run_scenario(scenario, None).report
}

#[test]
fn td_estimation_converges_and_stays_at_the_truth() {
    // Measured (seed 1): from the truth, at most 1.45 ms off after 20 s, final +0.17 ms, ATE
    // 0.0066 m; from a −10 ms error, −1.3 ms at 30 s and −0.54 ms at the end, ATE 0.0066 m.
    let from_truth = run_with_td(0.0);
    let c = from_truth.calibration.as_ref().unwrap();
    for s in c.history.iter().filter(|s| s.t_s >= 20.0) {
        assert!(s.td_error_ms.abs() < 2.0, "{s:?}");
    }
    assert!(c.td_error_ms.abs() < 0.5, "final {} ms", c.td_error_ms);
    assert!(from_truth.ate_rmse_m.unwrap() < 0.009);

    let from_error = run_with_td(0.01);
    let c = from_error.calibration.as_ref().unwrap();
    assert_eq!(c.history[0].td_error_ms, -10.0);
    for s in c.history.iter().filter(|s| s.t_s >= 30.0) {
        assert!(s.td_error_ms.abs() < 2.0, "{s:?}");
    }
    assert!(
        c.td_error_ms.abs() < 1.0,
        "from −10 ms to {} ms",
        c.td_error_ms
    );
    assert!(from_error.ate_rmse_m.unwrap() < 0.009);
}

#[test]
fn extrinsic_estimation_waits_for_its_warm_up_and_stays_near_the_truth() {
    // Default motion, seed 1, 20 s, estimation from the true extrinsics. Before the prior,
    // the IMU-only gate and the 3 s warm-up they left for metres within a second; with the
    // prior alone 2.4° / 35 mm within 20 s. Measured now: at most 0.12° / 5.6 mm (30 s).
    let text = scenarios::catalog::get(scenarios::catalog::DEFAULT)
        .unwrap()
        .text
        .replace(
            "[expectations]",
            "[estimator]\nestimate_extrinsics = true\n\n[expectations]",
        );
    let scenario = Scenario::parse("extrinsics", Origin::Catalog, &text).unwrap();
    let done = run_scenario(scenario, Some(20.0));
    let r = &done.report;
    let c = r.calibration.as_ref().unwrap();
    // Initialization at about 0.5 s, then 3 s of warm-up: untouched at 1, 2 and 3 s.
    for s in &c.history[..4] {
        assert_eq!(s.rotation_error_deg, 0.0, "{s:?}");
    }
    assert!(c.history.iter().skip(5).any(|s| s.rotation_error_deg > 0.0));
    for s in &c.history {
        assert!(
            s.rotation_error_deg < 0.2 && s.translation_error_mm < 8.0,
            "{s:?}"
        );
    }
    assert_eq!(r.resets, 0);
    assert!(r.ate_rmse_m.unwrap() < 0.012);
    // A run that studies calibration draws its errors over time.
    let dir = std::env::temp_dir().join(format!("vio-calibration-{}", std::process::id()));
    report::write_outputs(&dir, &done.scenario, &done.output, &done.eval, r).unwrap();
    let png = std::fs::read(dir.join("calibration.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "not a PNG");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn calibration_converges_from_the_perturbed_start_on_a_tilting_motion() {
    // The calibration issue's perturbed start: a 10 ms time offset and both cameras off by
    // [1.2, −1.2, 1.0]° and [12, −12, 10] mm (1.97° / 19.7 mm), on a motion whose roll and pitch
    // swing ±0.5 rad at 0.2 Hz, everything free from the start. Measured after 30 s, seeds
    // 1 / 2 / 3: td at most 0.27 / 0.12 / 0.15 ms, rotation 0.033 / 0.027 / 0.025°, translation
    // 3.5 / 3.0 / 2.2 mm. Bounds: the 0.5 ms and 5 mm, its 0.1° halved.
    let scenario = Scenario::load("room_lissajous_calibration_stereo_imu").unwrap();
    let r = run_scenario(scenario, Some(40.0)).report;
    let c = r.calibration.as_ref().unwrap();
    let first = &c.history[0];
    assert!((first.rotation_error_deg - 1.97).abs() < 0.01, "{first:?}");
    assert!((first.translation_error_mm - 19.7).abs() < 0.1, "{first:?}");
    assert_eq!(first.td_error_ms, -10.0);
    let late: Vec<_> = c.history.iter().filter(|s| s.t_s >= 30.0).collect();
    assert!(late.len() >= 9);
    for s in late {
        assert!(
            s.td_error_ms.abs() < 0.5
                && s.rotation_error_deg < 0.05
                && s.translation_error_mm < 5.0,
            "{s:?}"
        );
    }
    assert_eq!(r.resets, 0);
}
