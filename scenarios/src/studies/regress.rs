//! `vio regress`: a regression catalog for CI. Every scenario of a folder runs with its own
//! seed; each accuracy metric is compared with a stored baseline under a per-metric tolerance;
//! the result is a table, JUnit XML (one testcase per scenario × metric) and an exit code.
//!
//! A metric *regresses* when it is worse than its baseline by more than its tolerance,
//! `max(rel × |baseline|, abs)` (for `tracking_fraction` worse means lower, for the others
//! higher). Better by more than the tolerance is reported as *improved* (update the baseline to
//! lock the gain in) but does not fail. Timings are not compared: they depend on the machine.
//!
//! The baseline is JSON: `{"scenarios": {NAME: {METRIC: {"value": v, "rel": r, "abs": a}}}}`;
//! `--update-baseline` writes it from the current run with the default tolerances of
//! [`METRICS`], keeping tolerances already in the file.
//!
//! A baseline is checked before anything runs ([`check_baseline`]): unknown keys, scenario
//! names the catalog does not hold, metric names that are not compared, negative or non-finite
//! tolerances are refused with the file, line and key; and a baseline that would compare
//! nothing (no scenario of the catalog with a value for a compared metric) is an error, never
//! a green "0 regressed".

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::pipeline::{RunInput, run_to_report};
use crate::report::Report;
use crate::run::{RunControl, RunOptions};
use crate::spec::Scenario;
use std::sync::atomic::{AtomicBool, Ordering};

/// Which way a metric gets worse.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Worse {
    /// Higher is worse (errors, resets).
    Higher,
    /// Lower is worse (tracking).
    Lower,
}

/// The compared metrics with their default tolerances `(name, worse, rel, abs)`: the relative
/// parts cover the few-percent changes a numerically neutral refactor causes, the absolute ones
/// the noise floor of small values (1 mm, 0.02°, …).
pub const METRICS: &[(&str, Worse, f64, f64)] = &[
    ("ate_rmse_m", Worse::Higher, 0.15, 0.001),
    ("ate_rot_rmse_deg", Worse::Higher, 0.15, 0.02),
    ("rpe_trans_rmse_m", Worse::Higher, 0.15, 0.001),
    ("gyro_bias_error_rad_s", Worse::Higher, 0.5, 2e-4),
    ("accel_bias_error_m_s2", Worse::Higher, 0.5, 0.01),
    ("tracking_fraction", Worse::Lower, 0.0, 0.02),
    ("resets", Worse::Higher, 0.0, 0.0),
];

/// One stored metric.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stored {
    /// Its value (`null`: could not be computed).
    pub value: Option<f64>,
    /// Relative tolerance.
    pub rel: f64,
    /// Absolute tolerance.
    pub abs: f64,
}

/// The baseline file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Baseline {
    /// Scenario → metric → stored value.
    pub scenarios: BTreeMap<String, BTreeMap<String, Stored>>,
}

/// The outcome of one comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Within tolerance.
    Pass,
    /// Worse than the baseline beyond the tolerance.
    Regressed,
    /// Better than the baseline beyond the tolerance.
    Improved,
    /// No baseline for it (new scenario or metric): not a failure.
    New,
    /// The baseline had a value, the run has none (e.g. no ATE any more).
    Missing,
}

/// One scenario × metric comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct Check {
    /// Scenario name.
    pub scenario: String,
    /// The outside estimator that ran it (`None`: ours).
    pub estimator: Option<String>,
    /// Metric name.
    pub metric: &'static str,
    /// This run's value.
    pub value: Option<f64>,
    /// The baseline's value.
    pub baseline: Option<f64>,
    /// The allowed difference.
    pub tolerance: f64,
    /// The outcome.
    pub verdict: Verdict,
}

impl Check {
    /// Whether this check fails the run.
    pub fn failed(&self) -> bool {
        matches!(self.verdict, Verdict::Regressed | Verdict::Missing)
    }

    /// What happened, in words (the JUnit failure text).
    pub fn describe(&self) -> String {
        let f = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.6}"));
        format!(
            "{} {}: value {}, baseline {}, tolerance {:.6}: {}",
            self.scenario,
            self.metric,
            f(self.value),
            f(self.baseline),
            self.tolerance,
            match self.verdict {
                Verdict::Pass => "pass",
                Verdict::Regressed => "REGRESSED",
                Verdict::Improved => "improved (update the baseline)",
                Verdict::New => "new (no baseline)",
                Verdict::Missing => "MISSING (the baseline has a value)",
            }
        )
    }
}

