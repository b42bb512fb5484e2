//! The sweep file: parsed and checked ([`Sweep::load`]), its points (the axes' Cartesian
//! product) and runs (points × seeds), and each run's scenario text.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::point::{Point, point_of};
use super::summary::TargetSpec;
use crate::spec::{Origin, Scenario, SpecError, set_key};

/// The default metrics of a sweep.
pub const DEFAULT_METRICS: &[&str] = &[
    "ate_rmse_m",
    "ate_rot_rmse_deg",
    "rpe_trans_rmse_m",
    "tracking_fraction",
];

/// Most runs (points × seeds) one sweep may hold.
pub const MAX_RUNS: usize = 100_000;

/// The first value in `v` (an axis value, possibly an array) that is not a finite number, as
/// written; strings, booleans and tables are left to the scenario's own checks.
fn non_finite(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some(f.to_string()),
        toml::Value::Array(a) => a.iter().find_map(non_finite),
        _ => None,
    }
}

/// A sweep file as written.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    /// One line saying what the sweep asks.
    pub description: String,
    /// Base scenario: a catalog name or a path relative to the sweep file.
    pub scenario: String,
    /// Simulated duration (s) instead of the scenario's.
    pub duration_s: Option<f64>,
    /// Seeds run at every point.
    pub seeds: Vec<u64>,
    /// Metrics written to `results.csv` and plotted (names as in `[expectations]`).
    pub metrics: Option<Vec<String>>,
    /// The parameter axes.
    pub axes: Vec<AxisSpec>,
    /// The bound the sweep asks about (its summary says which points meet it).
    pub target: Option<TargetSpec>,
}

/// One `[[axes]]` entry.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AxisSpec {
    /// Column name in `results.csv` and the plots' axis label.
    pub name: String,
    /// Dotted scenario keys set together (`rig.cameras[0].pixel_sigma_px`).
    pub keys: Vec<String>,
    /// Per-key factor applied to a number value (default 1).
    pub scale: Option<Vec<f64>>,
    /// The values: numbers (times each key's scale), or arrays with one entry per key.
    pub values: Vec<toml::Value>,
    /// Position of each value on the plot's axis (default: the number value, else its index).
    pub x: Option<Vec<f64>>,
    /// Tick names of the values (default: the values).
    pub labels: Option<Vec<String>>,
    /// What each value costs (any unit, at least 0): the summary's cheapest passing point has
    /// the least sum over the axes.
    pub cost: Option<Vec<f64>>,
}

/// A validated sweep: its base scenario text and origin, the axes, seeds and metrics.
#[derive(Clone, Debug)]
pub struct Sweep {
    /// The file as written.
    pub spec: SweepSpec,
    /// The sweep file (for errors).
    pub file: String,
    /// Name of the base scenario.
    pub scenario_name: String,
    /// Base scenario text.
    pub base_text: String,
    /// Where the base scenario came from (data files resolve against it).
    pub base_origin: Origin,
    /// Metrics written and plotted.
    pub metrics: Vec<String>,
}

