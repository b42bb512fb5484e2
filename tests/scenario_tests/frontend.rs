//! The image front end on rendered scenarios: tracks against the renderer's ground truth, the
//! estimator on those tracks, and determinism of the whole image pipeline.
//!
//! Needs Mesa's llvmpipe (`bash .ci/install-deps`). The full-length catalog runs are `--ignored`.

use crate::common;

use scenarios::report::Report;
use scenarios::spec::Scenario;

// Bounds: what was measured (seed 1 unless named, llvmpipe GL), with the margin stated.
/// Track error median: measured 0.134 px over 8 s; bound 1.5× (the target, 0.2 px).
const TRACK_MEDIAN_PX: f64 = 0.2;
/// Track error p95: measured 0.52 px; bound 1.35× (the target, 0.7 px).
const TRACK_P95_PX: f64 = 0.7;
/// Wrong tracks (> 2 px) the estimator gets: measured 0.41 %; bound ≈ 2.5×.
const WRONG_AFTER: f64 = 0.01;
/// ATE over the first 8 s: measured 0.0019 m; bound 3×.
const ATE_8S_M: f64 = 0.006;
/// `(scenario, seconds, fewest features, ATE bound m)` of the short catalog slices. Measured:
/// exposure jump 10 s (the jump at 8 s) min 150 features, ATE 0.0019 m; blur 4 s 150, 0.0030 m;
/// fast rotation 6 s 150, 0.0012 m; texture-poor hall 20 s 65, 0.0103 m; V2_02 replay 6 s
/// (seed 4) 150, 0.0029 m. Bounds: 50 features (the floor) or 120, ATE 3×.
const SHORT: &[(&str, f64, usize, f64)] = &[
    ("room_figure8_exposure_jump_rendered", 10.0, 120, 0.006),
    ("room_figure8_blur_rendered", 4.0, 120, 0.01),
    ("room_fast_rotation_rendered", 6.0, 120, 0.004),
    ("hall_poor_wall_rendered", 20.0, 50, 0.031),
    ("room_replay_v2_02_rendered", 6.0, 120, 0.009),
];

fn run_report(name: &str, seconds: Option<f64>) -> (Report, Vec<u8>) {
    let scenario = Scenario::load(name).unwrap();
    let done = common::run_scenario(scenario, seconds);
    let dir = common::written(&done);
    let bytes = std::fs::read(dir.path().join("estimate.tum")).unwrap();
    let json = std::fs::read_to_string(dir.path().join("report.json")).unwrap();
    assert!(
        json.contains("\"track_error_median_px\""),
        "report.json lacks frontend"
    );
    (done.run.report, bytes)
}

fn print(name: &str, r: &Report) {
    let f = r.frontend.unwrap();
    eprintln!(
        "{name}: ATE {:.4} m, rot {:.3}°, features mean {:.0} min {}, track {:.1} frames, stereo {:.2}, track error median {:.3} p95 {:.3} px, wrong {:.4} → {:.4}, stereo error median {:.3} p95 {:.3} px",
        r.ate_rmse_m.unwrap(),
        r.ate_rot_rmse_deg.unwrap(),
        f.features_mean,
        f.features_min,
        f.mean_track_length,
        f.stereo_match_ratio,
        f.track_error_median_px,
        f.track_error_p95_px,
        f.wrong_before_ransac,
        f.wrong_after_ransac,
        f.stereo_error_median_px,
        f.stereo_error_p95_px
    );
}