/// Compares one scenario's report with the baseline.
pub fn compare(name: &str, report: &Report, baseline: &Baseline) -> Vec<Check> {
    let mut checks = compare_values(name, &|m| report.metric(m), baseline);
    for c in &mut checks {
        c.estimator = report.estimator.as_ref().map(|o| o.name.clone());
    }
    checks
}

/// Compares the metrics `value_of` gives with the baseline of scenario `name`.
pub fn compare_values(
    name: &str,
    value_of: &dyn Fn(&str) -> Option<f64>,
    baseline: &Baseline,
) -> Vec<Check> {
    let stored = baseline.scenarios.get(name);
    METRICS
        .iter()
        .map(|&(metric, worse, rel, abs)| {
            let value = value_of(metric).filter(|v| v.is_finite());
            let s = stored.and_then(|m| m.get(metric));
            let (rel, abs) = s.map_or((rel, abs), |s| (s.rel, s.abs));
            let base = s.and_then(|s| s.value);
            let tolerance = base.map_or(abs, |b| (rel * b.abs()).max(abs));
            let verdict = match (value, base, s.is_some()) {
                (_, _, false) => Verdict::New,
                (None, Some(_), _) => Verdict::Missing,
                (_, None, _) => Verdict::Pass,
                (Some(v), Some(b), _) => {
                    let excess = match worse {
                        Worse::Higher => v - b,
                        Worse::Lower => b - v,
                    };
                    if excess > tolerance {
                        Verdict::Regressed
                    } else if -excess > tolerance && tolerance > 0.0 {
                        Verdict::Improved
                    } else {
                        Verdict::Pass
                    }
                }
            };
            Check {
                scenario: name.to_string(),
                estimator: None,
                metric,
                value,
                baseline: base,
                tolerance,
                verdict,
            }
        })
        .collect()
}

/// The baseline for `reports`, keeping the tolerances `old` already holds.
pub fn updated_baseline(reports: &[(String, Report)], old: &Baseline) -> Baseline {
    let mut b = Baseline::default();
    for (name, r) in reports {
        let entry = b.scenarios.entry(name.clone()).or_default();
        for &(metric, _, rel, abs) in METRICS {
            let kept = old.scenarios.get(name).and_then(|m| m.get(metric));
            entry.insert(
                metric.to_string(),
                Stored {
                    value: r.metric(metric).filter(|v| v.is_finite()),
                    rel: kept.map_or(rel, |k| k.rel),
                    abs: kept.map_or(abs, |k| k.abs),
                },
            );
        }
    }
    b
}

/// The table `vio regress` prints.
pub fn table(checks: &[Check]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<38} {:<24} {:>12} {:>12} {:>10}  verdict",
        "scenario", "metric", "value", "baseline", "tolerance"
    );
    let f = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.6}"));
    for c in checks {
        let _ = writeln!(
            s,
            "{:<38} {:<24} {:>12} {:>12} {:>10.6}  {}",
            c.scenario,
            c.metric,
            f(c.value),
            f(c.baseline),
            c.tolerance,
            match c.verdict {
                Verdict::Pass => "pass",
                Verdict::Regressed => "REGRESSED",
                Verdict::Improved => "improved",
                Verdict::New => "new",
                Verdict::Missing => "MISSING",
            }
        );
    }
    let failed = checks.iter().filter(|c| c.failed()).count();
    let _ = writeln!(s, "{}", crate::report::ALIGNMENT_RULE);
    let _ = writeln!(
        s,
        "{} checks, {} regressed, {} improved, {} new",
        checks.len(),
        failed,
        checks
            .iter()
            .filter(|c| c.verdict == Verdict::Improved)
            .count(),
        checks.iter().filter(|c| c.verdict == Verdict::New).count()
    );
    s
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// JUnit XML: one testcase per scenario × metric, a `<failure>` naming value, baseline and
/// tolerance for each regression.
pub fn junit(checks: &[Check]) -> String {
    let failures = checks.iter().filter(|c| c.failed()).count();
    let mut s = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites>\n  <testsuite name=\"vio regress\" tests=\"{}\" failures=\"{failures}\">\n",
        checks.len()
    );
    for c in checks {
        let _ = write!(
            s,
            "    <testcase classname=\"{}\" name=\"{}\"",
            // An outside estimator's cases are its own: `ESTIMATOR.SCENARIO`.
            xml_escape(&match &c.estimator {
                Some(e) => format!("{e}.{}", c.scenario),
                None => c.scenario.clone(),
            }),
            c.metric
        );
        if c.failed() {
            let _ = write!(
                s,
                ">\n      <failure message=\"{}\"/>\n    </testcase>\n",
                xml_escape(&c.describe())
            );
        } else {
            s.push_str("/>\n");
        }
    }
    s.push_str("  </testsuite>\n</testsuites>\n");
    s
}