impl Sweep {
    /// Reads and validates a sweep file; errors name the file, line and key.
    pub fn load(path: &Path) -> Result<Self, SpecError> {
        let file = path.display().to_string();
        let err = |key: &str, line: Option<usize>, m: String| SpecError {
            file: file.clone(),
            key: key.into(),
            line,
            message: m,
        };
        let text = sim::input_file::read_to_string(path)
            .map_err(|e| err("", None, format!("cannot read the sweep file: {e}")))?;
        let spec: SweepSpec = crate::spec::error::deserialize_toml(&text, &file)?;
        let at = |key: &str, m: String| err(key, crate::spec::error::line_of_key(&text, key), m);
        // The base scenario: a catalog name, else a path relative to the sweep file. On a
        // catalog scenario, a data path a value names that the catalog does not embed is the
        // user's file, beside the sweep file.
        let (scenario_name, base_text, base_origin) = match crate::catalog::get(&spec.scenario) {
            Some(e) => (
                e.name.to_string(),
                e.text.to_string(),
                Origin::CatalogBeside(path.to_path_buf()),
            ),
            None => {
                let p: PathBuf = path.parent().unwrap_or(Path::new(".")).join(&spec.scenario);
                let t = sim::input_file::read_to_string(&p).map_err(|e| {
                    at(
                        "scenario",
                        format!("no catalog scenario of that name, and {}: {e}", p.display()),
                    )
                })?;
                let name = p
                    .file_stem()
                    .map_or("scenario".into(), |s| s.to_string_lossy().into_owned());
                (name, t, Origin::File(p))
            }
        };
        if spec.seeds.is_empty() {
            return Err(at("seeds", "expected at least one seed".into()));
        }
        if let Some(d) = spec.duration_s
            && !(d.is_finite() && d > 0.0 && d <= sim::limits::MAX_DURATION_S)
        {
            return Err(at(
                "duration_s",
                format!("expected seconds in (0, 86400], got {d}"),
            ));
        }
        if spec.axes.is_empty() {
            return Err(at("axes", "expected at least one [[axes]] entry".into()));
        }
        for (i, a) in spec.axes.iter().enumerate() {
            let k = |n: &str| format!("axes[{i}].{n}");
            if let Some(j) = spec.axes[..i].iter().position(|b| b.name == a.name) {
                return Err(at(
                    &k("name"),
                    format!(
                        "`{}` already names axes[{j}]: each axis needs its own name (its column and plot)",
                        a.name
                    ),
                ));
            }
            for (j, v) in a.values.iter().enumerate() {
                if let Some(bad) = non_finite(v) {
                    return Err(at(
                        &k(&format!("values[{j}]")),
                        format!("{bad} is not a finite number"),
                    ));
                }
            }
            for (n, list) in [("scale", a.scale.as_ref()), ("x", a.x.as_ref())] {
                if let Some(j) = list.and_then(|l| l.iter().position(|v| !v.is_finite())) {
                    return Err(at(
                        &k(&format!("{n}[{j}]")),
                        format!("{} is not a finite number", list.unwrap()[j]),
                    ));
                }
            }
            if a.keys.is_empty() || a.values.is_empty() {
                return Err(at(&k("keys"), "expected keys and values".into()));
            }
            if !a
                .name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_')
            {
                return Err(at(&k("name"), "expected letters, digits and `_`".into()));
            }
            if a.scale.as_ref().is_some_and(|s| s.len() != a.keys.len()) {
                return Err(at(&k("scale"), "expected one factor per key".into()));
            }
            for (j, v) in a.values.iter().enumerate() {
                if let toml::Value::Array(arr) = v
                    && arr.len() != a.keys.len()
                {
                    return Err(at(
                        &k(&format!("values[{j}]")),
                        format!("expected {} entries (one per key)", a.keys.len()),
                    ));
                }
            }
            if let Some(j) = a
                .cost
                .as_ref()
                .and_then(|c| c.iter().position(|v| !(v.is_finite() && *v >= 0.0)))
            {
                return Err(at(
                    &k(&format!("cost[{j}]")),
                    format!(
                        "{}: expected a finite cost ≥ 0",
                        a.cost.as_ref().unwrap()[j]
                    ),
                ));
            }
            for (n, len) in [
                ("x", a.x.as_ref().map(Vec::len)),
                ("labels", a.labels.as_ref().map(Vec::len)),
                ("cost", a.cost.as_ref().map(Vec::len)),
            ] {
                if len.is_some_and(|l| l != a.values.len()) {
                    return Err(at(&k(n), "expected one entry per value".into()));
                }
            }
        }
        // Counted without overflow: many axes multiply past 2^64 long before they are refused.
        let runs = spec
            .axes
            .iter()
            .try_fold(spec.seeds.len(), |n, a| n.checked_mul(a.values.len()));
        if runs.is_none_or(|n| n > MAX_RUNS) {
            return Err(at(
                "axes",
                format!(
                    "{} runs (points × seeds), more than the limit of {MAX_RUNS}",
                    runs.map_or("more than 2^64".to_string(), |n| n.to_string())
                ),
            ));
        }
        let metrics = spec
            .metrics
            .clone()
            .unwrap_or_else(|| DEFAULT_METRICS.iter().map(|s| s.to_string()).collect());
        let known = crate::studies::regress::METRICS
            .iter()
            .map(|m| m.0)
            .chain(["recovery_s", "suite_switches"]);
        let known: Vec<&str> = known.collect();
        if let Some(m) = metrics.iter().find(|m| !known.contains(&m.as_str())) {
            return Err(at(
                "metrics",
                format!("unknown metric `{m}` (known: {})", known.join(", ")),
            ));
        }
        if let Some(t) = &spec.target {
            if !metrics.contains(&t.metric) {
                return Err(at(
                    "target.metric",
                    format!(
                        "`{}` is not among the sweep's metrics ({}): add it to `metrics`",
                        t.metric,
                        metrics.join(", ")
                    ),
                ));
            }
            match (t.max, t.min) {
                (Some(v), None) | (None, Some(v)) if v.is_finite() => {}
                (Some(_), Some(_)) | (None, None) => {
                    return Err(at(
                        "target",
                        "expected one bound: `max` (an error metric) or `min`".into(),
                    ));
                }
                (Some(v), None) | (None, Some(v)) => {
                    return Err(at("target", format!("{v} is not a finite bound")));
                }
            }
        }
        let sweep = Self {
            spec,
            file,
            scenario_name,
            base_text,
            base_origin,
            metrics,
        };
        // Every point must make a valid scenario: found now, not after hours of runs.
        for p in sweep.points() {
            sweep.scenario(&p)?;
        }
        Ok(sweep)
    }

