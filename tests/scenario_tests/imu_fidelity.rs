//! The fidelity of the simulated IMU (docs/src/real-data.md, "the fidelity table"): on the whole
//! EuRoC V1_01 replay with the same simulated cameras, the IMU model fitted to the real log
//! (`euroc_mav`) predicts the real log's ATE within 0.7–1.4× (mean over seeds 1–5), and the
//! datasheet model does not. Fifteen 145 s runs (about 5 min on one core): ignored by default,
//! `cargo test --release --test scenario_tests imu_fidelity:: -- --ignored --nocapture`.

use crate::common;

use scenarios::spec::Scenario;

use common::run_seeded;

/// Mean ATE (m) of catalog scenario `name` over seeds 1–5, and the runs' resets.
fn mean_ate(name: &str) -> (f64, Vec<usize>) {
    let mut ates = Vec::new();
    let mut resets = Vec::new();
    for seed in 1..=5 {
        let scenario = Scenario::load(name).unwrap_or_else(|e| panic!("{e}"));
        let done = run_seeded(scenario, Some(seed), None);
        let r = &done.report;
        assert!(
            r.tracking_fraction > 0.95,
            "{name} seed {seed}: {}",
            r.tracking_fraction
        );
        ates.push(r.ate_rmse_m.expect("an ATE"));
        resets.push(r.resets);
    }
    println!("{name}: ATE {ates:?}, resets {resets:?}");
    (ates.iter().sum::<f64>() / ates.len() as f64, resets)
}

#[test]
#[ignore = "fifteen whole-flight runs: cargo test --release --test scenario_tests imu_fidelity:: -- --ignored"]
fn the_fitted_imu_predicts_the_real_ate_and_the_datasheet_does_not() {
    let (real, real_resets) = mean_ate("room_replay_v1_01_real_imu_stereo_imu");
    let (fitted, fitted_resets) = mean_ate("room_replay_v1_01_fitted_imu_stereo_imu");
    let (datasheet, _) = mean_ate("room_replay_v1_01_datasheet_imu_stereo_imu");
    let (rf, rd) = (fitted / real, datasheet / real);
    println!(
        "real {real:.4} m; fitted {fitted:.4} m ({rf:.2}×); datasheet {datasheet:.4} m ({rd:.2}×)"
    );
    // Measured at the default (100 inverse-distance points, drifted ones released from the
    // prior; 2026-11-28): real 0.0193 m, fitted 0.0164 m (0.85×); resets real 0 / 1 / 0 / 0 / 0,
    // fitted 1 / 0 / 1 / 1 / 1, every one the IMU χ² test a little above its threshold (264–286
    // against 247): the window's 100 points hold its frames to the cameras, which follow the
    // smoothed ground truth, and the IMU's residuals show against them in full. Without the
    // release: real 0.0199 m, fitted 0.0189 m (0.95×), resets real 0 / 1 / 0 / 1 / 0, fitted
    // 2 / 0 / 1 / 1 / 1. At 30 world points: real 0.0263 m, fitted 0.0219 m (0.83×), datasheet
    // 0.0057 m (0.22×); resets real none, fitted one (seed 1).
    assert!((0.7..=1.4).contains(&rf), "fitted / real {rf}");
    assert!(rd < 0.5, "datasheet / real {rd}");
    assert!(real_resets.iter().all(|r| *r <= 1), "{real_resets:?}");
    assert!(fitted_resets.iter().all(|r| *r <= 1), "{fitted_resets:?}");
}
