//! Fault scenarios of the catalog, at full length (each ~3 s in release): the estimator keeps
//! running when a sensor fails, says so (suite-switch events, excluded IMU samples), and its
//! ATE stays within the scenario's bounds (measured figures in the scenario files).

use crate::common;

use common::run_catalog;

/// The scenario's expectations all hold, and its suite switches are exactly `switches`
/// (`"from -> to"` at the given times, seconds, ±0.1 s).
fn assert_fault_scenario(name: &str, switches: &[(f64, &str)]) {
    assert_fault_run(name, &run_catalog(name, None), switches);
}

/// [`assert_fault_scenario`] on a finished run `d` of scenario `name`.
fn assert_fault_run(name: &str, d: &common::Done, switches: &[(f64, &str)]) {
    let r = &d.report;
    let failed: Vec<_> = r.expectations.iter().filter(|e| !e.passed).collect();
    assert!(failed.is_empty(), "{name}: failed expectations {failed:?}");
    let got: Vec<(f64, &str)> = r
        .events
        .iter()
        .filter(|e| e.kind == "suite_switch")
        .map(|e| (e.t_s, e.detail.as_str()))
        .collect();
    assert_eq!(got.len(), switches.len(), "{name}: switches {got:?}");
    for ((t, detail), (want_t, want)) in got.iter().zip(switches) {
        assert!(
            (t - want_t).abs() < 0.1,
            "{name}: switch at {t} s, want {want_t}"
        );
        assert!(
            detail.starts_with(want),
            "{name}: {detail:?}, want {want:?}"
        );
    }
    assert!(
        r.events.iter().all(|e| e.kind != "prior_dropped"),
        "{name}: the prior was dropped"
    );
}

/// Catalog scenario `name` with `[estimator]` settings appended, run at its full length.
fn run_catalog_with(name: &str, settings: &str) -> common::Done {
    common::run_edited(name, None, |text| {
        format!("{text}\n[estimator]\n{settings}\n")
    })
}

#[test]
fn left_camera_death_continues_on_the_right_camera() {
    // Camera 0 dies at 20 s; after 0.5 s of silence the window is mono+IMU on camera 1.
    assert_fault_scenario(
        "room_figure8_left_camera_death_stereo_imu",
        &[(20.46, "stereo_imu -> mono_imu(cam1)")],
    );
}

#[test]
fn right_camera_death_continues_on_the_left_camera() {
    assert_fault_scenario(
        "room_figure8_right_camera_death_stereo_imu",
        &[(20.46, "stereo_imu -> mono_imu(cam0)")],
    );
}

#[test]
fn imu_spikes_are_excluded() {
    assert_fault_scenario("room_figure8_imu_spikes_stereo_imu", &[]);
    let d = run_catalog("room_figure8_imu_spikes_stereo_imu", None);
    // Each spiked sample is excluded once (1 % of 12,000 samples expected).
    assert!(d.report.imu_samples_excluded >= 80);
}

#[test]
fn camera_blackout_switches_to_the_imu_and_back() {
    assert_fault_scenario(
        "room_figure8_blackout_stereo_imu",
        &[
            (15.46, "stereo_imu -> imu_only"),
            (16.0, "imu_only -> stereo_imu"),
        ],
    );
}

#[test]
fn two_and_ten_second_blackouts_are_bridged_by_the_imu() {
    assert_fault_scenario(
        "room_figure8_blackout_2s_stereo_imu",
        &[
            (20.46, "stereo_imu -> imu_only"),
            (22.0, "imu_only -> stereo_imu"),
        ],
    );
    assert_fault_scenario(
        "room_figure8_blackout_10s_stereo_imu",
        &[
            (20.46, "stereo_imu -> imu_only"),
            (30.0, "imu_only -> stereo_imu"),
        ],
    );
}

/// A camera that repeats its last image is recognized at its first repeated frame (its tracks
/// stand still while the gyroscope turns), dropped, and taken back when its features move.
#[test]
fn frozen_cameras_are_dropped_at_once_and_taken_back() {
    assert_fault_scenario(
        "room_figure8_left_camera_freeze_stereo_imu",
        &[
            (20.0, "stereo_imu -> mono_imu(cam1) (camera 0 frozen)"),
            (23.0, "mono_imu(cam1) -> stereo_imu (camera 0 back)"),
        ],
    );
    assert_fault_scenario(
        "room_figure8_freeze_2s_stereo_imu",
        &[
            (
                20.0,
                "stereo_imu -> imu_only (camera 0 frozen, camera 1 frozen)",
            ),
            (
                22.0,
                "imu_only -> stereo_imu (camera 0 back, camera 1 back)",
            ),
        ],
    );
}

