//! The answer a sweep was asked for: per point, each metric's mean and worst seed, the runs
//! that gave no value (a run that never initialized has no ATE), and, against the sweep's
//! `[target]`, whether the point passes and which passing point is the cheapest
//! (`summary.csv`, `summary.md`). A pure function of `results.csv`'s rows, so merged shards
//! and one process write the same bytes.
//!
//! A point passes when every one of its runs gave the target's metric and its worst seed meets
//! the bound: a design that holds on average but not on one seed is not one to buy. The
//! cheapest passing point is the one of least cost, the sum over the axes of each value's
//! `cost` (axes without costs count 0); ties, and sweeps without costs, go to the first in
//! grid order (list each axis's values cheapest first).

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::point::point_of;

/// `[target]`: the bound the sweep asks about.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TargetSpec {
    /// The metric bounded (one of the sweep's metrics).
    pub metric: String,
    /// At most this (for error metrics).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max: Option<f64>,
    /// At least this (for `tracking_fraction`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min: Option<f64>,
}

impl TargetSpec {
    /// Whether `v` meets the bound.
    fn met(&self, v: f64) -> bool {
        self.max.is_none_or(|m| v <= m) && self.min.is_none_or(|m| v >= m)
    }

    /// The bound in words: `ate_rmse_m ≤ 0.01`.
    pub fn describe(&self) -> String {
        match (self.max, self.min) {
            (Some(m), _) => format!("{} ≤ {m}", self.metric),
            (None, Some(m)) => format!("{} ≥ {m}", self.metric),
            (None, None) => self.metric.clone(),
        }
    }
}

/// Metrics where more is better (the worst seed is the least).
const HIGHER_IS_BETTER: &[&str] = &["tracking_fraction"];

/// One axis as the summary sees it: its name, its values' labels, their costs if given.
pub type AxisCosts<'a> = (&'a str, &'a [String], Option<&'a [f64]>);

/// What the summary needs of the sweep.
#[derive(Clone, Debug)]
pub struct SummaryInput<'a> {
    /// Metric names, in `results.csv`'s order.
    pub metrics: &'a [String],
    /// Per axis: its name, its values' labels, and their costs if given.
    pub axes: Vec<AxisCosts<'a>>,
    /// The bound asked about.
    pub target: Option<&'a TargetSpec>,
    /// Seeds per point.
    pub seeds: usize,
}

/// One point's line of the summary.
#[derive(Clone, Debug, PartialEq)]
pub struct PointSummary {
    /// Point index.
    pub point: usize,
    /// Each axis's value label at this point.
    pub labels: Vec<String>,
    /// Per metric: (runs with a value, mean, worst seed's value).
    pub metrics: Vec<(usize, Option<f64>, Option<f64>)>,
    /// Runs of this point.
    pub runs: usize,
    /// Whether it meets the target (`None` without one).
    pub pass: Option<bool>,
    /// The point's cost (sum over the axes with costs; `None` when no axis has any).
    pub cost: Option<f64>,
}

/// The summary: a line per point and the cheapest passing point.
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// Lines in point order.
    pub points: Vec<PointSummary>,
    /// The cheapest passing point's index in `points` (`None`: no target, or none passes).
    pub cheapest: Option<usize>,
}

/// Summarizes `rows` (each run's point index and metric values, in run order).
pub fn summarize(input: &SummaryInput<'_>, rows: &[(usize, Vec<Option<f64>>)]) -> Summary {
    let lens: Vec<usize> = input.axes.iter().map(|a| a.1.len()).collect();
    let n_points: usize = lens.iter().product();
    let target_ix = input
        .target
        .and_then(|t| input.metrics.iter().position(|m| *m == t.metric));
    let any_cost = input.axes.iter().any(|a| a.2.is_some());
    let mut points = Vec::with_capacity(n_points);
    for p in 0..n_points {
        let idx = point_of(p, &lens);
        let mine: Vec<&Vec<Option<f64>>> = rows.iter().filter(|r| r.0 == p).map(|r| &r.1).collect();
        let metrics = (0..input.metrics.len())
            .map(|m| {
                let vals: Vec<f64> = mine.iter().filter_map(|r| r[m]).collect();
                if vals.is_empty() {
                    return (0, None, None);
                }
                let mean = vals.iter().sum::<f64>() / vals.len() as f64;
                let worst = if HIGHER_IS_BETTER.contains(&input.metrics[m].as_str()) {
                    vals.iter().copied().fold(f64::INFINITY, f64::min)
                } else {
                    vals.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                };
                (vals.len(), Some(mean), Some(worst))
            })
            .collect::<Vec<_>>();
        let pass = match (input.target, target_ix) {
            (Some(t), Some(m)) => {
                let (n, _, _) = metrics[m];
                Some(
                    n == mine.len() && n > 0 && mine.iter().all(|r| r[m].is_some_and(|v| t.met(v))),
                )
            }
            _ => None,
        };
        let cost = any_cost.then(|| {
            input
                .axes
                .iter()
                .zip(&idx)
                .filter_map(|(a, &i)| a.2.map(|c| c[i]))
                .sum()
        });
        points.push(PointSummary {
            point: p,
            labels: input
                .axes
                .iter()
                .zip(&idx)
                .map(|(a, &i)| a.1[i].clone())
                .collect(),
            metrics,
            runs: mine.len(),
            pass,
            cost,
        });
    }
    let cheapest = points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.pass == Some(true))
        .min_by(|a, b| {
            a.1.cost
                .unwrap_or(0.0)
                .total_cmp(&b.1.cost.unwrap_or(0.0))
                .then(a.0.cmp(&b.0))
        })
        .map(|(i, _)| i);
    Summary { points, cheapest }
}

