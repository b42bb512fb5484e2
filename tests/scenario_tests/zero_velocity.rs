//! Zero-velocity detection on a motion with stops (`room_figure8_stops_stereo_imu`, first
//! 20 s: one 4 s rest from 11 to 15 s) and on the moving default motion: rest is found from the
//! IMU and the images together, never while moving.

use crate::common;

use common::{run_catalog, run_scenario};
use scenarios::spec::Scenario;

#[test]
fn rest_is_detected_from_the_imu_and_the_images_and_never_while_moving() {
    let done = run_catalog("room_figure8_stops_stereo_imu", Some(20.0));
    let rest = done.report.rest.as_ref().expect("a rest block");
    // Seed 1: 77–78 of the 81–82 frames at rest detected; the 4 missed are the first of the
    // rest, inside the 0.25 s the test needs (seeds 2, 3: 78 of 81). None while moving. The
    // truth is read at each estimate's time, which the estimated time offset shifts: a frame
    // at an edge of the rest counts on either side.
    assert!((81..=82).contains(&rest.frames_at_rest), "{rest:?}");
    assert!(rest.frames_detected >= 76, "{rest:?}");
    assert_eq!(rest.false_detections, 0, "{rest:?}");
    assert_eq!(rest.rests.len(), 1);
    // The causal estimate moved 8.2 mm between the first and last frame at rest (seeds 2, 3:
    // 8.3, 6.3 mm; with the time offset held at 0: 6.8, 14.4, 4.4 mm). Vision holds the
    // position at rest, the factors add the zero velocity and the gyroscope bias. Bound:
    // measured + 40 %.
    assert!(rest.max_drift_m.unwrap() < 0.0115, "{rest:?}");
    assert!(done.report.ate_rmse_m.unwrap() < 0.0095); // measured 0.0068
}

/// The default scenario with zero-velocity detection on and the figure-eight's period set.
fn default_with_detection(period_s: f64) -> Scenario {
    common::catalog_edited(scenarios::catalog::DEFAULT, |text| {
        text.replace("period_s = 20.0", &format!("period_s = {period_s:?}"))
            .replace(
                "[expectations]",
                "[estimator.zero_velocity]\nenabled = true\n\n[expectations]",
            )
    })
}

#[test]
fn nothing_is_detected_at_rest_on_a_moving_run() {
    // The default figure-eight never stops: with the detector on, no frame may be called at
    // rest, and the run is the one without it (ATE 0.0065 m over 20 s).
    let done = run_scenario(default_with_detection(20.0), Some(20.0));
    let r = &done.report;
    assert!(r.rest.is_none(), "{:?}", r.rest);
    assert!(done.output.frames.iter().all(|f| !f.estimate.at_rest));
    let plain = run_catalog("room_figure8_stereo_imu", Some(20.0));
    assert_eq!(r.ate_rmse_m, plain.report.ate_rmse_m);
}

#[test]
fn a_slow_creep_is_not_called_at_rest() {
    // The default figure-eight slowed to a 400 s period: about 3 cm/s with hardly any turn,
    // which the IMU and 0.25 s of 1 px features cannot tell from rest. Before the window's
    // speed was consulted every frame was declared at rest: 7 resets, ATE 0.20 m (0.012 m
    // without the factor). Now none is (seed 1, 20 s).
    let done = run_scenario(default_with_detection(400.0), Some(20.0));
    assert!(done.output.frames.iter().all(|f| !f.estimate.at_rest));
    assert_eq!(done.report.resets, 0);
}

#[test]
fn overlapping_stops_are_refused_naming_the_key() {
    let err = Scenario::catalog_edited("room_figure8_stops_stereo_imu", |text| {
        text.replace("at_s = 28.0", "at_s = 15.0")
    })
    .unwrap_err();
    let message = err.to_string();
    assert!(
        message.contains("trajectory.stops[1].at_s") && message.contains("before the previous"),
        "{message}"
    );
}
