//! Marginalization consistency at scenario level: the sliding window against the full batch
//! over its own keyframes on the same measurements (`vio run --batch-reference`).

use scenarios::batch::BatchReport;
use scenarios::report;
use scenarios::run::{RunOptions, run};
use scenarios::spec::Scenario;

fn batch_reference(name: &str, duration_s: Option<f64>) -> BatchReport {
    let scenario = Scenario::load(name).unwrap_or_else(|e| panic!("{e}"));
    let options = RunOptions {
        duration_s,
        batch_reference: true,
        ..Default::default()
    };
    let output = run(&scenario, &options, &mut |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let eval = report::evaluate(&output, scenario.spec.suite);
    let report = report::build_report(&scenario, &output, &eval);
    println!("{}", report::summary(&report, None));
    report.batch_reference.expect("a batch reference")
}

#[test]
fn the_batch_beats_the_window_on_the_first_20_s() {
    // Seed 1, 20 s, realistic track ids: 114 keyframes; batch 0.0037 m, window 0.0104 m
    // (x2.78), causal 0.0125 m (x3.35). Over a short run the batch gains most: every keyframe
    // still shares landmarks with many others.
    let b = batch_reference("room_figure8_stereo_imu", Some(20.0));
    assert!(b.keyframes >= 100, "{b:?}");
    assert!(b.ate_batch_m < b.ate_window_m, "{b:?}");
    assert!(b.ate_window_m <= b.ate_causal_m * 1.05, "{b:?}");
    assert!(
        b.ratio_window <= 3.3,
        "window x{:.2} of the batch",
        b.ratio_window
    );
}

#[test]
#[ignore = "full length: ~30 s in release"]
fn the_window_is_within_1_3_of_the_batch_over_60_s() {
    // Seed 1, 60 s: 380 keyframes; batch 0.0082 m, window 0.0104 m (x1.26), causal 0.0119 m.
    let b = batch_reference("room_figure8_stereo_imu", None);
    assert!(
        b.ratio_window <= 1.3,
        "window x{:.2} of the batch",
        b.ratio_window
    );
}

#[test]
fn nees_study_is_deterministic_and_states_its_overconfidence() {
    use scenarios::nees::{NeesOptions, run_nees};
    let scenario = Scenario::load("room_figure8_stereo_imu").unwrap();
    let options = |threads| NeesOptions {
        seeds: vec![1, 2, 3],
        duration_s: Some(8.0),
        threads,
    };
    let one = run_nees(&scenario, &options(1)).unwrap();
    let two = run_nees(&scenario, &options(2)).unwrap();
    print!("{}", scenarios::nees::summary(&one));
    for (a, b) in one.metrics.iter().zip(&two.metrics) {
        assert_eq!(
            a.series, b.series,
            "{}: thread count changed the result",
            a.name
        );
    }
    assert_eq!(one.ate_rmse_m, two.ate_rmse_m);
    // Measured (seeds 1-3, 8 s): the newest state's covariance is overconfident. Bounds are
    // the measured values +30 %, so that any further loss of consistency fails here; the
    // issue's goal is every value inside its band.
    // Bands for 3 runs: [0.89, 6.34] (3 dof), [0.40, 4.81] (2 dof).
    let measured = [
        ("velocity", 11.16),
        ("accel_bias", 6.44),
        ("gyro_bias", 17.93),
        ("roll_pitch", 4.34),
    ];
    for (m, (name, value)) in one.metrics.iter().zip(measured) {
        assert_eq!(m.name, name);
        assert!(
            m.series.len() >= 140,
            "{name}: {} frame times",
            m.series.len()
        ); // 152
        assert!(
            m.time_average <= 1.3 * value,
            "{name}: NEES {:.2}, measured {value}",
            m.time_average
        );
    }
}
