//! `vio imu-model`: the Allan fit recovers the densities a simulated IMU was given, and bad
//! input is refused with the file named (exit 2), never a panic.

use crate::common;

use std::sync::Arc;

use estimator::imu::{ImuNoise, ImuSample};
use nalgebra::{UnitQuaternion, Vector3};
use scenarios::imu_model::{Input, Options, analyze};
use sim::imu::{ImuConfig, ImuSim, ImuWindow};
use sim::motion::{BodyParams, ControllerGains, MotionSim, RefState, Reference, TruthBuffer};

use common::{scratch, vio, write};

/// A body held still at the origin, level.
#[derive(Debug)]
struct AtRest;

impl Reference for AtRest {
    fn state(&self, _t: f64) -> RefState {
        RefState {
            p: Vector3::zeros(),
            v: Vector3::zeros(),
            a: Vector3::zeros(),
            q: UnitQuaternion::identity(),
            omega_w: Vector3::zeros(),
            alpha_w: Vector3::zeros(),
        }
    }

    fn duration(&self) -> Option<f64> {
        None
    }
}

/// `seconds` of a still IMU at 200 Hz through the simulator's own IMU (`ImuSim::next_sample`:
/// its white noise and bias random walk), one physics step per sample.
fn still_log(noise: ImuNoise, seconds: f64, seed: u64) -> Vec<ImuSample> {
    let cfg = ImuConfig {
        window: ImuWindow::Forward,
        noise: Some(noise),
        gyro_range: None,
        accel_range: None,
        ..ImuConfig::default()
    };
    let period = cfg.period_ns();
    let motion = MotionSim::new(
        Arc::new(AtRest),
        BodyParams::default(),
        ControllerGains::default(),
        period,
        0,
    );
    let mut truth = TruthBuffer::new(motion);
    let mut imu = ImuSim::new(cfg, seed);
    let n = (seconds * 200.0).round() as usize;
    (0..n)
        .map(|_| {
            let (s, _) = imu.next_sample(&mut truth);
            truth.trim(imu.needs_from_ns());
            s
        })
        .collect()
}

/// The test's densities: white noise as EuRoC's ADIS16448, random walks 300× (gyro) and 23×
/// (accelerometer) EuRoC's, so that they dominate from τ ≈ 0.05 s on (crossover
/// `τ = √3·N/K`: 0.049 s, 0.049 s).
///
/// Why not EuRoC's own random walks: the fitted `K`'s scatter is set by the number of
/// independent clusters in the random-walk region, i.e. by `T/τ_crossover`. With the values
/// below, 600 s (T/τ ≈ 12 000) give a standard deviation of 1.6 % (gyro) and 1.3 % (accel) for
/// `K` and 0.3 % for `N` over 40 seeds × 3 axes (`recovery_error_statistics`, ignored), so the
/// 10 % bound is ≥ 6 σ. EuRoC's gyro crossover is at 15.5 s: the same 1.6 % would need ≈ 50 h
/// of 200 Hz samples, a 3.3 % (10 % = 3 σ) still ≈ 13 h, too long to simulate in a default test.
const NOISE: ImuNoise = ImuNoise {
    gyroscope_noise_density: 1.7e-4,
    gyroscope_random_walk: 6e-3,
    accelerometer_noise_density: 2e-3,
    accelerometer_random_walk: 7e-2,
};

/// Relative errors of the fitted `[N_gyro, K_gyro, N_accel, K_accel]` per axis.
fn recovery_errors(seconds: f64, seed: u64) -> Vec<[f64; 4]> {
    let input = Input {
        log: "simulated".into(),
        samples: still_log(NOISE, seconds, seed),
        ..Input::default()
    };
    let m = analyze(&input, &Options::default()).unwrap();
    (0..3)
        .map(|a| {
            let g = m.allan.raw.gyro.axes[a].fit.unwrap();
            let f = m.allan.raw.accel.axes[a].fit.unwrap();
            [
                g.white_noise_density / NOISE.gyroscope_noise_density - 1.0,
                g.random_walk / NOISE.gyroscope_random_walk - 1.0,
                f.white_noise_density / NOISE.accelerometer_noise_density - 1.0,
                f.random_walk / NOISE.accelerometer_random_walk - 1.0,
            ]
        })
        .collect()
}

