//! `vio sweep-merge`: joins shard folders into one (`results.csv` in run order, `sweep.json`)
//! and draws a plot per metric and axis: the mean over seeds against the axis, the seeds'
//! spread as a band, one line per combination of the other axes. `vio sweep` without shards ends
//! the same way, so both write the same bytes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use serde::Deserialize;

use super::summary::{SummaryInput, TargetSpec, summarize};
use crate::plot::{DrawResult, render_png};

/// What merging needs of `sweep.json`.
#[derive(Clone, Debug, Deserialize)]
struct SweepMeta {
    description: String,
    metrics: Vec<String>,
    axes: Vec<AxisMeta>,
    runs: usize,
    seeds: Vec<u64>,
    #[serde(default)]
    target: Option<TargetSpec>,
}

#[derive(Clone, Debug, Deserialize)]
struct AxisMeta {
    name: String,
    x: Vec<f64>,
    labels: Vec<String>,
    #[serde(default)]
    cost: Option<Vec<f64>>,
}

/// Merges the shard folders `dirs` into `out`; returns the files written.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Vec<PathBuf>, String> {
    let read = |p: PathBuf| {
        sim::input_file::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))
    };
    let first = dirs.first().ok_or("no shard folders given")?;
    let json = read(first.join("sweep.json"))?;
    let meta: SweepMeta = serde_json::from_str(&json)
        .map_err(|e| format!("{}: {e}", first.join("sweep.json").display()))?;
    check_meta(&meta).map_err(|e| format!("{}: {e}", first.join("sweep.json").display()))?;
    let points: usize = meta.axes.iter().map(|a| a.x.len()).product();
    let mut header = None;
    // Each row as written and as parsed (checked once, here, and plotted from the same parse).
    let mut rows: BTreeMap<usize, (String, Row)> = BTreeMap::new();
    for d in dirs {
        if read(d.join("sweep.json"))? != json {
            return Err(format!(
                "{}: sweep.json differs from {}'s: shards of different sweeps",
                d.display(),
                first.display()
            ));
        }
        let csv = read(d.join("results.csv"))?;
        if !csv.is_empty() && !csv.ends_with('\n') {
            return Err(format!(
                "{}/results.csv: the last row has no line end: the file is truncated (a shard stopped while writing)",
                d.display()
            ));
        }
        let mut lines = csv.lines();
        let h = lines
            .next()
            .ok_or_else(|| format!("{}: empty results.csv", d.display()))?;
        if header.get_or_insert_with(|| h.to_string()) != h {
            return Err(format!("{}: results.csv has another header", d.display()));
        }
        for (n, line) in lines.enumerate() {
            let at = |m: String| format!("{}/results.csv:{}: {m}", d.display(), n + 2);
            let run: usize = line
                .split(',')
                .next()
                .and_then(|r| r.parse().ok())
                .ok_or_else(|| at("no run index".into()))?;
            if run >= meta.runs {
                return Err(at(format!(
                    "run {run} is beyond the sweep's {} runs",
                    meta.runs
                )));
            }
            let parsed = parse_row(line, &meta).map_err(at)?;
            if parsed.0 >= points {
                return Err(at(format!(
                    "point {} is beyond the sweep's {points} points",
                    parsed.0
                )));
            }
            if rows.insert(run, (line.to_string(), parsed)).is_some() {
                return Err(at(format!(
                    "run {run} appears twice (in this shard or in two of the folders given)"
                )));
            }
        }
    }
    let missing: Vec<usize> = (0..meta.runs).filter(|r| !rows.contains_key(r)).collect();
    if let Some(r) = missing.first() {
        return Err(format!(
            "{} of {} runs are missing from the results.csv of {} (first: run {r}): a shard has not finished or is not among them",
            missing.len(),
            meta.runs,
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut csv = header.unwrap_or_default() + "\n";
    for (line, _) in rows.values() {
        csv.push_str(line);
        csv.push('\n');
    }
    let write = |name: &str, bytes: &[u8]| {
        let p = out.join(name);
        std::fs::write(&p, bytes)
            .map(|()| p.clone())
            .map_err(|e| format!("{}: {e}", p.display()))
    };
    let mut files = vec![
        write("results.csv", csv.as_bytes())?,
        write("sweep.json", json.as_bytes())?,
    ];
    let table: Table = rows.into_values().map(|(_, row)| row).collect();
    let input = SummaryInput {
        metrics: &meta.metrics,
        axes: meta
            .axes
            .iter()
            .map(|a| (a.name.as_str(), a.labels.as_slice(), a.cost.as_deref()))
            .collect(),
        target: meta.target.as_ref(),
        seeds: meta.seeds.len(),
    };
    let per_run: Vec<(usize, Vec<Option<f64>>)> =
        table.iter().map(|(p, _, vs)| (*p, vs.clone())).collect();
    let summary = summarize(&input, &per_run);
    files.push(write("summary.csv", summary.csv(&input).as_bytes())?);
    files.push(write("summary.md", summary.markdown(&input).as_bytes())?);
    for (mi, metric) in meta.metrics.iter().enumerate() {
        for (ai, axis) in meta.axes.iter().enumerate() {
            let png = plot(&meta, &table, mi, ai)?;
            files.push(write(&format!("{metric}_vs_{}.png", axis.name), &png)?);
        }
    }
    Ok(files)
}

/// One row: (point index, axis x values, metric values).
type Row = (usize, Vec<f64>, Vec<Option<f64>>);
/// Rows in run order.
type Table = Vec<Row>;

/// One row's axis values and metrics: every cell present, every number finite (an empty
/// metric cell is a metric the run could not compute).
fn parse_row(line: &str, meta: &SweepMeta) -> Result<Row, String> {
    let na = meta.axes.len();
    let cells: Vec<&str> = line.split(',').collect();
    let want = 3 + na + meta.metrics.len();
    if cells.len() != want {
        return Err(format!(
            "a row with {} cells, expected {want}: {line}",
            cells.len()
        ));
    }
    let num = |c: &str| match c.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("`{c}` is not a finite number")),
    };
    let point: usize = cells[1]
        .parse()
        .map_err(|_| format!("`{}` is not a point index", cells[1]))?;
    let xs = cells[3..3 + na]
        .iter()
        .map(|c| num(c))
        .collect::<Result<_, _>>()?;
    let vs = cells[3 + na..]
        .iter()
        .map(|c| {
            if c.is_empty() {
                Ok(None)
            } else {
                num(c).map(Some)
            }
        })
        .collect::<Result<_, _>>()?;
    Ok((point, xs, vs))
}