/// A number for a table read by people: four significant digits.
fn short(v: f64) -> String {
    if v == 0.0 || (1e-3..1e5).contains(&v.abs()) {
        let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.3e}")
    }
}

impl Summary {
    /// `summary.csv`: a header, then one line per point (numbers in their shortest exact
    /// form, an empty cell where no run gave a value).
    pub fn csv(&self, input: &SummaryInput<'_>) -> String {
        let mut s = String::from("point");
        for a in &input.axes {
            let _ = write!(s, ",{}", a.0);
        }
        s.push_str(",runs");
        for m in input.metrics {
            let _ = write!(s, ",{m}_runs,{m}_mean,{m}_worst");
        }
        if input.target.is_some() {
            s.push_str(",pass");
        }
        if self.points.iter().any(|p| p.cost.is_some()) {
            s.push_str(",cost");
        }
        s.push('\n');
        let cell = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
        for p in &self.points {
            let _ = write!(s, "{}", p.point);
            for l in &p.labels {
                let _ = write!(s, ",{}", csv_text(l));
            }
            let _ = write!(s, ",{}", p.runs);
            for (n, mean, worst) in &p.metrics {
                let _ = write!(s, ",{n},{},{}", cell(*mean), cell(*worst));
            }
            if let Some(pass) = p.pass {
                let _ = write!(s, ",{pass}");
            }
            if let Some(c) = p.cost {
                let _ = write!(s, ",{c}");
            }
            s.push('\n');
        }
        s
    }

    /// `summary.md`: the alignment, the table in Markdown, the target and the cheapest passing
    /// point.
    pub fn markdown(&self, input: &SummaryInput<'_>) -> String {
        let mut s = String::new();
        if let Some(t) = input.target {
            let _ = writeln!(
                s,
                "target: {} on every seed ({} per point)\n",
                t.describe(),
                input.seeds
            );
        }
        if input.metrics.iter().any(|m| m.starts_with("ate_")) {
            let _ = writeln!(s, "{}\n", crate::report::ALIGNMENT_RULE);
        }
        let mut head: Vec<String> = input.axes.iter().map(|a| a.0.to_string()).collect();
        for m in input.metrics {
            head.push(format!("{m} mean"));
            head.push(format!("{m} worst"));
        }
        head.push("runs without a value".into());
        let costs = self.points.iter().any(|p| p.cost.is_some());
        if costs {
            head.push("cost".into());
        }
        if input.target.is_some() {
            head.push("target".into());
        }
        let _ = writeln!(s, "| {} |", head.join(" | "));
        let _ = writeln!(s, "|{}", "---|".repeat(head.len()));
        let opt = |v: Option<f64>| v.map_or("—".to_string(), short);
        for (i, p) in self.points.iter().enumerate() {
            let mut row: Vec<String> = p.labels.clone();
            for (_, mean, worst) in &p.metrics {
                row.push(opt(*mean));
                row.push(opt(*worst));
            }
            let missing: Vec<String> = input
                .metrics
                .iter()
                .zip(&p.metrics)
                .filter(|(_, m)| m.0 < p.runs)
                .map(|(name, m)| format!("{name} {}", p.runs - m.0))
                .collect();
            row.push(if missing.is_empty() {
                "0".into()
            } else {
                missing.join(", ")
            });
            if costs {
                row.push(opt(p.cost));
            }
            if let Some(pass) = p.pass {
                let mark = match (pass, self.cheapest == Some(i)) {
                    (true, true) => "pass (cheapest)",
                    (true, false) => "pass",
                    (false, _) => "FAIL",
                };
                row.push(mark.into());
            }
            let _ = writeln!(s, "| {} |", row.join(" | "));
        }
        if let Some(t) = input.target {
            s.push('\n');
            match self.cheapest {
                Some(i) => {
                    let p = &self.points[i];
                    let at: Vec<String> = input
                        .axes
                        .iter()
                        .zip(&p.labels)
                        .map(|(a, l)| format!("{} = {l}", a.0))
                        .collect();
                    let _ = writeln!(
                        s,
                        "cheapest point meeting {}: {}{}",
                        t.describe(),
                        at.join(", "),
                        p.cost
                            .map_or(String::new(), |c| format!(" (cost {})", short(c)))
                    );
                }
                None => {
                    let _ = writeln!(s, "no point meets {} on every seed", t.describe());
                }
            }
        }
        s
    }
}