/// The scenario files of a regression catalog folder, in name order.
pub fn catalog_files(dir: &Path) -> Result<Vec<PathBuf>, String> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| format!("--catalog {}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(format!(
            "--catalog {}: no scenario files (*.toml)",
            dir.display()
        ));
    }
    Ok(files)
}

/// Reads a baseline file with its text (`None`: none there yet); syntax and schema errors
/// name the file and line.
pub fn read_baseline(path: &Path) -> Result<Option<(Baseline, String)>, String> {
    match sim::input_file::read_to_string(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(format!("--baseline {}: {e}", path.display())),
        Ok(text) => serde_json::from_str(&text)
            .map(|b| Some((b, text)))
            .map_err(|e| format!("--baseline {}:{}: {e}", path.display(), e.line())),
    }
}

/// The 1-based line of the JSON key path `keys` in `text` (each key searched after the one
/// before it), when found.
fn json_line(text: &str, keys: &[&str]) -> Option<usize> {
    let mut at = 0;
    for k in keys {
        at += text[at..].find(&format!("\"{k}\""))?;
    }
    Some(text[..at].matches('\n').count() + 1)
}

/// The scenario names of a catalog's files (their stems, as `vio regress` names them).
pub fn catalog_names(files: &[PathBuf]) -> Vec<String> {
    files
        .iter()
        .filter_map(|f| f.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect()
}

/// Checks a baseline read from `text` (the file `path`) against the catalog's scenario names:
/// see the module documentation. The error names the file, the line and the key.
pub fn check_baseline(
    baseline: &Baseline,
    text: &str,
    path: &Path,
    catalog: &[String],
) -> Result<(), String> {
    let err = |keys: &[&str], msg: String| {
        let line = json_line(text, keys).map_or(String::new(), |l| format!(":{l}"));
        let key = std::iter::once("scenarios")
            .chain(keys.iter().copied())
            .collect::<Vec<_>>()
            .join(".");
        Err(format!(
            "--baseline {}{line}: key `{key}`: {msg}",
            path.display()
        ))
    };
    let metric_names: Vec<&str> = METRICS.iter().map(|m| m.0).collect();
    let mut compared = 0;
    for (name, metrics) in &baseline.scenarios {
        if !catalog.contains(name) {
            return err(
                &[name],
                format!(
                    "no scenario of that name in the catalog: {}",
                    crate::catalog::closest_hint(name, catalog)
                ),
            );
        }
        for (metric, stored) in metrics {
            if !metric_names.contains(&metric.as_str()) {
                return err(
                    &[name, metric],
                    format!(
                        "not a compared metric (metrics: {})",
                        metric_names.join(", ")
                    ),
                );
            }
            for (field, v) in [("rel", stored.rel), ("abs", stored.abs)] {
                if !(v.is_finite() && v >= 0.0) {
                    return err(
                        &[name, metric, field],
                        format!("a tolerance must be finite and ≥ 0, got {v}"),
                    );
                }
            }
            if stored.value.is_some() {
                compared += 1;
            }
        }
    }
    if compared == 0 {
        return Err(format!(
            "--baseline {}: compares nothing: no scenario of the catalog has a stored value (rewrite it with --update-baseline)",
            path.display()
        ));
    }
    Ok(())
}

/// Runs every scenario file with `settings` set (`--estimator`: `estimator_adapter`); `(name,
/// report)` in order, or the first error. Once `stop` is set (Ctrl-C) no scenario starts and
/// the one under way stops and is dropped: the list ends with the last scenario that finished.
pub fn run_catalog(
    files: &[PathBuf],
    settings: &[(String, toml::Value)],
    progress: &mut dyn FnMut(&str),
    stop: Option<&AtomicBool>,
) -> Result<Vec<(String, Report)>, String> {
    let mut out = Vec::new();
    for f in files {
        if stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
            break;
        }
        let path = f.to_string_lossy().into_owned();
        let scenario = Scenario::load_with_settings(&path, settings).map_err(|e| e.to_string())?;
        progress(&scenario.name);
        let control = RunControl {
            progress: None,
            stop,
            workspace: None,
        };
        let run = run_to_report(
            RunInput::Scenario(&scenario),
            &RunOptions::default(),
            control,
        )
        .map_err(|e| e.to_string())?;
        if run.report.interrupted_at_s.is_some() {
            break;
        }
        out.push((scenario.name.clone(), run.report));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The verdicts on `ate_rmse_m` (baseline 1 cm, 15 %, 1 mm) and `tracking_fraction`
    /// (baseline 0.95, 0.02 absolute) for the given values.
    fn verdicts(ate: f64, tracking: f64) -> (Verdict, Verdict) {
        let mut b = Baseline::default();
        let m = b.scenarios.entry("s".into()).or_default();
        m.insert(
            "ate_rmse_m".into(),
            Stored {
                value: Some(0.010),
                rel: 0.15,
                abs: 0.001,
            },
        );
        m.insert(
            "tracking_fraction".into(),
            Stored {
                value: Some(0.95),
                rel: 0.0,
                abs: 0.02,
            },
        );
        let checks = compare_values(
            "s",
            &|metric| match metric {
                "ate_rmse_m" => Some(ate),
                "tracking_fraction" => Some(tracking),
                _ => None,
            },
            &b,
        );
        let v = |name: &str| checks.iter().find(|c| c.metric == name).unwrap().verdict;
        // Metrics without a baseline entry are new, never failures.
        assert_eq!(v("resets"), Verdict::New);
        (v("ate_rmse_m"), v("tracking_fraction"))
    }

    #[test]
    fn tolerances_are_relative_with_an_absolute_floor_and_know_which_way_is_worse() {
        // 15 % of 1 cm is 1.5 mm, above the 1 mm floor.
        assert_eq!(verdicts(0.0114, 0.95).0, Verdict::Pass);
        assert_eq!(verdicts(0.0116, 0.95).0, Verdict::Regressed);
        assert_eq!(verdicts(0.0084, 0.95).0, Verdict::Improved);
        // Tracking regresses downwards.
        assert_eq!(verdicts(0.01, 0.92).1, Verdict::Regressed);
        assert_eq!(verdicts(0.01, 0.94).1, Verdict::Pass);
        assert_eq!(verdicts(0.01, 0.98).1, Verdict::Improved);
        // A value that disappears fails.
        assert_eq!(verdicts(f64::NAN, 0.95).0, Verdict::Missing);
    }

    #[test]
    fn baselines_that_compare_nothing_or_name_unknown_things_are_refused() {
        let path = Path::new("b.json");
        let catalog = vec!["a".to_string(), "b".to_string()];
        let check = |text: &str| {
            let b: Baseline = serde_json::from_str(text).map_err(|e| e.to_string())?;
            check_baseline(&b, text, path, &catalog)
        };
        let good = "{\"scenarios\": {\"a\": {\"ate_rmse_m\": {\"value\": 0.01, \"rel\": 0.1, \"abs\": 0.001}}}}";
        assert_eq!(check(good), Ok(()));
        for (text, expect) in [
            ("{\"scenarios\": {}}", "compares nothing"),
            (
                "{\"scenarios\": {\"a\": {\"ate_rmse_m\": {\"value\": null, \"rel\": 0.1, \"abs\": 0.0}}}}",
                "compares nothing",
            ),
            (
                "{\"scenarios\": {\n\"zz\": {\"ate_rmse_m\": {\"value\": 1.0, \"rel\": 0.1, \"abs\": 0.0}}}}",
                "b.json:2: key `scenarios.zz`: no scenario",
            ),
            (
                "{\"scenarios\": {\"a\": {\n\n\"ate_rmse\": {\"value\": 1.0, \"rel\": 0.1, \"abs\": 0.0}}}}",
                "b.json:3: key `scenarios.a.ate_rmse`: not a compared metric",
            ),
            (
                "{\"scenarios\": {\"a\": {\"ate_rmse_m\": {\"value\": 1.0, \"rel\": -0.1, \"abs\": 0.0}}}}",
                "key `scenarios.a.ate_rmse_m.rel`: a tolerance must be finite and ≥ 0, got -0.1",
            ),
            (
                "{\"scenarios\": {\"a\": {\"ate_rmse_m\": {\"vlaue\": 1.0, \"rel\": 0.1, \"abs\": 0.0}}}}",
                "unknown field `vlaue`",
            ),
        ] {
            let e = check(text).expect_err(text);
            assert!(e.contains(expect), "{text}: {e}");
        }
    }

    #[test]
    fn junit_escapes_and_counts_failures() {
        let c = Check {
            estimator: None,
            scenario: "a<b>".into(),
            metric: "ate_rmse_m",
            value: Some(2.0),
            baseline: Some(1.0),
            tolerance: 0.1,
            verdict: Verdict::Regressed,
        };
        let x = junit(&[
            c.clone(),
            Check {
                verdict: Verdict::Pass,
                ..c
            },
        ]);
        assert!(x.contains("tests=\"2\" failures=\"1\""), "{x}");
        assert!(x.contains("classname=\"a&lt;b&gt;\""), "{x}");
        assert!(
            x.contains("value 2.000000, baseline 1.000000, tolerance 0.100000"),
            "{x}"
        );
    }
}
