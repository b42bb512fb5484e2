//! Reading `vio imu-model`'s inputs: the IMU csv (or the `imu0` / `mav0` folder holding it),
//! the `sensor.yaml` beside it, and the ground truth, through the EuRoC readers of
//! [`crate::dataset`].

use std::path::{Path, PathBuf};

use super::analysis::Input;
use super::report::KalibrReference;
use crate::dataset::{
    DatasetError, SensorYaml, read_groundtruth_csv, read_imu_csv, read_sensor_yaml,
};

/// The IMU csv a path names: the file itself, or `data.csv` of an `imu0` folder, `imu0/data.csv`
/// of a `mav0` folder, or `mav0/imu0/data.csv` of a dataset folder.
pub fn resolve_log(path: &Path) -> Result<PathBuf, String> {
    if !path.is_dir() {
        return Ok(path.to_path_buf());
    }
    for tail in ["data.csv", "imu0/data.csv", "mav0/imu0/data.csv"] {
        let p = path.join(tail);
        if p.is_file() {
            return Ok(p);
        }
    }
    Err(format!(
        "{}: a folder without data.csv, imu0/data.csv or mav0/imu0/data.csv",
        path.display()
    ))
}

/// The Kalibr values of the `sensor.yaml` beside `csv`: `Ok(None)` when there is none, `Err`
/// (the reader's message: file, line, key) when it is not a readable IMU `sensor.yaml`.
pub fn sensor_yaml_beside(csv: &Path) -> Result<Option<KalibrReference>, String> {
    let Some(yaml) = csv.parent().map(|d| d.join("sensor.yaml")) else {
        return Ok(None);
    };
    if !yaml.is_file() {
        return Ok(None);
    }
    match read_sensor_yaml(&yaml).map_err(|e| e.to_string())? {
        SensorYaml::Imu(s) => Ok(Some(KalibrReference {
            path: yaml.display().to_string(),
            gyroscope_noise_density: s.noise.gyroscope_noise_density,
            gyroscope_random_walk: s.noise.gyroscope_random_walk,
            accelerometer_noise_density: s.noise.accelerometer_noise_density,
            accelerometer_random_walk: s.noise.accelerometer_random_walk,
        })),
        SensorYaml::Camera(_) => Err(format!(
            "{}: a camera sensor.yaml beside an IMU log",
            yaml.display()
        )),
    }
}

/// Reads the log (and its `sensor.yaml`, whose problems are returned as a warning) and the
/// ground truth. `Err` names the file and, for a bad row, the line and the column.
pub fn load(log: &Path, gt: Option<&Path>) -> Result<(Input, Option<String>), String> {
    let csv = resolve_log(log)?;
    let samples = read_imu_csv(&csv).map_err(|e: DatasetError| e.to_string())?;
    if samples.is_empty() {
        return Err(format!("{}: no IMU samples", csv.display()));
    }
    let (sensor_yaml, warning) = match sensor_yaml_beside(&csv) {
        Ok(s) => (s, None),
        Err(w) => (None, Some(format!("{w} (ignored)"))),
    };
    let groundtruth = match gt {
        Some(p) => {
            let rows = read_groundtruth_csv(p).map_err(|e| e.to_string())?;
            if rows.is_empty() {
                return Err(format!("{}: no ground-truth rows", p.display()));
            }
            Some((p.display().to_string(), rows))
        }
        None => None,
    };
    Ok((
        Input {
            log: csv.display().to_string(),
            samples,
            sensor_yaml,
            groundtruth,
        },
        warning,
    ))
}