    /// Point `index` of the grid (the axes' value indices, the last axis fastest).
    pub fn point(&self, index: usize) -> Point {
        let lens: Vec<usize> = self.spec.axes.iter().map(|a| a.values.len()).collect();
        point_of(index, &lens)
    }

    /// Every point, in index order (the Cartesian product of the axes, the last varying
    /// fastest).
    pub fn points(&self) -> Vec<Point> {
        let mut out = vec![Vec::new()];
        for a in &self.spec.axes {
            out = out
                .into_iter()
                .flat_map(|p| {
                    (0..a.values.len()).map(move |i| {
                        let mut q = p.clone();
                        q.push(i);
                        q
                    })
                })
                .collect();
        }
        out
    }

    /// The number written for `point` on axis `a` (its `x`, its number, or its index).
    pub fn x(&self, a: usize, i: usize) -> f64 {
        let axis = &self.spec.axes[a];
        if let Some(x) = &axis.x {
            return x[i];
        }
        match &axis.values[i] {
            toml::Value::Float(f) => *f,
            toml::Value::Integer(n) => *n as f64,
            _ => i as f64,
        }
    }

    /// The tick label of value `i` of axis `a`.
    pub fn label(&self, a: usize, i: usize) -> String {
        let axis = &self.spec.axes[a];
        match &axis.labels {
            Some(l) => l[i].clone(),
            // A string value (a model's name, a file) is its own label.
            None => match &axis.values[i] {
                toml::Value::String(v) => v.clone(),
                _ => format!("{}", self.x(a, i)),
            },
        }
    }

    /// The base scenario with the point's values set.
    pub fn scenario(&self, point: &[usize]) -> Result<Scenario, SpecError> {
        let text = self.point_text(point)?;
        self.parse_point(point, &text)
    }

    /// The base scenario's text with the point's values set (TOML as the `toml` crate writes
    /// it: the base's comments are not kept).
    pub fn point_text(&self, point: &[usize]) -> Result<String, SpecError> {
        let mut doc: toml::Table =
            self.base_text
                .parse()
                .map_err(|e: toml::de::Error| SpecError {
                    file: self.file.clone(),
                    key: "scenario".into(),
                    line: None,
                    message: format!("the base scenario is not TOML: {e}"),
                })?;
        for (a, &i) in point.iter().enumerate() {
            let axis = &self.spec.axes[a];
            for (k, key) in axis.keys.iter().enumerate() {
                let value = match &axis.values[i] {
                    toml::Value::Array(arr) => arr[k].clone(),
                    // A whole number is a number like its float twin: with a scale it is
                    // scaled (and becomes a float), without one it stays as written.
                    toml::Value::Float(f) => {
                        toml::Value::Float(f * axis.scale.as_ref().map_or(1.0, |s| s[k]))
                    }
                    toml::Value::Integer(n) if axis.scale.is_some() => {
                        toml::Value::Float(*n as f64 * axis.scale.as_ref().map_or(1.0, |s| s[k]))
                    }
                    v => v.clone(),
                };
                set_key(&mut doc, key, value).map_err(|m| SpecError {
                    file: self.file.clone(),
                    key: format!("axes[{a}].keys[{k}]"),
                    line: None,
                    message: format!("`{key}`: {m}"),
                })?;
            }
        }
        toml::to_string(&doc).map_err(|e| SpecError {
            file: self.file.clone(),
            key: String::new(),
            line: None,
            message: e.to_string(),
        })
    }

    /// The point's scenario from its text ([`Sweep::point_text`]).
    pub(super) fn parse_point(&self, point: &[usize], text: &str) -> Result<Scenario, SpecError> {
        // The error names the sweep file (the point's values come from it), the axis that
        // set the refused key, and where the base scenario holds it.
        Scenario::parse(&self.scenario_name, self.base_origin.clone(), text).map_err(|e| {
            let axis = self
                .spec
                .axes
                .iter()
                .find(|a| a.keys.iter().any(|k| e.key.starts_with(k.as_str())))
                .map_or(String::new(), |a| format!("axis `{}` sets it; ", a.name));
            let base = match e.line {
                Some(l) => format!("{}:{l}", e.file),
                None => e.file.clone(),
            };
            SpecError {
                file: self.file.clone(),
                line: None,
                message: format!(
                    "at sweep point {}: {} ({axis}base scenario {base})",
                    self.describe_point(point),
                    e.message,
                ),
                key: e.key,
            }
        })
    }

    /// `name=label, …` of a point.
    pub fn describe_point(&self, point: &[usize]) -> String {
        point
            .iter()
            .enumerate()
            .map(|(a, &i)| format!("{}={}", self.spec.axes[a].name, self.label(a, i)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}
