//! Convergence of the stereo+IMU and mono+IMU estimators on catalog scenarios, against the simulator's ground
//! truth: ATE bounds, bias convergence, and (ignored by default) the full-length scenarios'
//! own expectations.
//!
//! The default test run uses the first 20 s of each scenario to keep CI fast; the full-length
//! runs are `#[ignore]`d: `cargo test --release --test scenario_tests convergence:: -- --ignored`.

use crate::common;

use common::{run_catalog, run_edited};
use scenarios::report::Report;

/// Shortened duration of the default test run (s).
const SHORT_S: f64 = 20.0;

/// What a convergence run must show: its suite, the least fraction of tracking frames (the
/// rest initializing) and the largest position ATE.
struct Converges {
    suite: &'static str,
    min_tracking: f64,
    max_ate_m: f64,
}

/// Runs `name` for `duration_s` (None: its full length) and asserts `want`, and no reset.
fn assert_run_converges(name: &str, duration_s: Option<f64>, want: Converges) {
    let d = run_catalog(name, duration_s);
    let r = &d.report;
    assert_eq!(r.suite, want.suite);
    assert!(
        r.tracking_fraction > want.min_tracking,
        "{name}: tracking only {:.1} % of frames",
        100.0 * r.tracking_fraction
    );
    let ate = r.ate_rmse_m.expect("tracking frames");
    let max = want.max_ate_m;
    assert!(ate < max, "{name}: ATE {ate:.4} m ≥ {max} m");
    assert_eq!(r.resets, 0);
}

/// The times (s) at which a run's status turned to tracking.
fn tracking_starts(r: &Report) -> Vec<f64> {
    r.events
        .iter()
        .filter(|e| e.kind == "status_change" && e.detail.ends_with("Tracking"))
        .map(|e| e.t_s)
        .collect()
}

/// Asserts a run's position and rotation ATE below `max_ate_m` and `max_rot_deg`, and no reset.
fn assert_accurate(r: &Report, max_ate_m: f64, max_rot_deg: f64) {
    let (ate, rot) = (r.ate_rmse_m.unwrap(), r.ate_rot_rmse_deg.unwrap());
    assert!(ate < max_ate_m, "ATE {ate:.4} m");
    assert!(rot < max_rot_deg, "rotation ATE {rot:.3}°");
    assert_eq!(r.resets, 0);
}

/// Asserts the position ATE of a shortened stereo+IMU run and that it tracked almost throughout.
fn assert_converges(name: &str, max_ate_m: f64) {
    let want = Converges {
        suite: "stereo_imu",
        min_tracking: 0.9,
        max_ate_m,
    };
    assert_run_converges(name, Some(SHORT_S), want);
}

#[test]
fn stereo_imu_converges_on_room_figure8() {
    assert_converges("room_figure8_stereo_imu", 0.06);
}

#[test]
fn stereo_imu_converges_on_room_circle() {
    assert_converges("room_circle_stereo_imu", 0.08);
}

#[test]
fn stereo_imu_converges_on_euroc_v2_02_replay() {
    assert_converges("room_replay_v2_02_stereo_imu", 0.10);
}

/// Mono+IMU on the EuRoC V2_02 replay (20 s, seed 4): the scale gate passes within 4 s and the
/// ATE stays within 0.02 m (measured: initialized at 3.2 s, ATE 0.0094 m).
#[test]
fn mono_imu_initializes_and_converges_on_euroc_v2_02_replay() {
    let want = Converges {
        suite: "mono_imu",
        min_tracking: 0.8,
        max_ate_m: 0.02,
    };
    assert_run_converges("room_replay_v2_02_mono_imu", None, want);
}

/// Mono+IMU on the first 20 s of the default figure-eight (seed 1): the scale gate passes
/// within 7 s (measured 6.05 s: tracking 0.698 of the frames) and the ATE stays within 0.05 m
/// (measured 0.0222 m).
#[test]
fn mono_imu_initializes_and_converges_on_room_figure8() {
    let want = Converges {
        suite: "mono_imu",
        min_tracking: 0.65,
        max_ate_m: 0.05,
    };
    assert_run_converges("room_figure8_mono_imu", Some(SHORT_S), want);
}

/// Mono+IMU from a static start: the default figure-eight after 3 s at rest and a 1 s ramp
/// (seed 1, 20 s). Nothing can start at rest (no parallax); the rest frames then pin gravity,
/// the velocities and the gyroscope bias in the visual-inertial alignment, and the scale passes
/// its 3 % gate 0.65 s into the motion (measured: initialized at 3.65 s on seeds 1–3, tracking
/// 81.8 %, ATE 0.0222 m; 60 s: 0.0162 / 0.0161 / 0.0147 m).
#[test]
fn mono_imu_initializes_soon_after_a_static_start() {
    let done = run_edited("room_figure8_mono_imu", Some(SHORT_S), |t| {
        t.replace(
            "figure_eight = {",
            "static_start = { hold_s = 3.0, ramp_s = 1.0 }\nfigure_eight = {",
        )
    });
    let r = &done.report;
    let started = tracking_starts(r);
    assert_eq!(started.len(), 1, "{started:?}");
    assert!(
        (3.0..4.5).contains(&started[0]),
        "started at {} s",
        started[0]
    );
    assert!(r.ate_rmse_m.unwrap() < 0.03);
    assert_eq!(r.resets, 0);
}

