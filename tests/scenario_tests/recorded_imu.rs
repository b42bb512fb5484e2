//! A recorded IMU log under simulated cameras (`rig.imu.recorded`): the first 15 s of the real
//! EuRoC V1_01 flight (4 s at rest, then take-off) track without a reset, the log's checks
//! against the replayed ground truth find its clock and frame, and the run is deterministic.

use crate::common;

use scenarios::report::Report;
use scenarios::spec::Scenario;
use tempfile::TempDir;

const NAME: &str = "room_replay_v1_01_real_imu_stereo_imu";
const DURATION_S: f64 = 15.0;

/// Runs the scenario for [`DURATION_S`], writes its files into a fresh folder and returns the
/// folder and the report.
fn run_into() -> (TempDir, Report) {
    let scenario = Scenario::load(NAME).unwrap_or_else(|e| panic!("{e}"));
    let done = common::run_scenario(scenario, Some(DURATION_S));
    (common::written(&done), done.run.report)
}

#[test]
fn a_recorded_imu_log_tracks_and_its_clock_and_frame_check_out() {
    let (a, rep) = run_into();
    assert_eq!(rep.resets, 0, "resets");
    assert!(rep.tracking_fraction > 0.9, "{}", rep.tracking_fraction);
    let ate = rep.ate_rmse_m.expect("an ATE");
    assert!(ate < 0.05, "ATE {ate} m");

    let imu = rep
        .replay
        .as_ref()
        .and_then(|r| r.recorded_imu.as_ref())
        .expect("replay.recorded_imu");
    assert_eq!(imu.biases, "recording");
    // 15 s at 200 Hz, both ends included.
    assert_eq!(imu.samples, 3001);
    let c = imu.comparison.as_ref().expect("a comparison");
    assert!(c.flight_samples > 1000 && c.rest_samples > 400, "{c:?}");
    for clock in [c.clock, c.clock_vector] {
        let clock = clock.expect("a clock lag");
        assert!(clock.lag_ms.abs() < 2.0, "{clock:?}");
        assert!(clock.correlation > 0.95, "{clock:?}");
    }
    let frame = c.frame.expect("a frame check");
    assert!(frame.angle_deg < 0.5, "{frame:?}");
    // The real sensor is far noisier than its datasheet's white noise.
    let rms = c.residual.gyro.rms_flight.unwrap();
    assert!(
        rms.iter().all(|r| *r > 2.0 * imu.datasheet_sigma.gyro),
        "{rms:?}"
    );

    let (b, _) = run_into();
    for name in [
        "estimate.tum",
        "estimate_source_time.tum",
        "groundtruth.tum",
    ] {
        let fa = std::fs::read(a.path().join(name)).unwrap();
        let fb = std::fs::read(b.path().join(name)).unwrap();
        assert!(fa.len() > 1000, "{name} is too short");
        assert!(fa == fb, "{name} differs between two identical runs");
    }
    // Source time: the recording's own stamps (the log's and the ground truth's first is
    // 1403715273262142976 ns, the run's 0).
    let source = std::fs::read_to_string(a.path().join("estimate_source_time.tum")).unwrap();
    let first = source.lines().find(|l| !l.starts_with('#')).unwrap();
    assert!(first.starts_with("1403715273."), "{first}");
}