#[test]
fn imu_dropouts_run_stereo_only_and_the_imu_rejoins() {
    // 0.5 s is within the sensor timeout: no switch, and nothing interpolated over the gap.
    assert_fault_scenario("room_figure8_imu_dropout_short_stereo_imu", &[]);
    assert_fault_scenario(
        "room_figure8_imu_dropout_stereo_imu",
        &[
            (20.5, "stereo_imu -> stereo"),
            (23.0, "stereo -> stereo_imu"),
        ],
    );
}

#[test]
fn frame_drops_and_a_time_offset_stay_within_twice_the_fault_free_error() {
    assert_fault_scenario("room_figure8_frame_drops_stereo_imu", &[]);
    assert_fault_scenario("room_figure8_time_offset_stereo_imu", &[]);
}

/// A gyroscope clipping at 2 rad/s in 2.5 rad/s yaw swings: the clipped samples are
/// recognized, the intervals over them take the clipped axis as a bound (its noise widened by
/// the range) and the initialization leaves them out, so the window neither resets nor
/// diverges and stays within 2x the run on a gyroscope that does not clip (0.3737 m with 33
/// resets when the clipped readings were trusted; 0.0156 m when those intervals had no IMU
/// factor).
#[test]
fn imu_saturation_in_fast_turns_is_recognized() {
    assert_fault_scenario("room_fast_rotation_imu_saturation_stereo_imu", &[]);
}

/// No false alarm on the fault-free catalog scenarios: no suite switch, no excluded or
/// saturated IMU sample, no dropped prior, no reset (stereo+IMU, stereo, mono+IMU).
#[test]
fn healthy_runs_raise_no_alarm() {
    for name in [
        "room_figure8_stereo_imu",
        "room_figure8_stereo",
        "room_figure8_mono_imu",
        "room_circle_stereo_imu",
        "room_replay_v2_02_stereo_imu",
        "room_replay_v2_02_mono_imu",
    ] {
        let d = run_catalog(name, None);
        let r = &d.report;
        assert_eq!(r.suite_switches, 0, "{name}");
        assert_eq!(r.imu_samples_excluded, 0, "{name}");
        assert_eq!(r.imu_samples_saturated, 0, "{name}");
        assert_eq!(r.resets, 0, "{name}");
        assert!(r.events.iter().all(|e| e.kind != "prior_dropped"), "{name}");
    }
}

/// A scenario without expectations still fails when the estimator never tracks: mono+IMU on a
/// circle at constant speed facing along the tangent (the scale is not observable, so the
/// initialization never passes its gate) gets the default bounds (ATE within
/// max(0.5 m, 2 % of the path), tracking on half of the frames) and does not pass; one that
/// expects the refusal passes.
#[test]
fn a_run_that_never_tracks_fails_on_the_default_expectations() {
    let without_expectations = |text: &str| {
        let text = text.replace("suite = \"stereo_imu\"", "suite = \"mono_imu\"");
        text[..text.find("[expectations]").expect("has expectations")].to_string()
    };
    let scenario = common::catalog_edited("room_circle_stereo_imu", without_expectations);
    let done = common::run_scenario(scenario, Some(20.0));
    let r = &done.report;
    let metrics: Vec<&str> = r.expectations.iter().map(|e| e.metric).collect();
    assert_eq!(
        metrics,
        ["ate_rmse_m", "ate_rot_rmse_deg", "tracking_fraction"]
    );
    assert_eq!(r.tracking_fraction, 0.0);
    assert!(!r.passed);
    // Expecting the refusal (`tracking_fraction = { max = 0 }`) passes, with no ATE bound.
    let scenario = common::catalog_edited("room_circle_stereo_imu", |text| {
        without_expectations(text) + "[expectations]\ntracking_fraction = { max = 0.0 }\n"
    });
    let context = scenarios::report::RunContext::with_run(&scenario, &done.output);
    let r = scenarios::report::build_report(&context, &done.output, &done.evaluation);
    let metrics: Vec<&str> = r.expectations.iter().map(|e| e.metric).collect();
    assert_eq!(metrics, ["tracking_fraction"]);
    assert!(r.passed);
}

