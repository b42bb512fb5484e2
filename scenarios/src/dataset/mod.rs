//! Dataset I/O: TUM trajectories, the EuRoC ASL folder layout, `sensor.yaml` files, Kalibr
//! calibration files and the `features.csv` export of feature tracks.
//!
//! Every reader checks each row and reports problems as `file:line: what was wrong`
//! ([`DatasetError`]); none of them panics on malformed input. Writers produce files that the
//! community's tools read unchanged (evo, the EuRoC/Kalibr tool chain, OpenVINS, VINS-Fusion).
//!
//! Numbers are written in Rust's shortest round-trip form, so write → read gives back the exact
//! `f64` values and write → read → write is byte-identical.

mod euroc_asl;
mod features;
mod image_file;
pub mod kalibr;
mod kalibr_export;
pub mod ros2;
mod sensor_yaml;
mod tum;
mod yaml;

use std::path::{Path, PathBuf};

pub use euroc_asl::{
    CameraFrame, EurocCamera, EurocDataset, GroundTruthState, INCOMPLETE_MARKER, format_camera_csv,
    format_groundtruth_csv, format_imu_csv, parse_camera_csv, parse_groundtruth_csv, parse_imu_csv,
    read_camera_csv, read_euroc, read_euroc_cameras, read_groundtruth_csv, read_imu_csv,
    write_camera_csv, write_euroc, write_groundtruth_csv, write_imu_csv,
};
pub use features::{
    PIXEL_SLACK_PX, format_features_csv, parse_features_csv, parse_features_csv_within,
    read_features_csv, read_features_csv_within, write_features_csv,
};
pub use image_file::read_gray_image;
pub use kalibr_export::{
    KalibrCamera, KalibrImu, camera_from_imu, format_camchain, format_imu_yaml, yaml_f64,
};
pub use sensor_yaml::{
    CameraSensor, ImuSensor, SensorYaml, format_sensor_yaml, parse_sensor_yaml, read_sensor_yaml,
    write_sensor_yaml,
};
pub(crate) use tum::parse_seconds;
pub use tum::{StampedPose, format_tum, parse_tum, read_tum, write_tum};

/// An error from a dataset reader or writer. Its message always names the file, and for
/// problems in a row also the 1-based line number.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The file or folder could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// A row (or a YAML key) is malformed.
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        /// The file concerned.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// A problem with the file as a whole (a missing key, no data) or with values handed to a
    /// writer (non-finite numbers, timestamps out of order).
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file concerned.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
}

impl DatasetError {
    /// The 1-based line number of a row error, if the error concerns one row.
    pub fn line(&self) -> Option<usize> {
        match self {
            DatasetError::Parse { line, .. } => Some(*line),
            _ => None,
        }
    }

    /// The file the error concerns.
    pub fn path(&self) -> &Path {
        match self {
            DatasetError::Io { path, .. }
            | DatasetError::Parse { path, .. }
            | DatasetError::Invalid { path, .. } => path,
        }
    }
}

/// Row-level error: the caller attaches the file name and line number.
pub(crate) type RowResult<T> = Result<T, String>;

pub(crate) fn parse_error(path: &Path, line: usize, message: String) -> DatasetError {
    DatasetError::Parse {
        path: path.to_path_buf(),
        line,
        message,
    }
}

pub(crate) fn invalid(path: &Path, message: impl Into<String>) -> DatasetError {
    DatasetError::Invalid {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

pub(crate) fn read_text(path: &Path) -> Result<String, DatasetError> {
    let bytes = sim::input_file::read(path).map_err(|source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    String::from_utf8(bytes).map_err(|e| {
        // Name the line of the first invalid byte.
        let valid = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..valid]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        parse_error(path, line, "the file is not valid UTF-8 text".into())
    })
}

pub(crate) fn write_text(path: &Path, text: &str) -> Result<(), DatasetError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| DatasetError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    std::fs::write(path, text).map_err(|source| DatasetError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The data lines of a text file: `(1-based line number, trimmed content)`, skipping blank lines
/// and `#` comments. Handles `\n` and `\r\n` endings.
pub(crate) fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    // A byte-order mark (spreadsheet exports write one) is not part of the first cell.
    text.strip_prefix('\u{feff}')
        .unwrap_or(text)
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'))
}

/// Parses a finite `f64`; `what` names the column in the error message.
pub(crate) fn parse_f64(field: &str, what: &str) -> RowResult<f64> {
    let s = field.trim();
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("{what}: `{s}` is not a finite number")),
        Err(_) => Err(format!("{what}: `{s}` is not a number")),
    }
}

/// Parses an integer nanosecond timestamp of at most [`MAX_STAMP_NS`] in magnitude.
pub(crate) fn parse_stamp_ns(field: &str, what: &str) -> RowResult<i64> {
    let s = field.trim();
    let t = s
        .parse::<i64>()
        .map_err(|_| format!("{what}: `{s}` is not an integer"))?;
    if t.unsigned_abs() > MAX_STAMP_NS as u64 {
        return Err(format!(
            "{what}: `{s}` ns is beyond ±{MAX_STAMP_NS} ns (years 1824–2116): the difference of two stamps must fit in 64 bits"
        ));
    }
    Ok(t)
}

/// Largest magnitude of a nanosecond stamp a reader accepts: half the 64-bit range, so that
/// the difference of any two stamps (durations, the shift to the run's clock) cannot wrap.
pub const MAX_STAMP_NS: i64 = i64::MAX / 2;

/// Formats an `f64` so that parsing it gives back the same value (shortest round-trip digits);
/// scientific notation for very small or very large magnitudes to keep lines short.
pub(crate) fn fmt_f64(v: f64) -> String {
    let a = v.abs();
    if v != 0.0 && !(1e-5..1e16).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Checks that every value handed to a writer is finite.
pub(crate) fn check_finite(path: &Path, row: usize, values: &[f64]) -> Result<(), DatasetError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(invalid(
            path,
            format!("cannot write row {row}: it holds a non-finite value"),
        ))
    }
}

/// Tolerance on `| |q| − 1 |` below which a quaternion read from a file is kept bit for bit.
const QUAT_EXACT_TOL: f64 = 1e-12;
/// Largest `| |q| − 1 |` that a reader renormalizes; larger deviations are errors.
pub const QUAT_NORM_TOL: f64 = 1e-3;

/// Builds a unit quaternion from file values (Hamilton, `w, x, y, z`): kept exactly when its norm
/// is one to 1e-12, renormalized when within [`QUAT_NORM_TOL`], an error otherwise.
pub(crate) fn unit_quaternion(
    w: f64,
    x: f64,
    y: f64,
    z: f64,
) -> RowResult<nalgebra::UnitQuaternion<f64>> {
    let q = nalgebra::Quaternion::new(w, x, y, z);
    let n = q.norm();
    if (n - 1.0).abs() <= QUAT_EXACT_TOL {
        Ok(nalgebra::UnitQuaternion::new_unchecked(q))
    } else if (n - 1.0).abs() <= QUAT_NORM_TOL {
        Ok(nalgebra::UnitQuaternion::new_normalize(q))
    } else {
        Err(format!(
            "quaternion (w {w}, x {x}, y {y}, z {z}) has norm {n}, not 1 (tolerance {QUAT_NORM_TOL})"
        ))
    }
}
