//! Online calibration, gated by what the window observes (`estimator/src/odometry/
//! calibration_gates.rs`): the time offset on the default motion (60 s, seed 1), estimated through
//! image velocities predicted from the window's motion (`time_offset.rs`; with the track's
//! previous pixel displacement it went from −10 to −7.6 ms in 60 s); extrinsics from the truth,
//! where the figure-eight determines the rotation but not the translation; the whole
//! perturbed start (10 ms, 2°, 2 cm) on a tilting motion.

use crate::common;

use common::{run_edited, run_scenario};
use scenarios::report::Report;
use scenarios::spec::Scenario;

fn run_with_td(true_td_s: f64) -> Report {
    run_edited(scenarios::catalog::DEFAULT, None, |text| {
        text.replace(
            "time_offset_s = 0.0",
            &format!("time_offset_s = {true_td_s:?}"),
        )
        .replace(
            "[expectations]",
            "[estimator]\nestimate_td = true\ncompute_covariance = true\n\n[expectations]",
        )
    })
    .run
    .report
}

#[test]
fn td_estimation_converges_and_stays_at_the_truth() {
    // Measured (seed 1): the offset is held at its configured value until the window alone
    // determines it to 0.67 ms (38.8 s), or until the data contradict the configured value (the
    // free estimate 3 σ from it, σ at most 5 ms). From the truth: never contradicted, at most
    // 1.12 ms off after the first second (1.67 σ, mean squared 0.57), final −0.56 ms, ATE
    // 0.0049 m. From a −10 ms error: contradicted at 5.6 s (σ 2.5 ms), at most 2.14 ms off
    // after 30 s (31.0 s, 2.8 σ; seeds 2 / 3: 1.54 / 0.69 ms), final −0.80 ms, ATE 0.0060 m.
    // At 30 world points (the default until 2026-11-28) it was contradicted at 8.9 s and at
    // most 1.29 ms off after 30 s: the 100 points' longer memory of the states solved under the
    // wrong offset pulls the released estimate back longer (−2.0 to −2.6 ms from 14 to 34 s).
    let released = |r: &Report| {
        r.events
            .iter()
            .filter(|e| e.kind == "calibration_released")
            .map(|e| (e.t_s, e.detail.clone()))
            .collect::<Vec<_>>()
    };
    let from_truth = run_with_td(0.0);
    let c = from_truth.calibration.as_ref().unwrap();
    assert!(c.td_error_ms.abs() < 1.0, "final {} ms", c.td_error_ms);
    assert!(from_truth.ate_rmse_m.unwrap() < 0.008);
    // The bound: a true offset of 0 strays less than 2 ms and 3 σ after the first
    // second (σ if free while held, marginal after). With the offset released at σ 5 ms it
    // strayed 4.7 ms (seed 1) to 11.7 ms (seed 2, 3.4 σ); released at 1 ms, 0.48–1.50 ms over
    // seeds 1–10 at 30 points, but 1.20–2.11 ms over seeds 1–5 at 100 (the window determines
    // the offset to 1 ms at 19–20 s instead of 33–37 s, and strays right after, where 2 ms is
    // 2 σ); released at 0.67 ms (2 ms / 3 σ), seeds 1–5: 0.29–1.12 ms, at most 1.67 σ. The
    // mean squared error in σ is 1 for a consistent estimate; seeds 1–5 0.01–0.57.
    let x = c.td_excursion.expect("an excursion");
    assert!(x.max_error_ms < 2.0, "{x:?}");
    assert!(x.max_error_sigmas.unwrap() < 2.0, "{x:?}");
    assert!(x.mean_squared_sigmas.unwrap() < 1.0, "{x:?}");
    let events = released(&from_truth);
    assert_eq!(events.len(), 1, "{events:?}");
    assert!(
        events[0].1.starts_with("time offset determined") && (25.0..45.0).contains(&events[0].0),
        "{events:?}"
    );

    let from_error = run_with_td(0.01);
    let c = from_error.calibration.as_ref().unwrap();
    // Held until the release: no drift toward any value the window cannot yet support.
    for s in c.history.iter().filter(|s| s.t_s < 3.0) {
        assert!((s.td_error_ms + 10.0).abs() < 0.01, "{s:?}");
    }
    let events = released(&from_error);
    assert_eq!(events.len(), 1, "{events:?}");
    assert!(
        events[0].1.starts_with("time offset contradicted") && (3.0..12.0).contains(&events[0].0),
        "{events:?}"
    );
    for s in c.history.iter().filter(|s| s.t_s >= 30.0) {
        assert!(s.td_error_ms.abs() < 2.5, "{s:?}");
    }
    assert!(
        c.td_error_ms.abs() < 1.0,
        "from −10 ms to {} ms",
        c.td_error_ms
    );
    assert!(from_error.ate_rmse_m.unwrap() < 0.011);
    // Held at the wrong value until the data contradict it: the error reaches 4.0 σ of the σ
    // the offset would have if free (the free estimate is 3.1 σ from the configured value at
    // the release); mean squared 4.11, the slow pull back above included (at 30 world points:
    // 4.0 σ, 2.09; seeds 1–10 there 2.8–6.1 σ).
    let x = c.td_excursion.expect("an excursion");
    assert!(x.max_error_sigmas.unwrap() < 4.5, "{x:?}");
    assert!(x.mean_squared_sigmas.unwrap() < 5.0, "{x:?}");
}

