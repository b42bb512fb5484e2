//! TUM trajectory files: one pose per line, `t tx ty tz qx qy qz qw`, `t` in seconds.

use std::path::Path;

use estimator::geometry::Pose;
use nalgebra::Vector3;

use super::{
    DatasetError, RowResult, check_finite, data_lines, fmt_f64, parse_error, parse_f64, read_text,
    unit_quaternion, write_text,
};

/// A timestamped pose `T_w_b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StampedPose {
    /// Timestamp (ns).
    pub t_ns: i64,
    /// The pose `T_w_b` (body in world).
    pub pose: Pose,
}

impl StampedPose {
    /// Builds a stamped pose.
    pub fn new(t_ns: i64, pose: Pose) -> Self {
        Self { t_ns, pose }
    }
}

const NS_PER_S: u64 = 1_000_000_000;

/// Formats nanoseconds as seconds with exactly nine decimals (`{sec}.{nanos:09}`), no rounding.
pub(crate) fn format_seconds(t_ns: i64) -> String {
    let sign = if t_ns < 0 { "-" } else { "" };
    let a = t_ns.unsigned_abs();
    format!("{sign}{}.{:09}", a / NS_PER_S, a % NS_PER_S)
}

/// Parses a decimal number of seconds to exact integer nanoseconds without going through a float:
/// `1403636580.83856` → `1403636580838560000`. More than nine decimals are rounded to the nearest
/// nanosecond (half away from zero). Scientific notation (`1.4e9`) is accepted through `f64`
/// and rounded to the nearest nanosecond.
pub(crate) fn parse_seconds(field: &str) -> RowResult<i64> {
    let s = field.trim();
    let bad = || format!("timestamp `{s}` is not a number of seconds");
    if s.contains(['e', 'E']) {
        let v: f64 = s.parse().map_err(|_| bad())?;
        let ns = (v * 1e9).round();
        if !ns.is_finite() || ns.abs() >= 9.2e18 {
            return Err(format!("timestamp `{s}` is out of range"));
        }
        return Ok(ns as i64);
    }
    let (neg, body) = match s.as_bytes().first() {
        Some(b'-') => (true, &s[1..]),
        Some(b'+') => (false, &s[1..]),
        _ => (false, s),
    };
    let (int_part, frac_part) = body.split_once('.').unwrap_or((body, ""));
    let all_digits = |p: &str| p.bytes().all(|b| b.is_ascii_digit());
    if (int_part.is_empty() && frac_part.is_empty())
        || !all_digits(int_part)
        || !all_digits(frac_part)
    {
        return Err(bad());
    }
    let range = || format!("timestamp `{s}` is out of range");
    let secs: u64 = if int_part.is_empty() {
        0
    } else {
        int_part.parse().map_err(|_| range())?
    };
    let mut nanos: u64 = 0;
    for (i, b) in frac_part.bytes().take(9).enumerate() {
        nanos += u64::from(b - b'0') * 10u64.pow(8 - i as u32);
    }
    if frac_part.len() > 9 && frac_part.as_bytes()[9] >= b'5' {
        nanos += 1;
    }
    let total = secs
        .checked_mul(NS_PER_S)
        .and_then(|v| v.checked_add(nanos))
        .filter(|&v| v <= i64::MAX as u64)
        .ok_or_else(range)? as i64;
    Ok(if neg { -total } else { total })
}

fn parse_row(line: &str) -> RowResult<StampedPose> {
    let fields: Vec<&str> = line
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|f| !f.is_empty())
        .collect();
    if fields.len() != 8 {
        return Err(format!(
            "expected 8 columns `t tx ty tz qx qy qz qw`, found {}",
            fields.len()
        ));
    }
    let t_ns = parse_seconds(fields[0])?;
    const NAMES: [&str; 8] = ["t", "tx", "ty", "tz", "qx", "qy", "qz", "qw"];
    let mut v = [0.0; 7];
    for i in 0..7 {
        v[i] = parse_f64(fields[i + 1], NAMES[i + 1])?;
    }
    let q = unit_quaternion(v[6], v[3], v[4], v[5])?;
    Ok(StampedPose::new(
        t_ns,
        Pose::new(q, Vector3::new(v[0], v[1], v[2])),
    ))
}

