//! The rows of an outside estimator's side files (timing, state covariance): comma- or
//! space-separated numbers, `#` comments and blank lines skipped, a first row of column names
//! allowed; the first column a stamp in seconds — or in nanoseconds when that header names it
//! `t_ns`. A malformed row is refused naming the file and the line.

use std::path::Path;

/// One row: its line (1-based), its stamp (ns) and its other fields, parsed.
#[derive(Clone, Debug, PartialEq)]
pub struct StampedRow {
    /// The line in the file, 1-based.
    pub line: usize,
    /// The stamp (ns).
    pub t_ns: i64,
    /// The fields after the stamp.
    pub values: Vec<f64>,
}

/// The rows of `path`, each with exactly `columns` fields after its stamp; `what` names the
/// file in errors (`its timing file`) and `expected` the row's form (`t seconds`).
pub fn read_stamped_rows(
    path: &Path,
    what: &str,
    columns: usize,
    expected: &str,
) -> Result<Vec<StampedRow>, String> {
    let text =
        std::fs::read_to_string(path).map_err(|e| format!("{what} {}: {e}", path.display()))?;
    let mut out = Vec::new();
    let mut nanoseconds = false;
    let mut first = true;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |m: &str| format!("{what} {}:{}: {m}", path.display(), i + 1);
        let fields: Vec<&str> = line
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|f| !f.is_empty())
            .collect();
        if fields.len() != columns + 1 {
            return Err(bad(&format!(
                "expected {} columns `{expected}`, found {}",
                columns + 1,
                fields.len()
            )));
        }
        let t = fields[0];
        if std::mem::take(&mut first) && t.parse::<f64>().is_err() {
            nanoseconds = t == "t_ns";
            continue;
        }
        let t_ns = if nanoseconds {
            t.parse::<i64>()
                .map_err(|_| bad(&format!("`{t}` is not a stamp in nanoseconds")))?
        } else {
            crate::dataset::parse_seconds(t).map_err(|m| bad(&m))?
        };
        let values = fields[1..]
            .iter()
            .enumerate()
            .map(|(k, f)| {
                f.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| bad(&format!("column {}: `{f}` is not a finite number", k + 2)))
            })
            .collect::<Result<Vec<f64>, String>>()?;
        out.push(StampedRow {
            line: i + 1,
            t_ns,
            values,
        });
    }
    Ok(out)
}

/// The index of the stamp in `stamps` (sorted) nearest `t_ns`, when within `within_ns`.
pub fn nearest_stamp(stamps: &[i64], t_ns: i64, within_ns: i64) -> Option<usize> {
    let k = stamps.partition_point(|&p| p < t_ns);
    [k.checked_sub(1), Some(k)]
        .into_iter()
        .flatten()
        .filter(|&j| j < stamps.len())
        .min_by_key(|&j| (stamps[j] - t_ns).abs())
        .filter(|&j| (stamps[j] - t_ns).abs() <= within_ns)
}
