//! A sweep's finished runs kept as they finish, so an interrupted sweep (Ctrl-C, a preempted
//! batch job) resumes where it stopped: `OUT/partial/run-<index>.csv`, each `results.csv`'s
//! header and that run's row, written to a temporary name and renamed, so a file is either
//! whole or absent. `vio sweep --resume` reads them back — every row checked against what the
//! sweep itself would write for that run — runs the rest, writes `results.csv` from all rows
//! (the bytes an uninterrupted run writes) and removes the folder.

use std::path::{Path, PathBuf};

use super::Sweep;
use super::run::{RunRow, Shard};

/// The folder under `--out`.
pub const PARTIAL_DIR: &str = "partial";

/// `OUT/partial`.
pub fn partial_dir(out: &Path) -> PathBuf {
    out.join(PARTIAL_DIR)
}

/// Keeps `row` under `out` (whole or not at all).
pub fn keep_row(out: &Path, sweep: &Sweep, row: &RunRow) -> Result<(), String> {
    let dir = partial_dir(out);
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let text = format!("{}\n{}\n", sweep.csv_header(), sweep.csv_row(row));
    let tmp = dir.join(format!(".run-{}.tmp", row.run));
    let path = dir.join(format!("run-{}.csv", row.run));
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, &path))
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// The rows kept under `out` for `shard` of `sweep`, in run order. A file that is not a
/// whole, valid row of this sweep and shard is an error naming it (temporary files of a run
/// stopped while writing are ignored).
pub fn kept_rows(out: &Path, sweep: &Sweep, shard: Shard) -> Result<Vec<RunRow>, String> {
    let dir = partial_dir(out);
    if !dir.exists() {
        return Ok(Vec::new());
    }
    let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let runs = sweep.points().len() * sweep.spec.seeds.len();
    let mut rows = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| format!("{}: {e}", dir.display()))?.path();
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        if name.starts_with('.') && name.ends_with(".tmp") {
            continue;
        }
        let at = |line: usize, m: String| format!("{}:{line}: {m}", path.display());
        let run: usize = name
            .strip_prefix("run-")
            .and_then(|n| n.strip_suffix(".csv"))
            .and_then(|n| n.parse().ok())
            .ok_or_else(|| {
                format!(
                    "{}: not a kept run (run-<index>.csv); remove it or start again without --resume",
                    path.display()
                )
            })?;
        if run >= runs || !shard.has(run) {
            return Err(format!(
                "{}: run {run} is not one of this sweep's {runs} runs in shard {}/{}",
                path.display(),
                shard.index,
                shard.count
            ));
        }
        let text = sim::input_file::read_to_string(&path)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        let mut lines = text.lines();
        if lines.next() != Some(sweep.csv_header().as_str()) {
            return Err(at(1, "not this sweep's header".into()));
        }
        let line = lines.next().ok_or_else(|| at(2, "no row".into()))?;
        if lines.next().is_some() || !text.ends_with('\n') {
            return Err(at(2, "not exactly one whole row".into()));
        }
        rows.push(parse_kept(sweep, run, line).map_err(|m| at(2, m))?);
    }
    rows.sort_by_key(|r| r.run);
    Ok(rows)
}

/// Run `run`'s row: its run, point, seed and axis cells exactly as the sweep writes them, then
/// one metric cell per metric, empty or a finite number.
fn parse_kept(sweep: &Sweep, run: usize, line: &str) -> Result<RunRow, String> {
    let seeds = &sweep.spec.seeds;
    let point = run / seeds.len();
    let expected = RunRow {
        run,
        point,
        seed: seeds[run % seeds.len()],
        values: Vec::new(),
    };
    let prefix = sweep.csv_row(&expected);
    let metrics = line
        .strip_prefix(prefix.as_str())
        .ok_or_else(|| format!("run {run} should begin `{prefix}`: {line}"))?;
    let cells: Vec<&str> = metrics.split(',').skip(1).collect();
    if !metrics.starts_with(',') && !sweep.metrics.is_empty() || cells.len() != sweep.metrics.len()
    {
        return Err(format!(
            "{} metric cells, expected {}: {line}",
            cells.len(),
            sweep.metrics.len()
        ));
    }
    let values = cells
        .iter()
        .map(|c| match *c {
            "" => Ok(None),
            c => match c.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                _ => Err(format!("`{c}` is not a finite number")),
            },
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(RunRow { values, ..expected })
}

/// Removes the kept rows (once `results.csv` holds them).
pub fn forget_rows(out: &Path) -> Result<(), String> {
    let dir = partial_dir(out);
    match std::fs::remove_dir_all(&dir) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(format!("{}: {e}", dir.display())),
    }
}