/// Parses TUM text; `path` only names the source in error messages. `#` comments and blank
/// lines are skipped; timestamps must increase strictly.
pub fn parse_tum(text: &str, path: &Path) -> Result<Vec<StampedPose>, DatasetError> {
    let mut out: Vec<StampedPose> = Vec::new();
    for (line, content) in data_lines(text) {
        let sp = parse_row(content).map_err(|m| parse_error(path, line, m))?;
        if let Some(prev) = out.last()
            && sp.t_ns <= prev.t_ns
        {
            return Err(parse_error(
                path,
                line,
                format!(
                    "timestamps not increasing: {} s follows {} s",
                    format_seconds(sp.t_ns),
                    format_seconds(prev.t_ns)
                ),
            ));
        }
        out.push(sp);
    }
    Ok(out)
}

/// Reads a TUM trajectory file.
pub fn read_tum(path: impl AsRef<Path>) -> Result<Vec<StampedPose>, DatasetError> {
    let path = path.as_ref();
    parse_tum(&read_text(path)?, path)
}

/// Formats poses as TUM text with a `#` header line; `path` only names the destination in error
/// messages. Fails on non-finite values and on timestamps that do not increase strictly.
pub fn format_tum(poses: &[StampedPose], path: &Path) -> Result<String, DatasetError> {
    let mut s = String::with_capacity(64 * (poses.len() + 1));
    s.push_str("# timestamp tx ty tz qx qy qz qw\n");
    for (i, sp) in poses.iter().enumerate() {
        if i > 0 && sp.t_ns <= poses[i - 1].t_ns {
            return Err(super::invalid(
                path,
                format!("cannot write row {i}: timestamps not increasing"),
            ));
        }
        let a = sp.pose.to_array(); // px py pz qx qy qz qw
        check_finite(path, i, &a)?;
        s.push_str(&format_seconds(sp.t_ns));
        for v in a {
            s.push(' ');
            s.push_str(&fmt_f64(v));
        }
        s.push('\n');
    }
    Ok(s)
}

/// Writes a TUM trajectory file (creating parent folders).
pub fn write_tum(path: impl AsRef<Path>, poses: &[StampedPose]) -> Result<(), DatasetError> {
    let path = path.as_ref();
    write_text(path, &format_tum(poses, path)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_parse_exactly() {
        assert_eq!(
            parse_seconds("1403636580.83856"),
            Ok(1_403_636_580_838_560_000)
        );
        assert_eq!(parse_seconds("0.000000001"), Ok(1));
        assert_eq!(parse_seconds("-0.5"), Ok(-500_000_000));
        assert_eq!(parse_seconds("12"), Ok(12_000_000_000));
        assert_eq!(parse_seconds(".25"), Ok(250_000_000));
        assert_eq!(parse_seconds("1.0000000015"), Ok(1_000_000_002));
        assert_eq!(parse_seconds("1.5e9"), Ok(1_500_000_000_000_000_000));
        assert!(parse_seconds("1.2.3").is_err());
        assert!(parse_seconds("").is_err());
        assert!(parse_seconds("-").is_err());
        assert!(parse_seconds("nan").is_err());
        assert!(parse_seconds("99999999999999999999").is_err());
    }

    #[test]
    fn seconds_format_round_trips() {
        for t in [
            0,
            1,
            -1,
            999_999_999,
            -1_500_000_000,
            1_403_636_580_838_555_648,
            i64::MAX,
            i64::MIN + 1,
        ] {
            assert_eq!(parse_seconds(&format_seconds(t)), Ok(t), "{t}");
        }
        assert_eq!(format_seconds(-500_000_000), "-0.500000000");
    }
}