/// Stereo+IMU with a 60 Hz camera (a period of 16.67 ms, not a whole number of nanoseconds) on
/// the EuRoC V2_02 replay (seed 4, 10 s): the initial window keeps frames at least
/// `stereo_init_window_s / init_frames` apart, so the alignment spans about 0.4 s as at 20 Hz
/// (measured: initialized at 0.42 s, ATE 0.0057 m, rotation 0.43°). Ten consecutive frames
/// (0.15 s) gave gravity from noisy second differences: initialized at 0.15 s, ATE 0.0126 m,
/// rotation 1.14°. Bounds: measured + 50 %.
#[test]
fn a_60_hz_stereo_imu_rig_spreads_its_initial_window_over_time() {
    let done = run_edited("room_replay_v2_02_stereo_imu", Some(10.0), |t| {
        t.replacen("rate_hz = 20.0", "rate_hz = 60.0", 1)
    });
    let r = &done.report;
    let started = tracking_starts(r);
    assert_eq!(started.len(), 1, "{started:?}");
    assert!(
        (0.35..0.6).contains(&started[0]),
        "started at {} s",
        started[0]
    );
    assert_accurate(r, 0.0086, 0.65);
}

/// The default figure-eight with 3 px feature noise on both cameras (seed 1, 20 s): the
/// outlier test measures reprojection errors in pixel σ of the camera, so sound tracks stay
/// (measured: ATE 0.0311 m, rotation 0.83°). With the test at a fixed 3 px, the mean error of
/// a sound track (1.25 σ = 3.8 px) failed it and most tracks were dropped after every solve:
/// ATE 0.195 m, rotation 3.1°, no reset. Bounds: measured + 50 %.
#[test]
fn a_noisier_camera_keeps_its_tracks() {
    let done = run_edited("room_figure8_stereo_imu", Some(SHORT_S), |t| {
        t.replace("pixel_sigma_px = 1.0", "pixel_sigma_px = 3.0")
    });
    let r = &done.report;
    assert_accurate(r, 0.047, 1.25);
}

/// Mono+IMU with a 30 Hz camera on the default figure-eight (seed 1, 20 s) initializes at
/// 6.03 s 9 % short of the metric scale. With first-estimate Jacobians each frame entered the
/// prior at the biased solution of the last and the scale stayed 3–9 % short to the end (ATE
/// 0.0899 m, rotation 0.66° with `frame_relinearize_fraction = inf`); frames whose position or
/// velocity moved far from the first estimate now get a new one and the scale is right within
/// a second (measured: ATE 0.0154 m, rotation 0.29°). Bounds: measured + 50 %.
#[test]
fn a_frame_far_from_its_first_estimate_gets_a_new_one() {
    let done = run_edited("room_figure8_mono_imu", Some(SHORT_S), |t| {
        t.replacen("rate_hz = 20.0", "rate_hz = 30.0", 1)
    });
    let r = &done.report;
    assert_accurate(r, 0.023, 0.44);
}

/// Estimated biases at the end of the shortened default scenario match the simulated ones
/// (which start at |b_g| ≈ 3.9e-3 rad/s, |b_a| ≈ 0.10 m/s² and random-walk from there): the
/// gyroscope bias to 1e-3 rad/s and the accelerometer bias to 0.04 m/s², both well under the
/// bias itself, so the estimator has learned them.
#[test]
fn biases_converge_to_the_simulated_biases() {
    let d = run_catalog("room_figure8_stereo_imu", Some(SHORT_S));
    let last = d
        .output
        .frames
        .iter()
        .rev()
        .find(|f| f.estimate.status.initialized())
        .expect("tracking frames");
    let bg_err = (last.estimate.bg - last.truth.gyro_bias).norm();
    let ba_err = (last.estimate.ba - last.truth.accel_bias).norm();
    println!(
        "|bg| {:.5} rad/s, error {bg_err:.5}; |ba| {:.4} m/s², error {ba_err:.4}",
        last.truth.gyro_bias.norm(),
        last.truth.accel_bias.norm()
    );
    assert!(bg_err < 1e-3, "gyro bias error {bg_err} rad/s");
    assert!(ba_err < 0.04, "accel bias error {ba_err} m/s²");
    assert!(bg_err < 0.5 * last.truth.gyro_bias.norm());
    assert!(ba_err < 0.5 * last.truth.accel_bias.norm());
    assert_eq!(
        d.report.gyro_bias_error_rad_s,
        Some(bg_err),
        "report field matches"
    );
}

/// Runs a catalog scenario at full length and checks its own expectations.
fn full_length(name: &str) {
    let d = run_catalog(name, None);
    let failed: Vec<_> = d.report.expectations.iter().filter(|e| !e.passed).collect();
    assert!(failed.is_empty(), "{name}: failed expectations {failed:?}");
}

#[test]
#[ignore = "full length: ~20 s each in release"]
fn full_room_figure8_stereo_imu() {
    full_length("room_figure8_stereo_imu");
}

#[test]
#[ignore = "full length"]
fn full_room_figure8_mono_imu() {
    full_length("room_figure8_mono_imu");
}

#[test]
#[ignore = "full length"]
fn full_room_figure8_stereo() {
    full_length("room_figure8_stereo");
}

#[test]
#[ignore = "full length"]
fn full_room_circle_stereo_imu() {
    full_length("room_circle_stereo_imu");
}

#[test]
#[ignore = "full length"]
fn full_room_replay_v2_02_stereo_imu() {
    full_length("room_replay_v2_02_stereo_imu");
}

#[test]
#[ignore = "full length"]
fn full_room_figure8_blackout_stereo_imu() {
    full_length("room_figure8_blackout_stereo_imu");
}

#[test]
#[ignore = "full length, every capture rendered"]
fn full_room_figure8_rendered_stereo_imu() {
    full_length("room_figure8_rendered_stereo_imu");
}
