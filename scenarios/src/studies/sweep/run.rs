//! Running a sweep's runs (all, or one shard) on worker threads, and the files they produce:
//! `results.csv` (one row per run, in run order) and `sweep.json` (the sweep's definition and
//! size, identical for every shard, so merged shards equal one process's output).

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use serde::Serialize;

use super::Sweep;
use crate::pipeline::{ReportedRun, RunInput, run_to_report};
use crate::run::{RunControl, RunOptions};

/// A slice of the runs: those whose index is `index` modulo `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard (0-based).
    pub index: usize,
    /// Number of shards.
    pub count: usize,
}

impl Shard {
    /// Every run.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Parses `i/n` with `0 ≤ i < n`.
    pub fn parse(s: &str) -> Result<Self, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("--shard {s}: expected i/n"))?;
        let parse = |v: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("--shard {s}: expected whole numbers i/n"))
        };
        let (index, count) = (parse(i)?, parse(n)?);
        if count == 0 || index >= count {
            return Err(format!("--shard {s}: expected 0 ≤ i < n"));
        }
        Ok(Self { index, count })
    }

    /// Whether run `r` belongs to this shard.
    pub fn has(self, r: usize) -> bool {
        r % self.count == self.index
    }
}

/// How a caller steers [`Sweep::run`].
pub struct SweepControl<'a> {
    /// Runs already done (kept from an interrupted sweep): not run again.
    pub done: BTreeSet<usize>,
    /// Once set (Ctrl-C), no run starts and the runs under way stop.
    pub stop: Option<&'a AtomicBool>,
    /// Called with each finished row as it finishes (to keep it); an error fails that run.
    pub keep: &'a (dyn Fn(&RunRow) -> Result<(), String> + Sync),
    /// Called with (runs finished, runs to do).
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// With `--keep-runs`: each finished run's files (those of `vio run --out`, and the
    /// point's `scenario.toml`) are kept in `runs_dir/run-<index>/`, written whole or not at
    /// all.
    pub runs_dir: Option<&'a Path>,
}

/// The folder `--keep-runs` keeps run `run` in, under the sweep's output folder.
pub fn run_dir(runs_dir: &Path, run: usize) -> PathBuf {
    runs_dir.join(format!("run-{run}"))
}

/// The folder under `--out` that holds the kept runs.
pub const RUNS_DIR: &str = "runs";

/// One finished run: its index, point, seed and metric values.
#[derive(Clone, Debug, PartialEq)]
pub struct RunRow {
    /// Run index (point-major, then seed).
    pub run: usize,
    /// Point index.
    pub point: usize,
    /// Seed.
    pub seed: u64,
    /// The sweep's metrics, in its order (`None`: not computable).
    pub values: Vec<Option<f64>>,
}

/// `sweep.json`: the definition and size of the sweep (nothing shard- or machine-specific).
#[derive(Clone, Debug, Serialize)]
pub struct SweepJson {
    /// The sweep's description.
    pub description: String,
    /// Base scenario name.
    pub scenario: String,
    /// Duration override (s).
    pub duration_s: Option<f64>,
    /// Seeds.
    pub seeds: Vec<u64>,
    /// Metrics.
    pub metrics: Vec<String>,
    /// Axes: name, keys, x positions and labels of the values.
    pub axes: Vec<AxisJson>,
    /// Number of points.
    pub points: usize,
    /// Number of runs (points × seeds).
    pub runs: usize,
    /// The bound asked about (absent without one).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub target: Option<super::summary::TargetSpec>,
}

/// One axis in `sweep.json`.
#[derive(Clone, Debug, Serialize)]
pub struct AxisJson {
    /// Name.
    pub name: String,
    /// Keys set together.
    pub keys: Vec<String>,
    /// Plot positions of the values.
    pub x: Vec<f64>,
    /// Labels of the values.
    pub labels: Vec<String>,
    /// Costs of the values (absent without them).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cost: Option<Vec<f64>>,
}

impl Sweep {
    /// `sweep.json`'s content.
    pub fn json(&self) -> SweepJson {
        let points = self.points().len();
        SweepJson {
            description: self.spec.description.clone(),
            scenario: self.scenario_name.clone(),
            duration_s: self.spec.duration_s,
            seeds: self.spec.seeds.clone(),
            metrics: self.metrics.clone(),
            axes: self
                .spec
                .axes
                .iter()
                .enumerate()
                .map(|(a, axis)| AxisJson {
                    name: axis.name.clone(),
                    keys: axis.keys.clone(),
                    x: (0..axis.values.len()).map(|i| self.x(a, i)).collect(),
                    labels: (0..axis.values.len()).map(|i| self.label(a, i)).collect(),
                    cost: axis.cost.clone(),
                })
                .collect(),
            points,
            runs: points * self.spec.seeds.len(),
            target: self.spec.target.clone(),
        }
    }

