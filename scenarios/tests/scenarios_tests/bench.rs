//! `vio bench --one`: one benchmark scenario's row, as each child process prints it.

use crate::common;

use common::vio;

/// `vio bench --one NAME --quick`'s row; asserts it exits 0.
fn row(name: &str) -> scenarios::studies::bench::BenchRow {
    let out = vio(&["bench", "--one", name, "--quick"]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn one_benchmark_row_has_every_stage() {
    let row = row("room_figure8_stereo_imu");
    // 8 s at 20 Hz, both ends included; with the time offset estimated the last frame's IMU
    // time `t + td` may fall after the last IMU sample, and it then waits for IMU past the end.
    assert!((160..=161).contains(&row.frames), "{} frames", row.frames);
    assert!(row.render_ms.is_none());
    assert!(row.backend_ms.median > 0.0 && row.backend_ms.median <= row.backend_ms.p99);
    assert!(row.solve_ms.median <= row.backend_ms.max);
    assert!(row.frames_per_s > 0.0);
    // Linux reports the peak resident memory.
    if cfg!(target_os = "linux") {
        assert!(row.peak_memory_mib.is_some_and(|m| m > 1.0));
    }
    assert!(row.ate_rmse_m.is_some_and(|a| a < 0.05));
    let out = vio(&["bench", "--one", "no_such"]);
    assert_eq!(out.status.code(), Some(2));
}

/// The real-frames row: the committed EuRoC V1_01 excerpt (20 stereo pairs at rest) through the
/// image front end and the estimator; its sanity figure is the position drift from the first
/// pose (measured 2.2 mm).
#[test]
fn the_real_frames_row_tracks_images() {
    let row = row("euroc_V1_01_easy_excerpt");
    assert_eq!((row.mode.as_str(), row.frames), ("recorded", 20));
    assert!(row.render_ms.is_none());
    assert!(row.frontend_ms.median > 0.0 && row.backend_ms.median > 0.0);
    assert!(
        row.ate_rmse_m.is_some_and(|d| d < 0.005),
        "{:?}",
        row.ate_rmse_m
    );
}
