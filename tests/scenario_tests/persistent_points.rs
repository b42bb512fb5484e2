//! Persistent points' first estimates: a point in inverse distance whose first estimate turned
//! out far off leaves the prior (`release_drifted_points`, `estimator/src/odometry/
//! relinearization.rs`) instead of carrying that estimate in its Jacobians for as long as it
//! lives.

use crate::common;

/// The hall's stereo ground vehicle (seed 1, 60 s) sees many of its points first from afar
/// and badly placed: kept at their first estimates (`release_drifted_points = false`), ATE
/// 0.0471 m; released once they drift 10 % of their range (the default), 0.0288 m (seeds 2 / 3:
/// 0.0251 → 0.0193, 0.0355 → 0.0269 m). Asserted: at least a quarter lower (measured 39 %), no
/// reset.
#[test]
fn releasing_drifted_points_lowers_the_drift_of_a_ground_vehicle() {
    let name = "hall_ground_vehicle_stereo_imu";
    let released = common::run_catalog(name, None);
    let kept = common::run_edited(name, None, |text| {
        text.replacen(
            "[expectations]",
            "[estimator]\nrelease_drifted_points = false\n\n[expectations]",
            1,
        )
    });
    let (a, b) = (
        released.report.ate_rmse_m.unwrap(),
        kept.report.ate_rmse_m.unwrap(),
    );
    assert!(a < 0.75 * b, "released {a} m, kept {b} m");
    assert_eq!(released.report.resets + kept.report.resets, 0);
}