/// The default scenario's rig with a 1 cm stereo baseline, 20 s, `[estimator]` settings
/// `settings` added, run and reported.
fn run_with_1cm_baseline(settings: &str) -> scenarios::report::Report {
    let scenario = common::catalog_edited("room_figure8_stereo_imu", |text| {
        text.replace(
            "translation_m = [0.0, 0.055, 0.0]",
            "translation_m = [0.0, 0.005, 0.0]",
        )
        .replace(
            "translation_m = [0.0, -0.055, 0.0]",
            "translation_m = [0.0, -0.005, 0.0]",
        )
        .replace(
            "[expectations]",
            &format!("[estimator]\n{settings}\n\n[expectations]"),
        )
    });
    common::run_scenario(scenario, Some(20.0)).run.report
}

/// The `reset` events of a report, in time order.
fn reset_events(r: &scenarios::report::Report) -> Vec<&scenarios::report::EventReport> {
    r.events.iter().filter(|e| e.kind == "reset").collect()
}

/// A 1 cm stereo baseline gives the stereo-inertial initialization depths too poor to hold the
/// scale: the window diverges (seed 1, 20 s: 8.86 m ATE, no alarm, before the IMU χ² test).
/// With the time offset held, its IMU factors then fail their χ² test in consecutive solves and
/// the window is reset (measured: 1 reset at 3.50 s, ATE 0.327 m; 3.75 s and 0.287 m with the
/// frames' first estimates never renewed, `frame_relinearize_fraction = inf`). The divergence is
/// noticed, not repaired: the bound asserts the reset and that the run no longer runs away.
#[test]
fn a_diverging_window_fails_the_imu_chi2_test() {
    let r = run_with_1cm_baseline("estimate_td = false");
    let resets = reset_events(&r);
    assert!(
        resets
            .iter()
            .any(|e| e.detail.contains("IMU factors inconsistent")),
        "no χ² reset: {resets:?}"
    );
    let ate = r.ate_rmse_m.unwrap();
    assert!(ate < 0.5, "ATE {ate} m");
}

/// The persistent-point budget these divergences were built with (30 points in world
/// coordinates, kept until their last observation leaves the window, the default until
/// 2026-11-28). With the default's 100 points in inverse distance the same constructions
/// unfold later or not at all: measured below and in the tests that run them at the default.
const THIRTY_WORLD_POINTS: &str = "max_persistent_points = 30\nmarginalize_lost_points = false\n\
                                   point_coordinates = \"world\"";

/// The same divergence with the time offset estimated (the default), the frames' first
/// estimates never renewed (`frame_relinearize_fraction = inf`, the setting this was found
/// with) and the IMU χ² test off (`health.imu_chi2_z = inf`; on, it resets this window at
/// 3.30 s, before the offset can move), at 30 world points: released at 3.50 s, the offset
/// jumps past 100 ms in the next solves, where it absorbs what the χ² test catches above
/// (without the health limit on it the run went on to 211 ms and 0.91 m ATE in 8.4 s, no
/// reset). The limit (100 ms from the configured offset) resets the window at 3.59 s
/// (106.8 ms); measured ATE 0.298 m, final offset error 4.8 ms. Bounds: the reset within 0.5 s
/// of the release, ATE measured + 50 %.
#[test]
fn a_time_offset_that_absorbs_a_divergence_fails_its_health_check() {
    let r = run_with_1cm_baseline(&format!(
        "{THIRTY_WORLD_POINTS}\nframe_relinearize_fraction = inf\n\n[estimator.health]\n\
         imu_chi2_z = inf"
    ));
    let resets = reset_events(&r);
    assert!(
        resets
            .first()
            .is_some_and(|e| e.detail.starts_with("time offset") && e.t_s < 4.0),
        "{resets:?}"
    );
    let ate = r.ate_rmse_m.unwrap();
    assert!(ate < 0.45, "ATE {ate} m");
    let td_error_ms = r.calibration.as_ref().unwrap().td_error_ms;
    assert!(td_error_ms.abs() < 10.0, "final td error {td_error_ms} ms");
}