/// 8 s of the rendered default motion: the tracker's errors against ground truth and the
/// estimate built on its tracks (bounds: measured figures in the comments, with margin).
#[test]
fn rendered_figure_eight_tracks_and_estimate_meet_their_bounds() {
    let (r, _) = run_report("room_figure8_rendered_stereo_imu", Some(8.0));
    print("room_figure8_rendered 8 s", &r);
    let f = r.frontend.unwrap();
    assert_eq!(f.frames, 161);
    assert!(f.features_min >= 140, "{}", f.features_min);
    assert!(f.stereo_match_ratio > 0.95, "{}", f.stereo_match_ratio);
    assert!(
        f.track_error_median_px < TRACK_MEDIAN_PX,
        "{}",
        f.track_error_median_px
    );
    assert!(
        f.track_error_p95_px < TRACK_P95_PX,
        "{}",
        f.track_error_p95_px
    );
    assert!(
        f.wrong_after_ransac < WRONG_AFTER,
        "{}",
        f.wrong_after_ransac
    );
    assert!(
        f.stereo_error_median_px < 0.1,
        "{}",
        f.stereo_error_median_px
    );
    assert!(r.ate_rmse_m.unwrap() < ATE_8S_M, "{:?}", r.ate_rmse_m);
    assert!(r.passed);
}

/// The same images give the same tracks and the same estimate, byte for byte.
#[test]
fn the_image_pipeline_is_deterministic() {
    let (a, bytes_a) = run_report("room_fast_rotation_rendered", Some(2.0));
    let (b, bytes_b) = run_report("room_fast_rotation_rendered", Some(2.0));
    assert!(bytes_a.len() > 500);
    assert!(bytes_a == bytes_b, "estimates differ");
    assert_eq!(a.frontend, b.frontend);
}

/// The left camera dies at 20 s under the image front end: the window goes on as mono+IMU on
/// the right camera's tracks. Measured over 25 s (seed 1): one switch at 20.46 s, 491 of 501
/// frames tracking, ATE 0.0041 m (60 s: 0.0069 m, the catalog scenario, `--ignored` below).
#[test]
fn rendered_left_camera_death_continues_on_the_right_camera() {
    let (r, _) = run_report("room_figure8_left_camera_death_rendered", Some(25.0));
    print("room_figure8_left_camera_death_rendered", &r);
    let switches: Vec<_> = r
        .events
        .iter()
        .filter(|e| e.kind == "suite_switch")
        .map(|e| (e.t_s, e.detail.as_str()))
        .collect();
    assert_eq!(switches.len(), 1, "{switches:?}");
    assert!((switches[0].0 - 20.46).abs() < 0.1, "{switches:?}");
    assert!(switches[0].1.starts_with("stereo_imu -> mono_imu(cam1)"));
    assert!(r.tracking_frames >= 480, "{} tracking", r.tracking_frames);
    assert!(r.ate_rmse_m.unwrap() < 0.008, "{:?}", r.ate_rmse_m);
}

/// A short slice of every image-front-end scenario of the catalog: tracked features and a
/// bounded estimate (the full-length runs are the `--ignored` test below).
#[test]
fn image_catalog_scenarios_keep_features_and_do_not_diverge_short() {
    for (name, seconds, min_features, max_ate) in SHORT {
        let (r, _) = run_report(name, Some(*seconds));
        print(name, &r);
        let f = r.frontend.unwrap();
        assert!(
            f.features_min >= *min_features,
            "{name}: {}",
            f.features_min
        );
        assert!(
            r.ate_rmse_m.unwrap() < *max_ate,
            "{name}: {:?}",
            r.ate_rmse_m
        );
    }
}

/// Every image-front-end scenario of the catalog at full length meets its expectations.
#[test]
#[ignore = "full-length rendered runs: minutes"]
fn image_catalog_scenarios_meet_their_expectations() {
    for name in [
        "room_figure8_rendered_stereo_imu",
        "room_figure8_exposure_jump_rendered",
        "room_figure8_blur_rendered",
        "room_fast_rotation_rendered",
        "hall_poor_wall_rendered",
        "room_replay_v2_02_rendered",
        "room_figure8_left_camera_death_rendered",
        "room_figure8_blackout_2s_rendered",
    ] {
        let (r, _) = run_report(name, None);
        print(name, &r);
        for e in &r.expectations {
            assert!(e.passed, "{name}: {} = {:?}", e.metric, e.value);
        }
    }
}
