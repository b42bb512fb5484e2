//! A bag is read with the checks its own readers make: a byte flipped in a chunk is refused
//! naming the chunk (before, it ran to a different estimate and PASS), zstd- and
//! lz4-compressed chunks, written by the Python `mcap` writer, read to the estimate of the same
//! bag uncompressed (fixtures: `scenarios/tests/fixtures/ros2/README.md`), and a fuzzer: a
//! mutated bag is refused naming the file or read to the unmutated bag's estimate, never to
//! another, never a panic.

use std::path::{Path, PathBuf};

use crate::common;
use scenarios::pipeline::{ReportedRun, RunInput};
use scenarios::run::{BagOptions, RunControl, RunError, RunOptions};
use scenarios::spec::SuiteSpec;

fn fixture(compression: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenarios/tests/fixtures/ros2")
        .join(format!("ros2_features_1s_{compression}.mcap"))
}

fn run(path: &Path) -> Result<ReportedRun, RunError> {
    let options = BagOptions {
        features_topic: Some("/features".into()),
        ..BagOptions::new(SuiteSpec::StereoImu)
    };
    let run = RunOptions {
        seed: Some(1),
        ..Default::default()
    };
    scenarios::pipeline::run_to_report(
        RunInput::Bag {
            path,
            options: &options,
        },
        &run,
        RunControl::default(),
    )
}

/// `(offset, length)` of the first chunk record (opcode 0x06) at the top level of an MCAP file.
fn first_chunk(bytes: &[u8]) -> (usize, usize) {
    let mut at = 8;
    loop {
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
        if bytes[at] == 0x06 {
            return (at, 9 + len);
        }
        at += 9 + len;
    }
}

#[test]
fn zstd_and_lz4_bags_from_the_python_writer_give_the_uncompressed_bags_estimate() {
    let plain = run(&fixture("none")).unwrap_or_else(|e| panic!("{e}"));
    // 1 s of the figure-eight: 21 frames, tracking from the ninth (measured: 12 tracked).
    assert_eq!(plain.output.frames.len(), 21);
    assert!(
        plain.report.tracking_frames >= 10,
        "{}",
        plain.report.tracking_frames
    );
    for compression in ["zstd", "lz4"] {
        let got = run(&fixture(compression)).unwrap_or_else(|e| panic!("{compression}: {e}"));
        assert_eq!(poses(&got), poses(&plain), "{compression}");
    }
}

#[test]
fn a_bag_with_a_flipped_byte_in_a_chunk_is_refused_naming_the_chunk() {
    let dir = common::scratch();
    for compression in ["none", "zstd", "lz4"] {
        let mut bytes = std::fs::read(fixture(compression)).unwrap();
        let (offset, len) = first_chunk(&bytes);
        bytes[offset + len / 2] ^= 0x10;
        let path = dir.path().join(format!("flipped_{compression}.mcap"));
        std::fs::write(&path, &bytes).unwrap();
        let e = run(&path)
            .err()
            .unwrap_or_else(|| panic!("{compression}: read as good"));
        let message = e.to_string();
        assert!(
            message.contains(&format!("chunk 0 (bytes {offset}..{})", offset + len)),
            "{compression}: {message}"
        );
        assert!(message.contains("flipped_"), "names the file: {message}");
    }
}

/// The estimate of a run: each frame's stamp, position and orientation (x, y, z, w).
type Poses = Vec<(i64, [f64; 3], [f64; 4])>;

fn poses(r: &ReportedRun) -> Poses {
    r.output
        .frames
        .iter()
        .map(|f| {
            let (p, q) = (f.estimate.T_w_b.p, f.estimate.T_w_b.q.coords);
            (f.estimate.t_ns, [p.x, p.y, p.z], [q.x, q.y, q.z, q.w])
        })
        .collect()
}

/// Mutates the bag at `path` `cases` ways (seeded xorshift: 1–20 bytes overwritten, the
/// file cut anywhere, a 4-byte field made huge) and runs each. Property: refused naming the
/// file, or read to the unmutated bag's estimate (a byte nothing reads); never a different
/// estimate, never a panic. Returns (refused, read unchanged).
fn fuzz_bags(path: &Path, cases: usize) -> (usize, usize) {
    let base = std::fs::read(path).unwrap();
    let expected = poses(&run(path).unwrap());
    let dir = common::scratch();
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = |n: usize| {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as usize % n.max(1)
    };
    let (mut refused, mut unchanged) = (0, 0);
    for case in 0..cases {
        let mut b = base.clone();
        match case % 3 {
            0 => {
                for _ in 0..1 + next(20) {
                    let at = next(b.len());
                    b[at] = next(256) as u8;
                }
            }
            1 => b.truncate(next(b.len())),
            _ => {
                let at = next(b.len() - 8);
                b[at..at + 4].copy_from_slice(&[0xff, 0xff, 0xff, 0x7f]);
            }
        }
        if b == base {
            continue;
        }
        let m = dir.path().join("m.mcap");
        std::fs::write(&m, &b).unwrap();
        match run(&m) {
            Ok(r) => {
                assert_eq!(
                    poses(&r),
                    expected,
                    "case {case}: a mutated bag read to another estimate"
                );
                unchanged += 1;
            }
            Err(e) => {
                assert!(e.to_string().contains("m.mcap"), "case {case}: {e}");
                refused += 1;
            }
        }
    }
    (refused, unchanged)
}

/// The bags fuzzed: the Python writer's (the fixture) and ours (`vio export --format mcap` of
/// the default scenario, 1 s).
fn fuzzed_bags(dir: &Path) -> [PathBuf; 2] {
    let scenario = scenarios::spec::Scenario::load("room_figure8_stereo_imu").unwrap();
    let ours = dir.join("ours.mcap");
    let options = RunOptions {
        duration_s: Some(1.0),
        ..Default::default()
    };
    scenarios::export::export_bag(&scenario, &options, &ours).unwrap();
    [fixture("none"), ours]
}

#[test]
fn mutated_bags_are_refused_or_read_unchanged_never_another_estimate() {
    let dir = common::scratch();
    for bag in fuzzed_bags(dir.path()) {
        let (refused, unchanged) = fuzz_bags(&bag, 60);
        assert!(
            refused >= 50,
            "{}: {refused} refused, {unchanged} read unchanged",
            bag.display()
        );
    }
}

#[test]
#[ignore = "long fuzz run (1,000 mutations of each of two bags)"]
fn mutated_bags_are_refused_or_read_unchanged_never_another_estimate_long() {
    let dir = common::scratch();
    for bag in fuzzed_bags(dir.path()) {
        let (refused, unchanged) = fuzz_bags(&bag, 1000);
        eprintln!(
            "{}: 1000 mutations, {refused} refused, {unchanged} read to the unmutated estimate",
            bag.display()
        );
    }
}