/// The same construction at the default budget (100 points in inverse distance) diverges more
/// slowly: the offset, released at 4.0 s, reaches the health limit at 8.85 s (101.6 ms) and
/// that reset comes first. The window restarted from the last state that passed then drifted
/// to the accelerometer-bias limit at 11.95 s and again at 14.2 s, and, restarted from a bias
/// just under the limit each time, failed every 0.15–0.25 s: twelve resets in 2 s. A failure
/// within `health.restart_trial_s` (1 s) of a restart now makes the estimator initialize again
/// from the data (measured: 4 resets, the fourth at 14.35 s initializing again, tracking from
/// 14.85 s with no reset after; final offset error 0.3 ms). Bounds: the offset's reset first,
/// after the release; at most one restart that fails within the trial, and it initializes
/// again; no reset in the last 4 s.
#[test]
fn a_restart_that_fails_at_once_initializes_again() {
    let r = run_with_1cm_baseline(
        "frame_relinearize_fraction = inf\n\n[estimator.health]\nimu_chi2_z = inf",
    );
    let resets = reset_events(&r);
    assert!(
        resets
            .first()
            .is_some_and(|e| e.detail.starts_with("time offset") && e.t_s > 4.0),
        "{resets:?}"
    );
    let relapses: Vec<_> = resets
        .windows(2)
        .filter(|w| w[1].t_s - w[0].t_s < 1.0)
        .map(|w| w[1])
        .collect();
    assert!(
        relapses.len() <= 1
            && relapses.iter().all(|e| e
                .detail
                .ends_with("again after the restart: initializing again")),
        "{resets:?}"
    );
    assert!(resets.len() <= 5, "{resets:?}");
    assert!(resets.iter().all(|e| e.t_s < 16.0), "{resets:?}");
    let td_error_ms = r.calibration.as_ref().unwrap().td_error_ms;
    assert!(td_error_ms.abs() < 10.0, "final td error {td_error_ms} ms");
}

/// Every frame of `d` reported as tracking has an accelerometer bias within the health limit
/// (`health.max_accel_bias_m_s2`, 2.5 m/s²).
fn assert_plausible_biases(d: &common::Done) {
    for f in &d.output.frames {
        let e = &f.estimate;
        if e.status == estimator::Status::Tracking {
            let t_s = e.t_ns as f64 * 1e-9;
            assert!(e.ba.norm() <= 2.5, "{t_s} s: |ba| {}", e.ba.norm());
        }
    }
}

/// No reset, the window started after the wrong 4.45 s initialization (at 4.85 s), and every
/// frame reported as tracking has a plausible accelerometer bias.
fn assert_started_after_the_wrong_initialization(d: &common::Done) {
    assert_eq!(d.report.resets, 0);
    let started = initialized_at(d);
    assert!(
        started.is_some_and(|t| t > 4.5),
        "initialized at {started:?}"
    );
    assert_plausible_biases(d);
}

/// The time of the first `Initializing -> Tracking` event.
fn initialized_at(d: &common::Done) -> Option<f64> {
    d.report
        .events
        .iter()
        .find(|e| e.detail == "Initializing -> Tracking")
        .map(|e| e.t_s)
}

/// EuRoC V1_01 stands still for 4.2 s and then takes off (seed 4). The monocular
/// initialization at 4.45 s, 0.25 s into the motion, comes from a wrong structure from motion.
/// With the structure from motion weighting each view by its camera model's magnification its
/// scale is reported as undetermined (σ_s/s 5.2 %) and the window starts at 4.85 s, with no
/// reset. Before (one weight for every view) it passed the 3 % gate at 2.8 %, the first
/// window solve needed a 6.1 m/s² accelerometer bias, the estimator restarted from that state
/// and ran away (ATE 82.9 m over 20 s).
#[test]
fn a_take_off_from_rest_initializes_once_the_motion_determines_it() {
    let d = run_catalog("room_replay_v1_01_mono_imu", None);
    let r = &d.report;
    let failed: Vec<_> = r.expectations.iter().filter(|e| !e.passed).collect();
    assert!(failed.is_empty(), "failed expectations {failed:?}");
    assert_started_after_the_wrong_initialization(&d);
}

/// With the scale gate relaxed to 10 %, the wrong 4.45 s initialization passes it; the
/// alignment's consistency gate refuses it instead (χ² / dof 61, gate 20) and the window
/// starts at 4.85 s as with the default gate, with no reset.
#[test]
fn an_inconsistent_mono_alignment_is_refused() {
    let d = run_catalog_with(
        "room_replay_v1_01_mono_imu",
        "mono_init_max_scale_sigma = 0.1",
    );
    assert_started_after_the_wrong_initialization(&d);
}

