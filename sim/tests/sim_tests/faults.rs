//! Every fault kind has a visible effect on the stream.

use crate::common;

use estimator::frontend::FeatureFrame;
use estimator::imu::ImuSample;
use sim::faults::Fault;
use sim::stream::Measurement;
use sim::{World, WorldConfig};

const S: i64 = 1_000_000_000;

fn run(faults: Vec<Fault>) -> (Vec<ImuSample>, Vec<FeatureFrame>) {
    let w = World::new(WorldConfig {
        seed: 5,
        duration_s: 6.0,
        rig: Some(common::rig(2)),
        faults,
        ..WorldConfig::default()
    })
    .unwrap();
    let (mut imu, mut frames) = (Vec::new(), Vec::new());
    let mut last = i64::MIN;
    for m in w.stream() {
        assert!(m.t_ns() >= last, "stream out of order");
        last = m.t_ns();
        match m {
            Measurement::Imu(s) => imu.push(s),
            Measurement::Frame(f) => frames.push(f),
            Measurement::Images(_) => panic!("images in a feature-level stream"),
            Measurement::Gnss(_) | Measurement::Wheel(_) => panic!("no aiding sensor configured"),
        }
    }
    (imu, frames)
}

#[test]
fn camera_blackout_drops_or_blanks_frames() {
    let (_, clean) = run(vec![]);
    assert_eq!(clean.len(), 121);
    let (_, dropped) = run(vec![Fault::CameraBlackout {
        start_ns: 2 * S,
        end_ns: 3 * S,
        black_frames: false,
    }]);
    assert_eq!(dropped.len(), 121 - 20);
    assert!(dropped.iter().all(|f| f.t_ns < 2 * S || f.t_ns >= 3 * S));
    let (_, black) = run(vec![Fault::CameraBlackout {
        start_ns: 2 * S,
        end_ns: 3 * S,
        black_frames: true,
    }]);
    assert_eq!(black.len(), 121);
    for f in &black {
        let empty = f.cameras.iter().all(|c| c.features.is_empty());
        assert_eq!(empty, (2 * S..3 * S).contains(&f.t_ns));
        assert_eq!(f.cameras.len(), 2);
    }
}

#[test]
fn camera_freeze_repeats_the_last_features_on_time() {
    let (_, clean) = run(vec![]);
    let (_, frozen) = run(vec![Fault::CameraFreeze {
        cam_id: Some(0),
        start_ns: 2 * S,
        end_ns: 3 * S,
    }]);
    assert_eq!(frozen.len(), clean.len());
    let last_before = frozen.iter().rfind(|f| f.t_ns < 2 * S).unwrap().cameras[0].clone();
    for (f, c) in frozen.iter().zip(&clean) {
        assert_eq!(f.t_ns, c.t_ns, "frames stay on time");
        assert_eq!(f.cameras[1], c.cameras[1], "the other camera is untouched");
        if (2 * S..3 * S).contains(&f.t_ns) {
            assert_eq!(f.cameras[0].features, last_before.features);
        } else {
            assert_eq!(f.cameras[0], c.cameras[0]);
        }
    }
    // Without a camera index every camera freezes.
    let (_, all) = run(vec![Fault::CameraFreeze {
        cam_id: None,
        start_ns: 2 * S,
        end_ns: 3 * S,
    }]);
    let inside: Vec<_> = all
        .iter()
        .filter(|f| (2 * S..3 * S).contains(&f.t_ns))
        .collect();
    assert!(inside.windows(2).all(|w| w[0].cameras == w[1].cameras));
}

#[test]
fn camera_death_is_permanent() {
    let (_, frames) = run(vec![Fault::CameraDeath {
        cam_id: 1,
        at_ns: 2 * S,
    }]);
    for f in &frames {
        let ids: Vec<usize> = f.cameras.iter().map(|c| c.cam_id).collect();
        assert_eq!(ids, if f.t_ns < 2 * S { vec![0, 1] } else { vec![0] });
    }
}

#[test]
fn random_frame_drops_follow_the_rate() {
    let (_, frames) = run(vec![Fault::FrameDrops {
        start_ns: 0,
        end_ns: i64::MAX,
        probability: 0.5,
    }]);
    let kept = frames.len() as f64 / 121.0;
    assert!((0.3..0.7).contains(&kept), "kept fraction {kept}");
}

#[test]
fn imu_dropout_removes_samples() {
    let (clean, _) = run(vec![]);
    let (imu, _) = run(vec![Fault::ImuDropout {
        start_ns: S,
        end_ns: 2 * S,
    }]);
    assert_eq!(imu.len(), clean.len() - 200);
    assert!(imu.iter().all(|s| s.t_ns < S || s.t_ns >= 2 * S));
}

#[test]
fn imu_spikes_and_saturation_change_values() {
    let (clean, _) = run(vec![]);
    let (spiky, _) = run(vec![Fault::ImuSpikes {
        start_ns: 0,
        end_ns: i64::MAX,
        probability: 0.1,
        gyro: 5.0,
        accel: 50.0,
    }]);
    let spikes = clean
        .iter()
        .zip(&spiky)
        .filter(|(a, b)| (a.gyro - b.gyro).norm() > 4.9 && (a.accel - b.accel).norm() > 49.0)
        .count();
    let changed = clean.iter().zip(&spiky).filter(|(a, b)| a != b).count();
    assert_eq!(spikes, changed);
    assert!(
        (spikes as f64 / clean.len() as f64 - 0.1).abs() < 0.03,
        "{spikes}"
    );
    let (sat, _) = run(vec![Fault::ImuSaturation {
        start_ns: 0,
        end_ns: 3 * S,
        gyro_range: 0.1,
        accel_range: 9.0,
    }]);
    for s in &sat {
        let clipped = s.gyro.amax() <= 0.1 && s.accel.amax() <= 9.0;
        if s.t_ns < 3 * S {
            assert!(clipped);
        }
    }
    assert!(sat.iter().any(|s| s.t_ns >= 3 * S && s.accel.amax() > 9.0));
}

#[test]
fn timestamp_jitter_and_time_offset_shift_stamps() {
    let (clean_imu, clean_frames) = run(vec![]);
    let (imu, frames) = run(vec![Fault::TimestampJitter {
        start_ns: 0,
        end_ns: i64::MAX,
        imu_sigma_ns: 2e5,
        camera_sigma_ns: 1e6,
    }]);
    let moved = imu
        .iter()
        .zip(&clean_imu)
        .filter(|(a, b)| a.t_ns != b.t_ns)
        .count();
    assert!(moved > imu.len() * 9 / 10);
    assert!(
        imu.iter()
            .zip(&clean_imu)
            .all(|(a, b)| (a.t_ns - b.t_ns).abs() <= 2_000_000 && a.gyro == b.gyro)
    );
    assert!(
        frames
            .iter()
            .zip(&clean_frames)
            .all(|(a, b)| a.cameras == b.cameras && (a.t_ns - b.t_ns).abs() <= 20_000_000)
    );
    assert!(
        frames
            .iter()
            .zip(&clean_frames)
            .any(|(a, b)| a.t_ns != b.t_ns)
    );
    let (_, offset) = run(vec![Fault::CameraTimeOffset {
        start_ns: 0,
        td_ns: 3_000_000,
    }]);
    for (a, b) in offset.iter().zip(&clean_frames) {
        assert_eq!(a.t_ns, b.t_ns - 3_000_000);
        assert_eq!(a.cameras, b.cameras);
    }
}
