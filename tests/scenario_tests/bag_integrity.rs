//! A bag is read with the checks its own readers make: a byte flipped in a chunk is refused
//! naming the chunk (before, it ran to a different estimate and PASS), and zstd- and
//! lz4-compressed chunks, written by the Python `mcap` writer, read to the estimate of the same
//! bag uncompressed (fixtures: `scenarios/tests/fixtures/ros2/README.md`).

use std::path::{Path, PathBuf};

use crate::common;
use scenarios::run::{BagOptions, ReportedRun, RunControl, RunError, RunInput, RunOptions};
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
    scenarios::run::run_to_report(
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
    let poses = |r: &ReportedRun| {
        r.output
            .frames
            .iter()
            .map(|f| (f.estimate.t_ns, f.estimate.T_w_b.p, f.estimate.T_w_b.q))
            .collect::<Vec<_>>()
    };
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