/// `sweep.json` is what `vio sweep` writes: a run count within the limit, finite axis positions,
/// one label per position.
fn check_meta(meta: &SweepMeta) -> Result<(), String> {
    if meta.runs == 0 || meta.runs > super::MAX_RUNS {
        return Err(format!(
            "`runs` is {}, expected 1 to {}",
            meta.runs,
            super::MAX_RUNS
        ));
    }
    for (i, a) in meta.axes.iter().enumerate() {
        if let Some(j) = a.x.iter().position(|x| !x.is_finite()) {
            return Err(format!("`axes[{i}].x[{j}]` is not a finite number"));
        }
        if a.labels.len() != a.x.len() {
            return Err(format!(
                "`axes[{i}]`: {} labels for {} positions",
                a.labels.len(),
                a.x.len()
            ));
        }
    }
    Ok(())
}

/// One line of a plot: `(x, mean, min, max)` per axis value.
type Line = Vec<(f64, f64, f64, f64)>;

/// `metric` against `axis`: one line per combination of the other axes' values.
fn lines(meta: &SweepMeta, table: &Table, metric: usize, axis: usize) -> Vec<(String, Line)> {
    let mut groups: BTreeMap<Vec<u64>, BTreeMap<u64, Vec<f64>>> = BTreeMap::new();
    for (_, xs, vs) in table {
        let others: Vec<u64> = xs
            .iter()
            .enumerate()
            .filter(|(a, _)| *a != axis)
            .map(|(_, x)| x.to_bits())
            .collect();
        if let Some(v) = vs[metric] {
            groups
                .entry(others)
                .or_default()
                .entry(xs[axis].to_bits())
                .or_default()
                .push(v);
        }
    }
    groups
        .into_iter()
        .map(|(others, by_x)| {
            let name = meta
                .axes
                .iter()
                .enumerate()
                .filter(|(a, _)| *a != axis)
                .zip(&others)
                .map(|((_, ax), &x)| {
                    let x = f64::from_bits(x);
                    let i = ax.x.iter().position(|&v| v == x);
                    format!(
                        "{}={}",
                        ax.name,
                        i.map_or(x.to_string(), |i| ax.labels[i].clone())
                    )
                })
                .collect::<Vec<_>>()
                .join(", ");
            let mut line: Line = by_x
                .into_iter()
                .map(|(x, v)| {
                    let n = v.len() as f64;
                    let mean = v.iter().sum::<f64>() / n;
                    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    (f64::from_bits(x), mean, lo, hi)
                })
                .collect();
            line.sort_by(|a, b| a.0.total_cmp(&b.0));
            (name, line)
        })
        .collect()
}