#[test]
fn extrinsics_are_estimated_where_the_motion_determines_them() {
    // Default motion, seed 1, 20 s, from the true extrinsics. The figure-eight turns about one
    // axis: the window determines the rig's rotation to 0.5° within about 2 s, never its
    // translation (σ about 13 mm if free: a horizontal lever arm looks like an accelerometer
    // bias). Measured: rotation released at 1.8 s, a 0.85° excursion at 2 s, at most 0.18°
    // after 10 s; translation held, 0.04 mm; ATE 0.0088 m. Over seeds 1–8 the largest
    // excursions are 0.85 / 0.44 / 0.26 / 0.23 / 0.90 / 0.38 / 0.63 / 0.33° with the persistent
    // points spread over the view (0.57 / 0.49 / 0.31 / 0.38 / 0.49 / 0.45 / 0.65 / 0.39° with
    // the longest tracks first): seeds 1 and 5 are released 0.3–0.5 s earlier, further from
    // the truth (book, "Window against batch").
    let done = run_edited(scenarios::catalog::DEFAULT, Some(20.0), |text| {
        text.replace(
            "[expectations]",
            "[estimator]\nestimate_extrinsics = true\nestimate_td = false\n\n[expectations]",
        )
    });
    let r = &done.report;
    let released: Vec<_> = r
        .events
        .iter()
        .filter(|e| e.kind == "calibration_released")
        .collect();
    assert_eq!(released.len(), 1, "{released:?}");
    assert!(released[0].detail.starts_with("rotation") && released[0].t_s < 4.0);
    let c = r.calibration.as_ref().unwrap();
    for s in &c.history {
        assert!(
            s.rotation_error_deg < 1.0 && s.translation_error_mm < 0.5,
            "{s:?}"
        );
        if s.t_s >= 10.0 {
            assert!(s.rotation_error_deg < 0.25, "{s:?}");
        }
    }
    assert_eq!(r.resets, 0);
    assert!(r.ate_rmse_m.unwrap() < 0.013);
    // A run that studies calibration draws its errors over time.
    let dir = common::written(&done);
    let png = std::fs::read(dir.path().join("calibration.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"), "not a PNG");
}

#[test]
fn calibration_converges_from_the_perturbed_start_on_a_tilting_motion() {
    // The calibration issue's perturbed start: a 10 ms time offset and both cameras off by
    // [1.2, −1.2, 1.0]° and [12, −12, 10] mm (1.97° / 19.7 mm), on a motion whose roll and pitch
    // swing ±0.5 rad at 0.2 Hz. Measured after 30 s, seeds 1 / 2 / 3: td at most 0.36 / 0.36 /
    // 0.16 ms, rotation 0.038 / 0.044 / 0.024°, translation 3.7 / 3.4 / 1.8 mm; released (seed 1)
    // time offset 0.7 s, rotation 0.9 s, translation 9.3 s. Bounds: the 0.5 ms and
    // 5 mm, its 0.1° halved.
    let scenario = Scenario::load("room_lissajous_calibration_stereo_imu").unwrap();
    let r = run_scenario(scenario, Some(40.0)).run.report;
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
    let released: Vec<_> = r
        .events
        .iter()
        .filter(|e| e.kind == "calibration_released")
        .map(|e| (e.t_s, e.detail.split(' ').next().unwrap_or("")))
        .collect();
    assert_eq!(released.len(), 3, "{released:?}");
    for (t, what) in released {
        let by = if what == "translation" { 12.0 } else { 2.0 };
        assert!(t < by, "{what} released at {t} s");
    }
}

/// The offset is estimated by default and found from 0 well past the first health limit tried
/// (50 ms from `td_s`: a true 60 ms offset then made 22 resets and 0.096 m on these 20 s): EuRoC
/// V1_01's first 20 s, stereo+IMU, seed 4, frames stamped 60 ms early. Measured under the
/// 100 ms limit: no reset, ATE 0.0026 m, final td error −0.15 ms; the scenario's own bounds
/// (ATE 0.006 m, 1°, no reset, 90 % tracking) hold.
#[test]
fn a_60_ms_offset_is_found_from_zero_without_a_reset() {
    let r = run_edited("room_replay_v1_01_time_offset_stereo_imu", None, |t| {
        t.replace("time_offset_s = 0.02", "time_offset_s = 0.06")
    })
    .run
    .report;
    assert_eq!(r.resets, 0);
    assert!(r.passed, "{:?}", r.expectations);
    assert_offset_found(&r, 60.0);
}

/// Mono+IMU initialization finds an unknown offset: EuRoC V2_02 replay (20 s, seed 1), frames
/// stamped 35 ms early, nothing configured. The alignment is searched over shifts of the
/// interior frames' IMU intervals and starts from 35 ms (measured: no reset, ATE 0.0203 m,
/// final td error −0.009 ms). Aligned at 0 it started 13° tilted, reset once at 8.5 s and
/// diverged unnoticed (ATE 13 m). Bounds: measured + 50 %.
#[test]
fn mono_initialization_finds_a_35_ms_offset() {
    let r = run_edited("room_replay_v2_02_mono_imu", None, |t| {
        t.replacen("seed = 4", "seed = 1", 1).replacen(
            "[rig]\n",
            "[rig]\ntime_offset_s = 0.035\n",
            1,
        )
    })
    .run
    .report;
    assert_eq!(r.resets, 0);
    let ate = r.ate_rmse_m.unwrap();
    assert!(ate < 0.031, "ATE {ate:.4} m");
    assert_offset_found(&r, 35.0);
}

/// Asserts that the report studied a true offset of `true_ms` and ends within 1 ms of it.
fn assert_offset_found(r: &Report, true_ms: f64) {
    let c = r.calibration.as_ref().unwrap();
    assert_eq!(c.td_true_ms, true_ms);
    assert!(
        c.td_error_ms.abs() < 1.0,
        "final td error {} ms",
        c.td_error_ms
    );
}