    /// Runs the shard's runs on `jobs` threads, but not those in `control.done`; rows of the
    /// runs that finished, in run order (the result does not depend on `jobs`). Each finished
    /// row is handed to `control.keep` at once; `control.progress` is told each finished run.
    /// Once `control.stop` is set no run starts, and the runs under way stop and are dropped
    /// (a shortened run's metrics are not the run's).
    pub fn run(
        &self,
        shard: Shard,
        jobs: usize,
        control: &SweepControl<'_>,
    ) -> Result<Vec<RunRow>, String> {
        let points = self.points();
        let seeds = &self.spec.seeds;
        let todo: Vec<usize> = (0..points.len() * seeds.len())
            .filter(|&r| shard.has(r) && !control.done.contains(&r))
            .collect();
        let results: Mutex<Vec<Option<Result<RunRow, String>>>> =
            Mutex::new(vec![None; todo.len()]);
        let next = AtomicUsize::new(0);
        let finished = AtomicUsize::new(0);
        let stopped = || control.stop.is_some_and(|s| s.load(Ordering::Relaxed));
        std::thread::scope(|s| {
            for _ in 0..jobs.clamp(1, todo.len().max(1)) {
                s.spawn(|| {
                    loop {
                        let k = next.fetch_add(1, Ordering::Relaxed);
                        if k >= todo.len() || stopped() {
                            break;
                        }
                        let r = todo[k];
                        let (p, si) = (r / seeds.len(), r % seeds.len());
                        let row = match self.run_one((r, p), &points[p], seeds[si], control) {
                            Ok(None) => break,
                            Ok(Some(values)) => {
                                let row = RunRow {
                                    run: r,
                                    point: p,
                                    seed: seeds[si],
                                    values,
                                };
                                (control.keep)(&row).map(|()| row)
                            }
                            Err(e) => Err(e),
                        };
                        results.lock().expect("no worker panicked")[k] = Some(row);
                        (control.progress)(
                            finished.fetch_add(1, Ordering::Relaxed) + 1,
                            todo.len(),
                        );
                    }
                });
            }
        });
        results
            .into_inner()
            .expect("no worker panicked")
            .into_iter()
            .flatten()
            .collect()
    }

    /// One run's metric values (the run and point indices, the point, the seed); `None` when
    /// `control.stop` ended it early.
    fn run_one(
        &self,
        (run_index, point_index): (usize, usize),
        point: &[usize],
        seed: u64,
        control: &SweepControl<'_>,
    ) -> Result<Option<Vec<Option<f64>>>, String> {
        let text = self.point_text(point).map_err(|e| e.to_string())?;
        let scenario = self.parse_point(point, &text).map_err(|e| e.to_string())?;
        let options = RunOptions {
            seed: Some(seed),
            duration_s: self.spec.duration_s,
            ..Default::default()
        };
        // An outside estimator's files stay with the kept run (else in a temporary folder).
        let workspace = control
            .runs_dir
            .map(|dir| run_dir(dir, run_index).join("estimator"));
        let run_control = RunControl {
            progress: None,
            stop: control.stop,
            workspace: workspace.as_deref(),
        };
        let failed =
            |e: &dyn std::fmt::Display| format!("{} seed {seed}: {e}", self.describe_point(point));
        let run = run_to_report(RunInput::Scenario(&scenario), &options, run_control)
            .map_err(|e| failed(&e))?;
        if run.report.interrupted_at_s.is_some() {
            return Ok(None);
        }
        if let Some(dir) = control.runs_dir {
            let duration = self
                .spec
                .duration_s
                .map_or(String::new(), |d| format!(" --duration {d}"));
            let header = format!(
                "# Sweep \"{}\", point {point_index} ({}), seed {seed}: \
                 `vio run scenario.toml --seed {seed}{duration}` runs it again.\n",
                self.spec.description,
                self.describe_point(point),
            );
            keep_run_dir(&run_dir(dir, run_index), &(header + &text), &run)
                .map_err(|e| failed(&e))?;
        }
        Ok(Some(
            self.metrics
                .iter()
                .map(|m| run.report.metric(m).filter(|v| v.is_finite()))
                .collect(),
        ))
    }

    /// `results.csv`: a header, then one row per run in run order. Numbers are written in
    /// their shortest exact form; an empty cell is a metric that could not be computed.
    pub fn csv(&self, rows: &[RunRow]) -> String {
        let mut s = self.csv_header();
        s.push('\n');
        for row in rows {
            s.push_str(&self.csv_row(row));
            s.push('\n');
        }
        s
    }

    /// `results.csv`'s header.
    pub fn csv_header(&self) -> String {
        let mut s = String::from("run,point,seed");
        for a in &self.spec.axes {
            let _ = write!(s, ",{}", a.name);
        }
        for m in &self.metrics {
            let _ = write!(s, ",{m}");
        }
        s
    }

    /// One row of `results.csv` (without its line end): run, point, seed, the point's axis
    /// values, the metrics.
    pub fn csv_row(&self, row: &RunRow) -> String {
        let mut s = format!("{},{},{}", row.run, row.point, row.seed);
        for (a, &i) in self.point(row.point).iter().enumerate() {
            let _ = write!(s, ",{}", self.x(a, i));
        }
        for v in &row.values {
            match v {
                Some(v) => {
                    let _ = write!(s, ",{v}");
                }
                None => s.push(','),
            }
        }
        s
    }
}

/// Writes a run's files and its scenario into `dir`, whole: into a sibling folder first,
/// renamed into place once complete (a run kept before, by an interrupted sweep, is replaced).
fn keep_run_dir(dir: &Path, scenario_text: &str, run: &ReportedRun) -> Result<(), String> {
    let name = dir
        .file_name()
        .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let tmp = dir.with_file_name(format!(".{name}.partial"));
    let io = |p: &Path, e: std::io::Error| format!("{}: {e}", p.display());
    if tmp.exists() {
        std::fs::remove_dir_all(&tmp).map_err(|e| io(&tmp, e))?;
    }
    std::fs::create_dir_all(&tmp).map_err(|e| io(&tmp, e))?;
    std::fs::write(tmp.join("scenario.toml"), scenario_text).map_err(|e| io(&tmp, e))?;
    run.write_outputs(&tmp)?;
    if dir.exists() {
        std::fs::remove_dir_all(dir).map_err(|e| io(dir, e))?;
    }
    std::fs::rename(&tmp, dir).map_err(|e| io(dir, e))
}