fn plot(meta: &SweepMeta, table: &Table, metric: usize, axis: usize) -> Result<Vec<u8>, String> {
    let data = lines(meta, table, metric, axis);
    let size = (900u32, 560u32);
    render_png(size, |buf| draw(meta, &data, metric, axis, size, buf))
}

fn draw(
    meta: &SweepMeta,
    data: &[(String, Line)],
    metric: usize,
    axis: usize,
    size: (u32, u32),
    buf: &mut [u8],
) -> DrawResult {
    let ax = &meta.axes[axis];
    // Axes spanning more than a factor of 20 of positive values are drawn on log10.
    let (xmin, xmax) =
        ax.x.iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
    let log = xmin > 0.0 && xmax / xmin >= 20.0;
    let tx = |x: f64| if log { x.log10() } else { x };
    let (x0, x1) = (tx(xmin), tx(xmax));
    let pad = 0.08 * (x1 - x0).max(1e-9);
    // Values spanning more than a factor of 30 (a diverged seed among centimetre errors) are
    // drawn on log10 too.
    let (ylo, yhi) = data
        .iter()
        .flat_map(|(_, l)| l.iter().flat_map(|p| [p.2, p.3]))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), y| {
            (a.min(y), b.max(y))
        });
    let ylog = ylo > 0.0 && yhi / ylo > 30.0;
    let ty = |y: f64| if ylog { y.max(1e-300).log10() } else { y };
    let (y0, y1) = if ylog {
        (ty(ylo) - 0.1, ty(yhi) + 0.1)
    } else {
        (0.0, yhi.max(1e-12) * 1.1)
    };
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let label = crate::spec::key_listing::metric_label(&meta.metrics[metric]);
    let title = format!(
        "{}: {} vs {}",
        meta.description, meta.metrics[metric], ax.name
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18).into_font())
        .margin(14)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((x0 - pad)..(x1 + pad), y0..y1)?;
    let y_fmt = |v: &f64| {
        let y = if ylog { 10f64.powf(*v) } else { *v };
        if y == 0.0 {
            "0".to_string()
        } else {
            let digits = (2 - y.abs().log10().floor() as i32).clamp(0, 8) as usize;
            format!("{y:.digits$}")
        }
    };
    chart
        .configure_mesh()
        .x_desc(if log {
            format!("{} (log scale)", ax.name)
        } else {
            ax.name.clone()
        })
        .y_desc(if ylog {
            format!("{label} (log scale)")
        } else {
            label
        })
        .x_labels(0)
        .disable_x_mesh()
        .y_label_formatter(&y_fmt)
        .label_style(("sans-serif", 13))
        .draw()?;
    // The axis values themselves as ticks: a light line and the label at the bottom.
    let grid = RGBColor(200, 200, 200);
    for (x, label) in ax.x.iter().zip(&ax.labels) {
        chart.draw_series(LineSeries::new([(tx(*x), y0), (tx(*x), y1)], grid))?;
        chart.draw_series(std::iter::once(Text::new(
            label.clone(),
            (tx(*x), y0 + 0.01 * (y1 - y0)),
            ("sans-serif", 13)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Center, VPos::Bottom)),
        )))?;
    }
    let palette = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
        RGBColor(23, 190, 207),
    ];
    for (k, (name, line)) in data.iter().enumerate() {
        let c = palette[k % palette.len()];
        let band: Vec<(f64, f64)> = line
            .iter()
            .map(|p| (tx(p.0), ty(p.3)))
            .chain(line.iter().rev().map(|p| (tx(p.0), ty(p.2))))
            .collect();
        chart.draw_series(std::iter::once(Polygon::new(band, c.mix(0.18).filled())))?;
        let s = chart.draw_series(LineSeries::new(
            line.iter().map(|p| (tx(p.0), ty(p.1))),
            c.stroke_width(2),
        ))?;
        if !name.is_empty() {
            s.label(name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
        }
        chart.draw_series(
            line.iter()
                .map(|p| Circle::new((tx(p.0), ty(p.1)), 3, c.filled())),
        )?;
    }
    if data.iter().any(|(n, _)| !n.is_empty()) {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 13))
            .draw()?;
    }
    root.present()?;
    Ok(())
}
