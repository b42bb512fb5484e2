//! The aiding sensors as window factors, on their catalog scenarios (seed 1): GNSS fixes keep
//! the fused position in the receiver's frame within the receiver's noise, through an outage,
//! a removal and a bias jump; wheel odometry lowers the drift of a ground vehicle.

use crate::common;

use common::{run_catalog, run_edited};
use scenarios::report::Report;

/// The largest global error of the report's series over `[from_s, to_s)`.
fn max_error(report: &Report, from_s: f64, to_s: f64) -> f64 {
    let g = report.gnss.as_ref().expect("a gnss block");
    g.global_error_series
        .iter()
        .filter(|[t, _]| *t >= from_s && *t < to_s)
        .map(|[_, e]| *e)
        .fold(0.0, f64::max)
}

fn gnss_events(report: &Report) -> Vec<(f64, &str)> {
    report
        .events
        .iter()
        .filter(|e| e.kind.starts_with("gnss"))
        .map(|e| (e.t_s, e.kind))
        .collect()
}

#[test]
fn the_fused_position_stays_within_the_receiver_noise_without_any_trajectory_alignment() {
    let done = run_catalog("outdoor_figure8_gnss_stereo_imu", None);
    let g = done.report.gnss.as_ref().expect("aligned");
    // Receiver σ 0.3 m horizontal, 0.5 m vertical. Measured: aligned at 4.2 s, RMSE 0.061 m,
    // max 0.175 m (at the start, while the alignment is young), final 0.051 m (seeds 2, 3:
    // RMSE 0.076, 0.076 m). Bounds: measured + about 70 %, both well below the receiver's σ.
    assert!(g.aligned_at_s < 6.0, "{g:?}");
    assert!(g.global_rmse_m < 0.1, "{g:?}");
    assert!(g.global_max_m < 0.3, "{g:?}");
    assert_eq!(
        gnss_events(&done.report),
        vec![(g.aligned_at_s, "gnss_aligned")]
    );
    assert_eq!(done.report.resets, 0);
}

#[test]
fn a_20_s_outage_is_bridged_and_the_fixes_pull_the_estimate_back() {
    let done = run_catalog("outdoor_figure8_gnss_outage_stereo_imu", None);
    // Measured (outage 20-40 s): largest error 0.146 m before it, 0.118 m during it, 0.132 m in
    // the 10 s after it, 0.071 m over the last 10 s (the same run without the outage: 0.056 m);
    // no fix rejected on its return.
    assert!(max_error(&done.report, 20.0, 40.0) < 0.25);
    assert!(max_error(&done.report, 50.0, 61.0) < 0.12);
    assert_eq!(gnss_events(&done.report).len(), 1, "no re-alignment");
    assert!(done.report.ate_rmse_m.unwrap() < 0.08); // measured 0.0494
}

#[test]
fn a_receiver_removed_mid_run_leaves_the_odometry_running() {
    let report = run_edited("outdoor_figure8_gnss_stereo_imu", None, |text| {
        text.replace(
            "[expectations]",
            "[[faults]]\nkind = \"gnss_outage\"\nstart_s = 30.0\nend_s = 1000.0\n\n[expectations]",
        )
    })
    .run
    .report;
    // Measured: ATE 0.0452 m, largest global error after the removal 0.111 m (the alignment
    // keeps what the fixes taught it; the odometry drifts from there).
    assert_eq!(report.resets, 0);
    assert!(report.ate_rmse_m.unwrap() < 0.08);
    assert!(max_error(&report, 30.0, 61.0) < 0.25);
}

#[test]
fn a_bias_jump_is_rejected_and_the_alignment_found_again_without_dragging_the_odometry() {
    let done = run_catalog("outdoor_figure8_gnss_bias_jump_stereo_imu", None);
    // Jump of (2, -1, 0) m at 30 s: 20 fixes rejected in a row, the alignment dropped at
    // 31.9 s and found again at 37.25 s from the new fixes. ATE 0.0615 m (0.0561 m without any
    // GNSS; 0.48 m when the fixes were only Huber-weighted: they dragged the odometry).
    let events = gnss_events(&done.report);
    assert_eq!(events.len(), 3, "{events:?}");
    assert_eq!(events[1].1, "gnss_alignment_dropped");
    assert!(events[1].0 > 30.0 && events[1].0 < 33.0, "{events:?}");
    assert_eq!(events[2].1, "gnss_aligned");
    assert!(done.report.ate_rmse_m.unwrap() < 0.08);
    // Afterwards the fused position follows the receiver's new frame: 2.24 m off the truth,
    // which nothing on board can tell apart.
    let after = max_error(&done.report, 40.0, 61.0);
    assert!((after - 5f64.sqrt()).abs() < 0.2, "{after}");
}

#[test]
fn wheel_odometry_lowers_the_drift_of_a_ground_vehicle() {
    let with = run_catalog("hall_ground_vehicle_wheel_stereo_imu", None);
    let without = run_catalog("hall_ground_vehicle_stereo_imu", None);
    let (a, b) = (
        with.report.ate_rmse_m.unwrap(),
        without.report.ate_rmse_m.unwrap(),
    );
    // Three loops, 120 s: 0.0235 m with the wheels, 0.0288 m without (0.82×; seeds 2, 3:
    // 0.0177 against 0.0193, 0.0237 against 0.0269). Over the first loop alone (40 s) the
    // difference is within the seeds' spread since drifted points leave the prior (seeds 1–3:
    // 0.0137 / 0.0131 / 0.0138 against 0.0166 / 0.0127 / 0.0145 m; 0.0151 against 0.0185 m
    // before). Asserted: at least 10 % lower.
    assert!(a < 0.9 * b, "with {a}, without {b}");
    assert_eq!(with.report.resets + without.report.resets, 0);
}

#[test]
fn wheel_odometry_gives_the_scale_of_a_monocular_ground_vehicle() {
    let with = run_catalog("hall_ground_vehicle_wheel_mono_imu", None);
    let without = run_catalog("hall_ground_vehicle_mono_imu", None);
    // On level ground at near-constant speed the accelerometer barely sees the scale; the
    // wheels measure it, in the initial visual-inertial alignment too. With them (seed 1,
    // 60 s): initialized at 3.3 s (94.6 % of the frames tracking), ATE 0.0274 m (seeds 2, 3:
    // 0.0273 / 0.0250; 0.0182 / 0.0400 / 0.0770 with drifted points kept in the prior).
    // Without them the scale never passes the initialization's 3 % gate and the estimator does
    // not start (it started at 21.6 s into 0.31 m with a 5 % gate).
    let a = with.report.ate_rmse_m.unwrap();
    assert!(a < 0.05, "with the wheels {a}");
    assert!(with.report.tracking_fraction > 0.9);
    assert_eq!(without.report.tracking_fraction, 0.0);
    assert!(without.report.ate_rmse_m.is_none());
    assert_eq!(with.report.resets + without.report.resets, 0);
}
