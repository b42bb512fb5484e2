//! The merged stream: ordering, counts, rig time offset, lazy ground truth.

use crate::common;

use sim::stream::Measurement;
use sim::{World, WorldConfig};

#[test]
fn stream_is_ordered_and_complete_with_truth_at_frame_times() {
    let mut rig = common::rig(2);
    rig.td_ns = 2_500_000;
    let world = World::new(WorldConfig {
        duration_s: 10.0,
        rig: Some(rig),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut s = world.stream();
    let (mut n_imu, mut n_frames, mut last) = (0, 0, i64::MIN);
    while let Some(m) = s.next() {
        assert!(m.t_ns() >= last);
        last = m.t_ns();
        match m {
            Measurement::Imu(_) => n_imu += 1,
            Measurement::Images(_) => panic!("images in a feature-level stream"),
            Measurement::Gnss(_) | Measurement::Wheel(_) => panic!("no aiding sensor configured"),
            Measurement::Frame(f) => {
                // Stamped td before the capture; truth queried at the capture time.
                assert_eq!((f.t_ns + 2_500_000) % 50_000_000, 0);
                let gt = s.truth(f.t_ns + 2_500_000).unwrap();
                assert!(gt.pose.p.norm().is_finite());
                n_frames += 1;
            }
        }
    }
    assert_eq!((n_imu, n_frames), (2001, 201));
    // Old truth is gone, recent truth stays.
    assert!(s.truth(1_000_000_000).is_none());
    assert!(s.truth(9_000_000_000).is_some());
}

#[test]
fn truth_between_physics_steps_is_continuous() {
    let world = World::new(WorldConfig {
        duration_s: 2.0,
        ..WorldConfig::default()
    })
    .unwrap();
    let mut s = world.stream();
    let a = s.truth(1_000_000_000).unwrap();
    let b = s.truth(1_000_000_001).unwrap();
    let c = s.truth(1_000_500_000).unwrap();
    assert!((a.pose.p - b.pose.p).norm() < 1e-8);
    let dp = (c.pose.p - a.pose.p) / 5e-4;
    assert!((dp - a.v_w).norm() < 1e-2);
}

/// A rate whose period is not a whole number of nanoseconds (30 Hz) keeps its average rate:
/// frame `i` is captured at `i / 30 s` rounded to the nanosecond, so every third frame falls on
/// a whole 100 ms and the periods differ by at most 1 ns.
#[test]
fn a_30_hz_rig_captures_at_rounded_times_of_its_exact_rate() {
    let mut rig = common::rig(2);
    rig.rate_hz = 30.0;
    assert_eq!(rig.capture_ns(1), 33_333_333);
    assert_eq!(rig.capture_ns(2), 66_666_667);
    assert_eq!(rig.capture_ns(300), 10_000_000_000);
    for t in [
        0,
        33_333_332,
        33_333_333,
        66_666_666,
        66_666_667,
        9_999_999_999,
    ] {
        let k = rig.frame_at_or_before(t);
        assert!(
            rig.capture_ns(k) <= t && t < rig.capture_ns(k + 1),
            "t {t}: frame {k}"
        );
    }
    let world = World::new(WorldConfig {
        duration_s: 10.0,
        rig: Some(rig.clone()),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stamps = Vec::new();
    for m in world.stream() {
        if let Measurement::Frame(f) = m {
            stamps.push(f.t_ns);
        }
    }
    assert_eq!(stamps.len(), 301);
    for (i, t) in stamps.iter().enumerate() {
        assert_eq!(*t, rig.capture_ns(i as u64), "frame {i}");
    }
    for w in stamps.windows(2) {
        assert!((33_333_333..=33_333_334).contains(&(w[1] - w[0])));
    }
    // A whole-nanosecond period keeps exact multiples.
    rig.rate_hz = 20.0;
    assert!((0..100_000).all(|i| rig.capture_ns(i) == i as i64 * 50_000_000));
}