/// With both gates off the wrong initialization starts the window, and its first solve is
/// judged like every later one: its 4.4 m/s² accelerometer bias fails the health check, no
/// state has passed yet, so the estimator initializes again from the data (tracking from
/// 7.75 s, ATE 0.0076 m over 20 s) instead of restarting from that state.
#[test]
fn a_wrong_initialization_fails_its_first_health_check() {
    let d = run_catalog_with(
        "room_replay_v1_01_mono_imu",
        "mono_init_max_scale_sigma = 0.1\nmono_init_max_chi2_per_dof = inf",
    );
    let resets = reset_events(&d.report);
    assert_eq!(resets.len(), 1, "{resets:?}");
    assert!(
        (resets[0].t_s - 4.45).abs() < 0.1 && resets[0].detail.contains("initializing again"),
        "{resets:?}"
    );
    assert_plausible_biases(&d);
    let ate = d.report.ate_rmse_m.unwrap();
    assert!(ate < 0.012, "ATE {ate} m (measured 0.0076)");
}

/// With the time offset estimated, a frame's IMU time `t + td` can fall before the newest IMU
/// sample (`td` slightly negative): the sensor monitor judged at that earlier time and called
/// the dead camera back, three switches within 10 ms (silent, back, silent at 20.45 / 20.45 /
/// 20.46 s). Its clock never runs backwards now: one switch, as with `td` fixed, and the
/// scenario's expectations hold.
#[test]
fn a_dead_camera_stays_dead_with_the_time_offset_estimated() {
    let name = "room_figure8_right_camera_death_stereo_imu";
    let d = run_catalog_with(name, "estimate_td = true");
    assert_fault_run(name, &d, &[(20.46, "stereo_imu -> mono_imu(cam0)")]);
}

/// Mono+IMU on the EuRoC V2_02 replay with an unmodelled 35 ms camera–IMU offset, the
/// initialization's offset search off and the frames' first estimates never renewed
/// (`frame_relinearize_fraction = inf`; renewed, the default, this window does not diverge:
/// 0.45 m, no reset), seed 1, and the IMU χ² test off (`health.imu_chi2_z = inf`): the window
/// drifts away from what the camera sees, carried by the IMU alone. With the χ² test on it now
/// fails that test at 8.6 s and 9.6 s (ATE 0.71 m); when it did not (its IMU χ² 0.2 for 150
/// dof, 12 m/s and 13.2 m ATE), only the reprojection test saw the drift, rejecting 12–25 %
/// of the tracks per solve. With the χ² test off the rejection monitor resets the window at
/// 9.20 s (11 % of its tracks rejected over 20 solves) and the estimator initializes again
/// from the data (measured: ATE 1.64 m over the run, the drift before the reset included).
/// Bounds: the first reset is the monitor's, after the drift starts (8 s) and before 14 s;
/// ATE measured + 50 %. All at 30 world points: at the default's 100 inverse-distance points
/// this window does not run away (its offset released as determined at 3.27 s; ATE 0.73 m, no
/// reset), so there is no drift for the monitor to see.
#[test]
fn a_window_its_camera_contradicts_is_initialized_again() {
    let r = common::run_edited("room_replay_v2_02_mono_imu", None, |t| {
        t.replacen("seed = 4", "seed = 1", 1).replacen(
            "[rig]\n",
            "[rig]\ntime_offset_s = 0.035\n",
            1,
        ) + &format!(
            "\n[estimator]\n{THIRTY_WORLD_POINTS}\ninit_td_search_s = 0.0\n\
             frame_relinearize_fraction = inf\n\n[estimator.health]\nimu_chi2_z = inf\n"
        )
    })
    .run
    .report;
    let resets = reset_events(&r);
    assert!(
        resets
            .first()
            .is_some_and(|e| e.detail.contains("cameras contradict")
                && e.detail.ends_with("initializing again")
                && (8.0..14.0).contains(&e.t_s)),
        "no rejection reset: {resets:?}"
    );
    let ate = r.ate_rmse_m.unwrap();
    assert!(ate < 2.5, "ATE {ate} m");
}
