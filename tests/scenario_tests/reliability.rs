//! Reliability end to end: a glitchy recording repaired and flown as well as the clean one, an
//! honest tracking status when vision gives nothing, and faults that used to end in nonsense
//! (camera 0 dead from the start, an IMU dropout longer than the ground-truth retention).

use crate::common;

use scenarios::report::Report;
use scenarios::spec::Scenario;

/// Runs `scenario` with `seed` and `duration_s`; the report.
fn run_report(scenario: &Scenario, seed: Option<u64>, duration_s: Option<f64>) -> Report {
    common::run_seeded(scenario.clone(), seed, duration_s)
        .run
        .report
}

/// The default scenario with `edit` applied to its text.
fn default_with(edit: impl Fn(&str) -> String) -> Scenario {
    common::catalog_edited(scenarios::catalog::DEFAULT, edit)
}

#[test]
fn a_repaired_glitchy_replay_flies_within_1_5_times_the_clean_ate() {
    let clean = Scenario::load("room_replay_v2_02_stereo_imu").unwrap();
    let glitchy = Scenario::load("room_replay_v2_02_glitchy_stereo_imu").unwrap();
    let r = glitchy.recording_report().unwrap();
    assert_eq!((r.glitches.len(), r.gaps.len()), (2, 1));
    // Seeds 1 and 3: measured 0.0056 vs 0.0057 and 0.0049 vs 0.0039 m (ratios 0.98, 1.26);
    // seeds 2, 4, 5: 0.72, 1.47, 1.04.
    for seed in [1, 3] {
        let a = run_report(&clean, Some(seed), None).ate_rmse_m.unwrap();
        let b = run_report(&glitchy, Some(seed), None).ate_rmse_m.unwrap();
        println!(
            "seed {seed}: clean {a:.4} m, repaired {b:.4} m, ratio {:.2}",
            b / a
        );
        assert!(b <= 1.5 * a, "seed {seed}: {b} vs {a}");
    }
}

#[test]
fn no_features_means_no_tracking() {
    let s = default_with(|t| {
        t.replace(
            "pixel_sigma_px = 1.0",
            "pixel_sigma_px = 1.0\nmax_features = 0",
        )
    });
    let r = run_report(&s, None, Some(8.0));
    // It used to report 92.6 % tracking at 6.8 m of error.
    assert_eq!(r.tracking_frames, 0);
    assert_eq!(r.tracking_fraction, 0.0);
    assert!(!r.passed, "a run without vision must not pass");
}

#[test]
fn camera_0_dead_from_the_start_initializes_on_camera_1() {
    let s = default_with(|t| {
        t.to_string() + "\n[[faults]]\nkind = \"camera_death\"\ncam_id = 0\nat_s = 0.0\n"
    });
    let r = run_report(&s, None, Some(20.0));
    // Measured 0.0218 m, 69.8 % tracking (seed 1, 20 s; the mono scale gate of 3 % passes at
    // 6.05 s; with 5 %: 0.0291 m, 78 %); it was 1.41 m: the stereo initializer aligned
    // constant-velocity guesses.
    let ate = r.ate_rmse_m.unwrap();
    assert!(ate < 0.04, "{ate}");
    assert!(r.tracking_fraction > 0.65, "{}", r.tracking_fraction);
}

#[test]
fn an_imu_dropout_longer_than_five_seconds_runs() {
    let s = default_with(|t| {
        t.to_string() + "\n[[faults]]\nkind = \"imu_dropout\"\nstart_s = 5.0\nend_s = 11.0\n"
    });
    // It used to stop with `no ground truth at t = …` (exit 2): ground truth was kept 5 s.
    let r = run_report(&s, None, Some(16.0));
    // Measured: 321 frames, 312 tracking, ATE 0.0084 m (seed 1).
    assert!(
        r.frames > 300 && r.tracking_frames > 300,
        "{} {}",
        r.frames,
        r.tracking_frames
    );
    let ate = r.ate_rmse_m.unwrap();
    assert!(ate < 0.02, "{ate}");
}

#[test]
fn degraded_frames_are_evaluated_not_hidden() {
    // A 3 s black-frame blackout: frames keep coming with no features; they are degraded,
    // and the ATE counts them.
    let s = default_with(|t| {
        t.to_string()
            + "\n[[faults]]\nkind = \"camera_blackout\"\nstart_s = 6.0\nend_s = 9.0\nblack_frames = true\n"
    });
    let r = run_report(&s, None, Some(12.0));
    // Measured: 241 frames, 172 tracking, 60 degraded (the 3 s of black frames), ATE 0.0194 m.
    assert!(
        (55..=65).contains(&r.degraded_frames),
        "{}",
        r.degraded_frames
    );
    assert!(r.tracking_fraction < 0.75, "{}", r.tracking_fraction);
}
