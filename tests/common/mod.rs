//! Shared helpers of the scenario tests: run a catalog scenario once per test binary.

#![allow(dead_code)]

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use scenarios::report::{self, Evaluation, Report};
use scenarios::run::{RunOptions, RunOutput, run};
use scenarios::spec::Scenario;

/// A finished run with its evaluation and report.
pub struct Done {
    /// The scenario.
    pub scenario: Scenario,
    /// The run.
    pub output: RunOutput,
    /// Its evaluation.
    pub eval: Evaluation,
    /// Its report.
    pub report: Report,
}

/// Runs catalog scenario `name` for `duration_s` (None: its full length); each (name, duration)
/// runs once per test binary and is shared by the tests that ask for it.
pub fn run_catalog(name: &str, duration_s: Option<f64>) -> Arc<Done> {
    type Cache = Mutex<HashMap<String, Arc<OnceLock<Arc<Done>>>>>;
    static CACHE: OnceLock<Cache> = OnceLock::new();
    let key = format!("{name}@{duration_s:?}");
    let cell = CACHE
        .get_or_init(Default::default)
        .lock()
        .unwrap()
        .entry(key)
        .or_default()
        .clone();
    cell.get_or_init(|| {
        let scenario = Scenario::load(name).unwrap_or_else(|e| panic!("{e}"));
        Arc::new(run_scenario(scenario, duration_s))
    })
    .clone()
}

/// Runs `scenario` with its own seed for `duration_s` (None: its full length), evaluates it and
/// builds its report (printing the summary).
pub fn run_scenario(scenario: Scenario, duration_s: Option<f64>) -> Done {
    run_seeded(scenario, None, duration_s)
}

/// [`run_scenario`] with `seed` instead of the scenario's own (None: its own).
pub fn run_seeded(scenario: Scenario, seed: Option<u64>, duration_s: Option<f64>) -> Done {
    let output = run(
        &scenario,
        &RunOptions {
            seed,
            duration_s,
            ..Default::default()
        },
        &mut |_| {},
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let eval = report::evaluate(&output, scenario.spec.suite);
    let report = report::build_report(&scenario, &output, &eval);
    println!("{}", report::summary(&report, None));
    Done {
        scenario,
        output,
        eval,
        report,
    }
}

/// Runs catalog scenario `name`, its text changed by `edit`, for `duration_s` (None: its full
/// length).
pub fn run_edited(name: &str, duration_s: Option<f64>, edit: impl FnOnce(&str) -> String) -> Done {
    let text = edit(scenarios::catalog::get(name).unwrap().text);
    let scenario = Scenario::parse(name, scenarios::spec::Origin::Catalog, &text).unwrap();
    run_scenario(scenario, duration_s)
}
