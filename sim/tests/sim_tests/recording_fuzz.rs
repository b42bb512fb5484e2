//! Fuzzing recorded trajectories: irregular stamps (any unit), glitches, gaps, bad quaternions,
//! garbage lines. Property: loading never panics; it either refuses with a message or returns a
//! replay whose reference is finite everywhere on its span.
//!
//! The default suite runs 64 cases (seeded); `-- --ignored` runs 1,000.

use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};
use sim::motion::Reference;
use sim::motion::recording::{RecordingOptions, load_recording};

#[derive(Clone, Debug)]
struct Recipe {
    n: usize,
    /// Spacing of each sample (s, before the unit scale).
    spacing: Vec<f64>,
    /// Unit scale applied to the stamps (1, 1e3, 1e9).
    scale: f64,
    /// (index, position jump m, attitude jump rad) glitches.
    glitches: Vec<(usize, f64, f64)>,
    /// (index, gap length s).
    gaps: Vec<(usize, f64)>,
    /// A line replaced by garbage.
    garbage: Option<usize>,
    repair: bool,
}

fn recipe() -> impl Strategy<Value = Recipe> {
    (4usize..400).prop_flat_map(|n| {
        (
            Just(n),
            prop::collection::vec(
                prop_oneof![8 => 0.004..0.006f64, 1 => 3e-5..0.004f64, 1 => 0.006..0.9f64],
                n,
            ),
            prop::sample::select(vec![1.0, 1e3, 1e9]),
            prop::collection::vec((0..n, 0.0..0.5f64, 0.0..3.2f64), 0..4),
            prop::collection::vec((0..n, 0.05..3.0f64), 0..3),
            prop::option::weighted(0.1, 0..n),
            any::<bool>(),
        )
            .prop_map(
                |(n, spacing, scale, glitches, gaps, garbage, repair)| Recipe {
                    n,
                    spacing,
                    scale,
                    glitches,
                    gaps,
                    garbage,
                    repair,
                },
            )
    })
}

fn text(r: &Recipe) -> String {
    let mut t = 0.0;
    let mut s = String::from("# fuzzed\n");
    for i in 0..r.n {
        t += r.spacing[i] + r.gaps.iter().filter(|g| g.0 == i).map(|g| g.1).sum::<f64>();
        let mut p = Vector3::new((0.7 * t).sin(), (0.4 * t).cos(), 1.0 + 0.1 * t.sin());
        let mut q = UnitQuaternion::from_euler_angles(0.1 * t.sin(), 0.05 * t, 0.3 * t);
        for g in r.glitches.iter().filter(|g| g.0 == i) {
            p.x += g.1;
            q *= UnitQuaternion::from_axis_angle(&Vector3::z_axis(), g.2);
        }
        if r.garbage == Some(i) {
            s.push_str("1.0 nan x y\n");
            continue;
        }
        let c = q.coords;
        s.push_str(&format!(
            "{:.9} {} {} {} {} {} {} {}\n",
            t * r.scale,
            p.x,
            p.y,
            p.z,
            c.x,
            c.y,
            c.z,
            c.w
        ));
    }
    s
}

fn fuzz(cases: u32) -> (usize, usize) {
    use std::cell::Cell;
    let (ok, refused) = (Cell::new(0), Cell::new(0));
    let mut runner = TestRunner::new(Config {
        cases,
        rng_seed: RngSeed::Fixed(11),
        failure_persistence: None,
        ..Config::default()
    });
    runner
        .run(&recipe(), |r| {
            let options = RecordingOptions {
                repair: r.repair,
                ..Default::default()
            };
            match load_recording(&text(&r), &options) {
                Err(e) => {
                    prop_assert!(!e.to_string().is_empty());
                    refused.set(refused.get() + 1);
                }
                Ok((replay, _)) => {
                    let d = replay.duration().unwrap();
                    for k in 0..=100 {
                        let s = replay.state(d * k as f64 / 100.0);
                        prop_assert!(s.p.iter().all(|v| v.is_finite()), "{s:?}");
                        prop_assert!(s.a.iter().all(|v| v.is_finite()), "{s:?}");
                    }
                    ok.set(ok.get() + 1);
                }
            }
            Ok(())
        })
        .unwrap();
    println!(
        "{cases} recordings: {} replayed, {} refused",
        ok.get(),
        refused.get()
    );
    (ok.get(), refused.get())
}

#[test]
fn fuzzed_recordings_never_panic() {
    let (ok, refused) = fuzz(64);
    assert!(ok > 0 && refused > 0, "{ok} {refused}");
}

#[test]
#[ignore = "long fuzz run (1,000 recordings)"]
fn fuzzed_recordings_never_panic_long() {
    fuzz(1000);
}
