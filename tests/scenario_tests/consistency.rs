//! Marginalization consistency at scenario level: the sliding window against the full batch
//! over its own keyframes on the same measurements, and against the full-information filter
//! at checkpoints during the run (`vio run --batch-reference`).

use crate::common;

use scenarios::report::Report;
use scenarios::report::window_vs_batch::BatchReport;
use scenarios::run::RunOptions;
use scenarios::spec::Scenario;

fn reference_report(name: &str, duration_s: Option<f64>) -> Report {
    let scenario = Scenario::load(name).unwrap_or_else(|e| panic!("{e}"));
    let options = RunOptions {
        duration_s,
        batch_reference: true,
        ..Default::default()
    };
    common::run_with(scenario, &options).run.report
}

fn batch_reference(name: &str, duration_s: Option<f64>) -> BatchReport {
    reference_report(name, duration_s)
        .batch_reference
        .expect("a batch reference")
}

#[test]
fn the_batch_beats_the_window_on_the_first_20_s() {
    // Seed 1, 20 s, realistic track ids, the default's 100 inverse-distance points: 113
    // keyframes; batch 0.0028 m, window 0.0036 m (x1.25), causal 0.0051 m (x1.80) (at 30 world
    // points: 0.0030 / 0.0052 / 0.0061 m, x1.75; before 3-dof landmarks and persistent points:
    // window 0.0104 m, x2.78). Over a short run the batch gains most: every keyframe still
    // shares landmarks with many others. Bound: the measured ratio + 30 %.
    let report = reference_report("room_figure8_stereo_imu", Some(20.0));
    let b = report.batch_reference.expect("a batch reference");
    assert!(b.keyframes >= 100, "{b:?}");
    assert!(b.ate_batch_m < b.ate_window_m, "{b:?}");
    assert!(b.ate_window_m <= b.ate_causal_m * 1.05, "{b:?}");
    assert!(
        b.ratio_window <= 1.65,
        "window x{:.2} of the batch",
        b.ratio_window
    );
    // The same run against the full-information filter (every measurement so far, the same
    // initial prior, no marginalization) every 2 s of camera time. Measured: 11 checkpoints
    // (0, 2, …, 20 s), window 0.0043 m, filter 0.0044 m (x0.98), rotation 0.137 / 0.136 deg,
    // position gap median 0.0023 m, max 0.0038 m (at 30 world points: 0.0067 / 0.0052 m,
    // x1.28, gap 0.0087 / 0.0150 m). A filter that lost its prior (gauge adrift) or solved
    // another frame would be metres or a frame's motion (~5 cm) away. Bounds: the ratio
    // + 20 %, the gap x2.
    let f = report.filter_reference.expect("a filter reference");
    assert_eq!(f.checkpoints, 11, "{f:?}");
    assert!(f.last_batch_frames >= 100, "{f:?}");
    assert!(f.ratio <= 1.2, "window x{:.2} of the filter", f.ratio);
    assert!(f.position_gap_m[1] <= 0.008, "{f:?}");
    assert!(f.ate_rot_deg[1] <= f.ate_rot_deg[0] * 1.1, "{f:?}");
}

#[test]
#[ignore = "full length: ~60 s in release"]
fn the_window_stays_within_a_stated_factor_of_the_batch_over_60_s() {
    // Seed 1, 60 s, the default's 100 inverse-distance points: 381 keyframes; batch 0.0041 m,
    // window 0.0045 m (x1.10), causal 0.0050 m. At 30 world points: 382 keyframes, 0.0043 /
    // 0.0088 / 0.0094 m (x2.06); before the consistency work the window was at 0.0104 m but
    // the batch only at 0.0082 m (x1.26). Bound: the measured ratio + 20 %.
    let b = batch_reference("room_figure8_stereo_imu", None);
    assert!(
        b.ratio_window <= 1.35,
        "window x{:.2} of the batch",
        b.ratio_window
    );
}

#[test]
fn nees_study_is_deterministic_and_consistent() {
    use scenarios::studies::nees_monte_carlo::{NeesOptions, run_nees};
    let scenario = Scenario::load("room_figure8_stereo_imu").unwrap();
    let options = |threads, batch_reference| NeesOptions {
        seeds: vec![1, 2, 3],
        duration_s: Some(8.0),
        threads,
        batch_reference,
    };
    // The second study also solves the full-information filter at checkpoints: a side
    // computation that must not move the window by a bit.
    let one = run_nees(&scenario, &options(1, false)).unwrap();
    let two = run_nees(&scenario, &options(2, true)).unwrap();
    print!("{}", scenarios::studies::nees_monte_carlo::summary(&one));
    for (a, b) in one.metrics.iter().zip(&two.metrics) {
        assert_eq!(
            a.series, b.series,
            "{}: thread count changed the result",
            a.name
        );
    }
    assert_eq!(one.ate_rmse_m, two.ate_rmse_m);
    // Every time average inside its two-sided 95 % band for 3 runs ([0.89, 6.34] for 3 dof,
    // [0.40, 4.81] for 2, [2.74, 10.51] for 6): the band itself is what fewer seeds widen,
    // nothing else. Measured (seeds 1-3, 8 s): velocity 2.98, accel bias 1.74, gyro bias 3.55,
    // roll/pitch 1.01, relative pose over 0.5 s 6.26 (before 3-dof landmarks, no double
    // counting and per-observation weights: 11.16, 6.44, 17.93, 4.34; no relative pose).
    for m in &one.metrics {
        assert!(
            m.series.len() >= 140,
            "{}: {} frame times",
            m.name,
            m.series.len()
        ); // 152
        assert!(
            m.inside,
            "{}: NEES {:.2} outside [{:.2}, {:.2}]",
            m.name, m.time_average, m.band[0], m.band[1]
        );
    }
    // At the 10 filter checkpoints (every 0.8 s of camera time, the same frames in every seed)
    // the window and the full-information filter, each against the truth with its own
    // covariance, both inside every band. Measured (2026-12-03): window 3.33 / 1.32 / 2.67 /
    // 0.59 / 6.41, filter 3.00 / 1.23 / 2.36 / 0.57 / 5.80 (velocity, accel bias, gyro bias,
    // roll/pitch, relative pose). A filter whose covariance lost its prior, or was read for
    // another frame, would be far outside.
    print!("{}", scenarios::studies::nees_monte_carlo::summary(&two));
    let f = two.filter_reference.as_ref().expect("the filter reference");
    for (w, fi) in f.window.iter().zip(&f.filter) {
        assert_eq!(w.series.len(), 10, "{}: checkpoints", w.name);
        assert_eq!(fi.series.len(), 10, "{}: checkpoints", fi.name);
        for (who, m) in [("window", w), ("filter", fi)] {
            assert!(
                m.inside,
                "{who} {}: NEES {:.2} outside [{:.2}, {:.2}]",
                m.name, m.time_average, m.band[0], m.band[1]
            );
        }
    }
}