#[test]
#[ignore = "statistics over many seeds: cargo test --release -p scenarios --test scenarios_tests imu_model:: -- --ignored --nocapture"]
fn recovery_error_statistics() {
    let seconds: f64 = std::env::var("IMU_MODEL_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(600.0);
    let seeds = 40;
    let mut all: Vec<[f64; 4]> = Vec::new();
    for seed in 1..=seeds {
        all.extend(recovery_errors(seconds, seed));
    }
    for (q, name) in ["N gyro", "K gyro", "N accel", "K accel"]
        .iter()
        .enumerate()
    {
        let v: Vec<f64> = all.iter().map(|e| e[q]).collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
        let max = v.iter().map(|x| x.abs()).fold(0.0, f64::max);
        println!(
            "{seconds} s, {} axes: {name}: mean {mean:+.4}, sd {sd:.4}, max |e| {max:.4}",
            v.len()
        );
    }
}

#[test]
fn allan_fit_recovers_the_simulators_densities() {
    // 600 s at 200 Hz, seed 7. Measured relative errors (x / y / z):
    //   N gyro  −0.26 / +0.19 / +0.70 %,  K gyro  +2.12 / +0.08 / −0.01 %,
    //   N accel −0.02 / −0.04 / +0.35 %,  K accel −2.90 / −1.67 / −2.09 %.
    let errors = recovery_errors(600.0, 7);
    for (axis, e) in ["x", "y", "z"].iter().zip(&errors) {
        println!(
            "axis {axis}: N gyro {:+.4}, K gyro {:+.4}, N accel {:+.4}, K accel {:+.4}",
            e[0], e[1], e[2], e[3]
        );
    }
    for (axis, e) in ["x", "y", "z"].iter().zip(&errors) {
        for (name, v) in ["N gyro", "K gyro", "N accel", "K accel"].iter().zip(e) {
            assert!(
                v.abs() < 0.10,
                "axis {axis}: {name} off by {:+.1} %",
                v * 100.0
            );
        }
    }
}

/// Runs `vio imu-model ARGS… --out DIR`; returns (exit code, stderr).
fn imu_model(args: &[&str], out: &std::path::Path) -> (Option<i32>, String) {
    let mut all = vec!["imu-model"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", out.to_str().unwrap()]);
    let o = vio(&all);
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

const IMU_HEADER: &str = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";

fn imu_rows(n: usize) -> String {
    (0..n)
        .map(|k| {
            let x = (k as f64 * 0.7).sin() * 1e-3;
            format!("{},{x},{},0.0,0.01,-0.02,9.81\n", k as i64 * 5_000_000, -x)
        })
        .collect()
}

#[test]
fn bad_input_is_refused_with_the_file_named() {
    let dir = scratch("imu-model-bad");
    let dir = dir.path();
    let out = dir.join("out");
    let check = |tag: &str, (code, stderr): (Option<i32>, String), expect: &[&str]| {
        assert_eq!(code, Some(2), "{tag}: stderr: {stderr}");
        for e in expect {
            assert!(stderr.contains(e), "{tag}: `{e}` missing: {stderr}");
        }
        assert!(!out.exists(), "{tag}: wrote output on bad input");
    };

    let missing = dir.join("missing.csv");
    check(
        "missing",
        imu_model(&[missing.to_str().unwrap()], &out),
        &["missing.csv"],
    );

    // Line 4 (header, two rows, then this) has a word in the w_y column.
    let text = IMU_HEADER.to_string()
        + &imu_rows(2)
        + "10000000,0.1,abc,0.3,0.0,0.0,9.8\n"
        + &imu_rows(300);
    let bad_row = write(dir, "bad_row.csv", &text);
    check(
        "malformed row",
        imu_model(&[bad_row.to_str().unwrap()], &out),
        &["bad_row.csv:4", "w_y", "abc"],
    );

    // Microsecond stamps read as nanoseconds: a 200 Hz IMU at 200 kHz.
    let micro: String = imu_rows(300)
        .lines()
        .map(|l| {
            let (t, rest) = l.split_once(',').unwrap();
            format!("{},{rest}\n", t.parse::<i64>().unwrap() / 1000)
        })
        .collect();
    let micro = write(dir, "micro.csv", &(IMU_HEADER.to_string() + &micro));
    check(
        "microsecond stamps",
        imu_model(&[micro.to_str().unwrap()], &out),
        &["micro.csv", "look like microseconds", "200.0 Hz"],
    );

    let short = write(dir, "short.csv", &(IMU_HEADER.to_string() + &imu_rows(50)));
    check(
        "too short",
        imu_model(&[short.to_str().unwrap()], &out),
        &["short.csv", "50 samples", "at least 100"],
    );

    let good = write(dir, "good.csv", &(IMU_HEADER.to_string() + &imu_rows(400)));
    let g = good.to_str().unwrap();
    check(
        "from after to",
        imu_model(&[g, "--from", "1.5", "--to", "0.5"], &out),
        &["--from", "--to"],
    );
    check(
        "negative from",
        imu_model(&[g, "--from=-1"], &out),
        &["--from"],
    );
    for interval in ["0", "5", "nan"] {
        check(
            "estimator interval",
            imu_model(&[g, "--interval", interval], &out),
            &["--interval", "[0.001, 1] s"],
        );
    }
    for window in ["0.01", "20", "nan"] {
        check(
            "estimator window",
            imu_model(&[g, "--window", window], &out),
            &["--window", "10] s"],
        );
    }

    // Ground truth with a quaternion of norm 2 on line 3.
    let gt_row = |t: i64, qw: f64| format!("{t},0,0,0,{qw},0,0,0,0,0,0,0,0,0,0,0,0\n");
    let gt_text =
        "#timestamp, p, q, v, bw, ba\n".to_string() + &gt_row(0, 1.0) + &gt_row(50_000_000, 2.0);
    let bad_gt = write(dir, "bad_gt.csv", &gt_text);
    check(
        "malformed ground truth",
        imu_model(&[g, "--gt", bad_gt.to_str().unwrap()], &out),
        &["bad_gt.csv:3", "quaternion"],
    );

    // Ground truth of another time: covers none of the log.
    let far: String = (0..40)
        .map(|k| gt_row(1_000_000_000_000 + k * 50_000_000, 1.0))
        .collect();
    let far_gt = write(dir, "far_gt.csv", &("#t\n".to_string() + &far));
    check(
        "ground truth elsewhere",
        imu_model(&[g, "--gt", far_gt.to_str().unwrap()], &out),
        &["far_gt.csv", "covers 0"],
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_simulated_flight_matches_its_ground_truth_and_the_output_is_deterministic() {
    // `vio export`: the default scenario's IMU and ground truth (200 Hz, true biases) and the
    // sensor.yaml with its densities.
    let dir = scratch("imu-model-export");
    let dir = dir.path();
    let o = vio(&["export", "--out", dir.to_str().unwrap(), "--duration", "30"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mav0 = dir.join("mav0");
    let gt = mav0.join("state_groundtruth_estimate0/data.csv");
    let run = |out: &str| {
        let out = dir.join(out);
        let (code, stderr) = imu_model(
            &[mav0.to_str().unwrap(), "--gt", gt.to_str().unwrap()],
            &out,
        );
        assert_eq!(code, Some(0), "{stderr}");
        std::fs::read(out.join("imu_model.json")).unwrap()
    };
    let first = run("a");
    assert_eq!(first, run("b"), "same input, different imu_model.json");
    assert!(dir.join("a/allan.png").is_file() && dir.join("a/spectrum.png").is_file());
    let m: serde_json::Value = serde_json::from_slice(&first).unwrap();
    let g = &m["groundtruth"];
    let lag = g["clock_vector"]["lag_ms"].as_f64().unwrap();
    assert!(lag.abs() < 1.0, "clock lag {lag} ms");
    let angle = g["frame"]["angle_deg"].as_f64().unwrap();
    assert!(angle < 0.1, "frame angle {angle}°");
    // Against a 200 Hz ground truth the residual is the sensor's noise: its white-noise density
    // is the simulator's.
    let yaml = &m["sensor_yaml"];
    for (sensor, key) in [
        ("gyro", "gyroscope_noise_density"),
        ("accel", "accelerometer_noise_density"),
    ] {
        let fit = m["allan"]["residual"][sensor]["fit_mean"]["white_noise_density"]
            .as_f64()
            .unwrap();
        let truth = yaml[key].as_f64().unwrap();
        assert!(
            (fit / truth - 1.0).abs() < 0.1,
            "{sensor}: N {fit} vs {truth}"
        );
        // A white sensor needs no more than its datasheet: the estimator's model is the
        // datasheet's (the white-equivalent density at 50 ms is within 15 % of it).
        let per_axis = m["estimator_noise"]["per_axis"][sensor].as_array().unwrap();
        for v in per_axis {
            let v = v.as_f64().unwrap();
            assert!((v / truth - 1.0).abs() < 0.15, "{sensor}: {v} vs {truth}");
        }
        let assumed = m["estimator_noise"][key].as_f64().unwrap();
        assert!(
            assumed >= truth && assumed < 1.15 * truth,
            "{sensor}: {assumed}"
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

/// The built-in estimator model `euroc_mav` is what `vio imu-model --gt` writes from the real
/// V1_01 log in the catalog, key for key (nothing in it is tuned by hand), and it is the
/// flight's: many times the datasheet's white noise.
#[test]
fn the_built_in_estimator_model_is_the_one_imu_model_measures() {
    let mav0 = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("catalog/data/euroc_V1_01_easy_excerpt/mav0");
    let dir = scratch("imu-model-estimator");
    let out = dir.path().join("out");
    let (code, stderr) = imu_model(
        &[
            mav0.join("imu0/data.csv").to_str().unwrap(),
            "--gt",
            mav0.join("state_groundtruth_estimate0/data.csv")
                .to_str()
                .unwrap(),
        ],
        &out,
    );
    assert_eq!(code, Some(0), "{stderr}");
    let keys = |text: &str| -> toml::Table { text.parse().unwrap() };
    let written = std::fs::read_to_string(out.join("estimator_imu_noise.toml")).unwrap();
    let preset = scenarios::catalog::estimator_imu_noise("euroc_mav").unwrap();
    assert_eq!(keys(&written), keys(preset));
    let n = |k: &str| keys(preset)[k].as_float().unwrap();
    // Matched over 50–800 ms the flight's white density is 8× the datasheet's (16× / 13× at
    // 50 ms alone, where vibration is at its worst against white noise).
    assert!(n("gyroscope_noise_density") > 5.0 * 1.6968e-4);
    assert!(n("accelerometer_noise_density") > 5.0 * 2.0e-3);
}
