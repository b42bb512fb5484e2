//! A rolling-shutter rig: with the estimator's model a 20 ms readout costs about what a global
//! shutter does; without it, the rows' motion shows in the trajectory.

use crate::common::{self, catalog_edited};

/// The default figure-eight with both cameras reading out over `readout_ms`, the estimator's
/// model on or off; its ATE (m) on `seed`, 30 s.
fn ate(readout_ms: f64, modelled: bool, seed: u64) -> f64 {
    let scenario = catalog_edited("room_figure8_stereo_imu", |text| {
        let with_shutter = text.replace(
            "pixel_sigma_px = 1.0",
            &format!("pixel_sigma_px = 1.0\nrolling_shutter = {{ readout_ms = {readout_ms:?} }}"),
        );
        assert_ne!(with_shutter, text, "the catalog scenario's cameras changed");
        format!("{with_shutter}\n[estimator]\nmodel_rolling_shutter = {modelled}\n")
    });
    let done = common::run_seeded(scenario, Some(seed), Some(30.0));
    assert!(
        done.report.passed,
        "seed {seed}: the run failed its expectations"
    );
    done.report.ate_rmse_m.expect("an ATE")
}

#[test]
fn a_modelled_20_ms_readout_costs_what_a_global_shutter_does() {
    // Measured (seeds 1, 2, 3; global / modelled / not modelled, m): 0.0069 / 0.0073 / 0.0133,
    // 0.0080 / 0.0073 / 0.0119, 0.0056 / 0.0057 / 0.0112.
    let mut unmodelled_over_modelled = Vec::new();
    for seed in [1, 2] {
        let global = ate(0.0, true, seed);
        let modelled = ate(20.0, true, seed);
        let ignored = ate(20.0, false, seed);
        println!(
            "seed {seed}: global {global:.4} m, modelled {modelled:.4} m, ignored {ignored:.4} m"
        );
        assert!(
            modelled <= 1.3 * global,
            "seed {seed}: {modelled} vs {global}"
        );
        unmodelled_over_modelled.push(ignored / modelled);
    }
    // Ignoring the readout costs 1.6–2× here: the test sees the shutter, not noise.
    assert!(
        unmodelled_over_modelled.iter().all(|r| *r > 1.3),
        "{unmodelled_over_modelled:?}"
    );
}
