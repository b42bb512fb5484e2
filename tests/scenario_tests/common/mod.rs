//! Shared helpers of the scenario tests: each catalog scenario runs once per test binary
//! through the library's one pipeline (`scenarios::run::run_scenario`), edited catalog
//! scenarios, and scratch folders.

#![allow(dead_code)]

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

use scenarios::report::{self, Evaluation, Report, RunContext};
use scenarios::run::{ReportedRun, RunOptions, RunOutput};
use scenarios::spec::Scenario;

/// A finished run of `scenario`: the pipeline's [`ReportedRun`], its parts at hand.
pub struct Done {
    /// The scenario.
    pub scenario: Scenario,
    /// What the report knows of the scenario.
    pub context: RunContext,
    /// The run.
    pub output: RunOutput,
    /// Its evaluation.
    pub eval: Evaluation,
    /// Its report.
    pub report: Report,
}

impl Done {
    /// Writes the run's files (`vio run`'s) into `dir`.
    pub fn write_outputs(&self, dir: &Path) -> Result<(), String> {
        report::write_outputs(dir, &self.context, &self.output, &self.eval, &self.report)
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
    let ReportedRun {
        context,
        output,
        evaluation,
        report,
        ..
    } = scenarios::run::run_scenario(&scenario, options).unwrap_or_else(|e| panic!("{e}"));
    println!("{}", report::summary(&report, None));
    Done {
        scenario,
        context,
        output,
        eval: evaluation,
        report,
    }
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