/// A label as a CSV cell: quoted when it holds a comma or a quote.
fn csv_text(l: &str) -> String {
    if l.contains(',') || l.contains('"') {
        format!("\"{}\"", l.replace('"', "\"\""))
    } else {
        l.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input<'a>(
        metrics: &'a [String],
        labels: &'a [Vec<String>; 2],
        cost: Option<&'a [f64]>,
        target: Option<&'a TargetSpec>,
    ) -> SummaryInput<'a> {
        SummaryInput {
            metrics,
            axes: vec![("grade", &labels[0], cost), ("rate_hz", &labels[1], None)],
            target,
            seeds: 2,
        }
    }

    /// Two grades × two rates, two seeds: the cheap grade passes at 20 Hz only; a run that gave
    /// no ATE (never initialized) fails its point however good its other seed.
    #[test]
    fn the_worst_seed_decides_and_the_cheapest_passing_point_is_named() {
        let metrics = vec!["ate_rmse_m".to_string(), "tracking_fraction".to_string()];
        let labels = [
            vec!["consumer".to_string(), "tactical".to_string()],
            vec!["10".to_string(), "20".to_string()],
        ];
        let target = TargetSpec {
            metric: "ate_rmse_m".into(),
            max: Some(0.01),
            min: None,
        };
        let cost = [5.0, 500.0];
        let rows = vec![
            (0, vec![Some(0.008), Some(0.9)]),
            (0, vec![Some(0.02), Some(0.8)]), // one seed over: the point fails
            (1, vec![Some(0.006), Some(1.0)]),
            (1, vec![Some(0.009), Some(0.95)]),
            (2, vec![Some(0.004), Some(1.0)]),
            (2, vec![None, Some(0.0)]), // never initialized
            (3, vec![Some(0.003), Some(1.0)]),
            (3, vec![Some(0.004), Some(1.0)]),
        ];
        let inp = input(&metrics, &labels, Some(&cost), Some(&target));
        let s = summarize(&inp, &rows);
        let pass: Vec<Option<bool>> = s.points.iter().map(|p| p.pass).collect();
        assert_eq!(pass, [Some(false), Some(true), Some(false), Some(true)]);
        assert_eq!(s.cheapest, Some(1));
        assert_eq!(s.points[0].metrics[0], (2, Some(0.014), Some(0.02)));
        assert_eq!(
            s.points[0].metrics[1].2,
            Some(0.8),
            "tracking: the least is worst"
        );
        assert_eq!(s.points[2].metrics[0], (1, Some(0.004), Some(0.004)));
        let md = s.markdown(&inp);
        assert!(
            md.contains(
                "cheapest point meeting ate_rmse_m ≤ 0.01: grade = consumer, rate_hz = 20 (cost 5)"
            ),
            "{md}"
        );
        assert!(md.contains("| tactical | 10 | 0.004 | 0.004 |"), "{md}");
        assert!(
            md.contains("ate_rmse_m 1"),
            "the run without a value is shown: {md}"
        );
        let csv = s.csv(&inp);
        assert!(
            csv.starts_with("point,grade,rate_hz,runs,ate_rmse_m_runs,"),
            "{csv}"
        );
        assert!(csv.contains("\n2,tactical,10,2,1,0.004,0.004,"), "{csv}");
        assert!(csv.lines().nth(1).unwrap().ends_with(",false,5"), "{csv}");
    }

    #[test]
    fn without_costs_the_first_passing_point_in_grid_order_is_cheapest_and_none_may_pass() {
        let metrics = vec!["ate_rmse_m".to_string()];
        let labels = [
            vec!["a".to_string(), "b".to_string()],
            vec!["x".to_string()],
        ];
        let target = TargetSpec {
            metric: "ate_rmse_m".into(),
            max: Some(0.01),
            min: None,
        };
        let rows = vec![(0, vec![Some(0.005)]), (1, vec![Some(0.001)])];
        let inp = input(&metrics, &labels, None, Some(&target));
        assert_eq!(summarize(&inp, &rows).cheapest, Some(0));
        let strict = TargetSpec {
            max: Some(1e-4),
            ..target.clone()
        };
        let inp = input(&metrics, &labels, None, Some(&strict));
        let s = summarize(&inp, &rows);
        assert_eq!(s.cheapest, None);
        assert!(
            s.markdown(&inp)
                .contains("no point meets ate_rmse_m ≤ 0.0001")
        );
        assert_eq!(short(0.0123456), "0.01235");
        assert_eq!(short(152.0), "152");
        assert_eq!(short(2.5e-5), "2.500e-5");
    }
}
