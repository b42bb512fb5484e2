//! Shared helpers of the scenario tests: each catalog scenario runs once per test binary
//! through the library's one pipeline (`scenarios::pipeline::run_scenario`), edited catalog
//! scenarios, and scratch folders.

#![allow(dead_code)]

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use scenarios::pipeline::ReportedRun;
use scenarios::report;
use scenarios::run::RunOptions;
use scenarios::spec::Scenario;

/// A finished run of `scenario`: the scenario and the pipeline's [`ReportedRun`] (its context,
/// output, evaluation and report are reached through it: `done.report`).
pub struct Done {
    /// The scenario.
    pub scenario: Scenario,
    /// The run to its report.
    pub run: ReportedRun,
}

impl std::ops::Deref for Done {
    type Target = ReportedRun;
    fn deref(&self) -> &ReportedRun {
        &self.run
    }
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

/// Runs `scenario` with `options` to its report (printing the summary); panics on a run error.
pub fn run_with(scenario: Scenario, options: &RunOptions) -> Done {
    let run =
        scenarios::pipeline::run_scenario(&scenario, options).unwrap_or_else(|e| panic!("{e}"));
    println!("{}", report::summary(&run.report, None));
    Done { scenario, run }
}

/// Runs `scenario` with its own seed for `duration_s` (None: its full length).
pub fn run_scenario(scenario: Scenario, duration_s: Option<f64>) -> Done {
    run_seeded(scenario, None, duration_s)
}

/// [`run_scenario`] with `seed` instead of the scenario's own (None: its own).
pub fn run_seeded(scenario: Scenario, seed: Option<u64>, duration_s: Option<f64>) -> Done {
    let options = RunOptions {
        seed,
        duration_s,
        ..Default::default()
    };
    run_with(scenario, &options)
}

/// Catalog scenario `name` with its text changed by `edit`.
pub fn catalog_edited(name: &str, edit: impl FnOnce(&str) -> String) -> Scenario {
    Scenario::catalog_edited(name, edit).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs catalog scenario `name`, its text changed by `edit`, for `duration_s` (None: its full
/// length).
pub fn run_edited(name: &str, duration_s: Option<f64>, edit: impl FnOnce(&str) -> String) -> Done {
    run_scenario(catalog_edited(name, edit), duration_s)
}

/// A fresh scratch folder, removed when dropped.
pub fn scratch() -> tempfile::TempDir {
    tempfile::tempdir().expect("a scratch folder")
}

/// `done`'s files (`vio run`'s) written into a fresh scratch folder.
pub fn written(done: &Done) -> tempfile::TempDir {
    let dir = scratch();
    done.write_outputs(dir.path())
        .unwrap_or_else(|e| panic!("{e}"));
    dir
}
