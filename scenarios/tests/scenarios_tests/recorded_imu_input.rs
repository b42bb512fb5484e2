//! `rig.imu.recorded` refused at the door: without a replay, with a static start, a missing
//! log, a malformed or out-of-order row, a log that misses part of the run, a rate that does
//! not match. `vio run` exits 2 naming the scenario file, the key, and for a row the log's
//! file and line; nothing is written.

use crate::common;

use common::{assert_bad, assert_bad_with, default_text};

const CATALOG: &str = "room_replay_v1_01_real_imu_stereo_imu";
const GT: &str = "data/euroc_V1_01_easy_excerpt/mav0/state_groundtruth_estimate0/data.csv";
const IMU: &str = "data/euroc_V1_01_easy_excerpt/mav0/imu0/data.csv";

fn catalog_file(rel: &str) -> String {
    std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("catalog")
            .join(rel),
    )
    .unwrap()
}

/// The first `rows` data rows of a catalog csv, with its header.
fn head(rel: &str, rows: usize) -> String {
    catalog_file(rel)
        .lines()
        .take(rows + 1)
        .map(|l| format!("{l}\n"))
        .collect()
}

/// The catalog scenario cut to 20 s, with `edit` applied.
fn scenario(edit: impl FnOnce(String) -> String) -> String {
    let text = scenarios::catalog::get(CATALOG).unwrap().text;
    assert!(text.contains("duration_s = 145.0"));
    edit(text.replace("duration_s = 145.0", "duration_s = 20.0"))
}

/// 21 s of ground truth and of the log (the run needs 20 s).
fn data() -> (String, String) {
    (head(GT, 421), head(IMU, 4201))
}

#[test]
fn a_recorded_log_needs_a_replay() {
    let text = default_text(1.0).replace("[rig.imu]\n", "[rig.imu]\nrecorded = \"imu.csv\"\n");
    assert_bad(
        "recorded-no-replay",
        &text,
        "rig.imu.recorded",
        &["needs a replayed trajectory", "trajectory.replay"],
    );
}

#[test]
fn a_static_start_or_simulation_keys_are_refused_with_a_recorded_log() {
    let (gt, imu) = data();
    let files: [(&str, &[u8]); 2] = [(GT, gt.as_bytes()), (IMU, imu.as_bytes())];
    let text = scenario(|t| {
        t.replace(
            "duration_s = 20.0\n",
            "duration_s = 20.0\nstatic_start = { hold_s = 2.0, ramp_s = 1.0 }\n",
        )
    });
    assert_bad_with(
        "recorded-static",
        &text,
        &files,
        "trajectory.static_start",
        &["timing", "rig.imu.recorded"],
    );
    let text = scenario(|t| t.replace("rate_hz = 200.0\n", "rate_hz = 200.0\nnoise_free = true\n"));
    assert_bad_with(
        "recorded-noise-free",
        &text,
        &files,
        "rig.imu.noise_free",
        &[],
    );
    let text = scenario(|t| t.replace("rate_hz = 200.0\n", "rate_hz = 100.0\n"));
    assert_bad_with(
        "recorded-rate",
        &text,
        &files,
        "rig.imu.rate_hz",
        &["runs at 200.0", "imu0/data.csv"],
    );
}

#[test]
fn a_missing_log_is_refused_naming_the_file() {
    let (gt, _) = data();
    assert_bad_with(
        "recorded-missing",
        &scenario(|t| t),
        &[(GT, gt.as_bytes())],
        "rig.imu.recorded",
        &["cannot read", "imu0/data.csv"],
    );
}

#[test]
fn malformed_rows_are_refused_naming_the_file_and_line() {
    let (gt, imu) = data();
    let mut lines: Vec<String> = imu.lines().map(str::to_string).collect();
    // Line 5: a gyro value that is no number.
    let mut f: Vec<String> = lines[4].split(',').map(str::to_string).collect();
    f[2] = "abc".into();
    lines[4] = f.join(",");
    let bad = lines.join("\n") + "\n";
    assert_bad_with(
        "recorded-malformed",
        &scenario(|t| t),
        &[(GT, gt.as_bytes()), (IMU, bad.as_bytes())],
        "rig.imu.recorded",
        &["imu0/data.csv:5", "w_y", "abc"],
    );
    // Line 7 repeats line 6's stamp.
    let mut lines: Vec<String> = imu.lines().map(str::to_string).collect();
    let stamp6 = lines[5].split(',').next().unwrap().to_string();
    let rest7: Vec<&str> = lines[6].split(',').skip(1).collect();
    lines[6] = format!("{stamp6},{}", rest7.join(","));
    let bad = lines.join("\n") + "\n";
    assert_bad_with(
        "recorded-order",
        &scenario(|t| t),
        &[(GT, gt.as_bytes()), (IMU, bad.as_bytes())],
        "rig.imu.recorded",
        &["imu0/data.csv:7", "not increasing"],
    );
}

#[test]
fn a_log_that_misses_part_of_the_run_is_refused_saying_which() {
    let (gt, _) = data();
    // 10 s of log for a 20 s run.
    let short = head(IMU, 2001);
    assert_bad_with(
        "recorded-short",
        &scenario(|t| t),
        &[(GT, gt.as_bytes()), (IMU, short.as_bytes())],
        "rig.imu.recorded",
        &["10.000000 s to 20.000000 s are missing"],
    );
    let empty = head(IMU, 0);
    assert_bad_with(
        "recorded-empty",
        &scenario(|t| t),
        &[(GT, gt.as_bytes()), (IMU, empty.as_bytes())],
        "rig.imu.recorded",
        &["no IMU samples"],
    );
}

/// A step in the replayed ground truth is bridged by a blend under `repair` when the IMU is
/// simulated; under a recorded log, which flew the file's true motion, it is refused naming the
/// step's line.
#[test]
fn a_step_is_not_blended_under_a_recorded_log() {
    let (gt, imu) = data();
    // Rows 200 on (line 202 on) 8 cm off in x: a step nothing undoes.
    let stepped: String = gt
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i < 201 || l.starts_with('#') {
                return format!("{l}\n");
            }
            let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
            let x: f64 = f[1].trim().parse().unwrap();
            f[1] = format!("{:.6}", x + 0.08);
            format!("{}\n", f.join(","))
        })
        .collect();
    let repaired = |t: String| {
        t.replace(
            "knot_spacing_s = 0.05 }",
            "knot_spacing_s = 0.05, repair = true }",
        )
    };
    assert_bad_with(
        "recorded-step",
        &scenario(repaired),
        &[(GT, stepped.as_bytes()), (IMU, imu.as_bytes())],
        "trajectory.replay",
        &["line 202", "cannot be blended under a recorded IMU log"],
    );
}
