//! The EuRoC ASL folder layout (`mav0/...`): IMU and ground-truth CSV files, camera frame lists,
//! and whole folders with their `sensor.yaml` files (read and written by [`super::sensor_yaml`]).
//!
//! ```text
//! mav0/imu0/data.csv                          #timestamp [ns],w_RS_S_x [rad s^-1],...,a_RS_S_z [m s^-2]
//! mav0/imu0/sensor.yaml                       sensor_type: imu, T_BS, rate_hz, Kalibr noise values
//! mav0/cam0/data.csv                          #timestamp [ns],filename
//! mav0/cam0/sensor.yaml                       sensor_type: camera, T_BS, intrinsics, distortion
//! mav0/state_groundtruth_estimate0/data.csv   t, p (m), q (w x y z), v (m/s), b_w (rad/s), b_a (m/s²)
//! ```

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The file `vio export` keeps in `mav0/` while it writes (removed when it finishes): a folder
/// holding it is refused as incomplete.
pub const INCOMPLETE_MARKER: &str = "EXPORT_INCOMPLETE";

use estimator::geometry::Pose;
use estimator::imu::ImuSample;
use nalgebra::Vector3;

use super::sensor_yaml::{
    CameraSensor, ImuSensor, SensorYaml, read_sensor_yaml, write_sensor_yaml,
};
use super::{
    DatasetError, RowResult, check_finite, data_lines, fmt_f64, invalid, parse_error, parse_f64,
    parse_stamp_ns, read_text, unit_quaternion, write_text,
};

/// Header of `mav0/imu0/data.csv`, as in the EuRoC datasets.
pub const IMU_HEADER: &str = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]";
/// Header of `mav0/state_groundtruth_estimate0/data.csv`, as in the EuRoC datasets.
pub const GROUNDTRUTH_HEADER: &str = "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]";
/// Header of `mav0/cam*/data.csv`, as in the EuRoC datasets.
pub const CAMERA_HEADER: &str = "#timestamp [ns],filename";

/// One row of the EuRoC ground truth: the body (IMU) state in the world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GroundTruthState {
    /// Timestamp (ns).
    pub t_ns: i64,
    /// `T_w_b` (file columns p_RS_R and q_RS, quaternion stored w x y z).
    pub pose: Pose,
    /// Velocity in the world frame (m/s).
    pub velocity: Vector3<f64>,
    /// Gyroscope bias (rad/s).
    pub gyro_bias: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub accel_bias: Vector3<f64>,
}

/// One row of a camera `data.csv`: an image timestamp and its file name under `data/`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CameraFrame {
    /// Timestamp (ns).
    pub t_ns: i64,
    /// File name relative to the camera's `data/` folder (`<t_ns>.png`).
    pub filename: String,
}

impl CameraFrame {
    /// The EuRoC naming: `<t_ns>.png`.
    pub fn at(t_ns: i64) -> Self {
        Self {
            t_ns,
            filename: format!("{t_ns}.png"),
        }
    }
}

/// One camera folder `mav0/cam<i>`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EurocCamera {
    /// The calibration from `sensor.yaml`, if the folder has one.
    pub sensor: Option<CameraSensor>,
    /// The rows of `data.csv`.
    pub frames: Vec<CameraFrame>,
}

/// The contents of an EuRoC ASL `mav0` folder (without image pixels).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EurocDataset {
    /// `imu0/data.csv`.
    pub imu: Vec<ImuSample>,
    /// `imu0/sensor.yaml`, if present.
    pub imu_sensor: Option<ImuSensor>,
    /// `state_groundtruth_estimate0/data.csv` (empty if the folder is absent).
    pub groundtruth: Vec<GroundTruthState>,
    /// `cam0`, `cam1`, ... in order.
    pub cameras: Vec<EurocCamera>,
}

// ---------------------------------------------------------------------------------------------
// CSV helpers

fn split_csv<'a>(line: &'a str, expected: usize, what: &str) -> RowResult<Vec<&'a str>> {
    let fields: Vec<&str> = line.split(',').map(str::trim).collect();
    if fields.len() != expected {
        return Err(format!(
            "expected {expected} comma-separated columns ({what}), found {}",
            fields.len()
        ));
    }
    Ok(fields)
}

fn parse_numbers<const N: usize>(fields: &[&str], names: &[&str]) -> RowResult<[f64; N]> {
    let mut v = [0.0; N];
    for i in 0..N {
        v[i] = parse_f64(fields[i], names[i])?;
    }
    Ok(v)
}

fn check_increasing(
    path: &Path,
    line: usize,
    prev: Option<i64>,
    t: i64,
) -> Result<(), DatasetError> {
    match prev {
        Some(p) if t <= p => Err(parse_error(
            path,
            line,
            format!("timestamps not increasing: {t} ns follows {p} ns"),
        )),
        _ => Ok(()),
    }
}

fn check_increasing_write(
    path: &Path,
    stamps: impl Iterator<Item = i64>,
) -> Result<(), DatasetError> {
    let mut prev: Option<i64> = None;
    for (i, t) in stamps.enumerate() {
        if prev.is_some_and(|p| t <= p) {
            return Err(invalid(
                path,
                format!("cannot write row {i}: timestamps not increasing"),
            ));
        }
        prev = Some(t);
    }
    Ok(())
}

fn push_row(s: &mut String, t_ns: i64, values: &[f64]) {
    let _ = write!(s, "{t_ns}");
    for v in values {
        s.push(',');
        s.push_str(&fmt_f64(*v));
    }
    s.push('\n');
}

// ---------------------------------------------------------------------------------------------
// IMU

const IMU_NAMES: [&str; 7] = ["timestamp", "w_x", "w_y", "w_z", "a_x", "a_y", "a_z"];

/// A reading no IMU can give: a component beyond the widest plausible full scale
/// (`sim::plausible`: ±100 rad/s, ±10,000 m/s²), a units mistake (°/s as rad/s at high rate,
/// mg as m/s²·10³) or a corrupt value, refused with its column before it is fitted or fused.
/// `written`: the values as the file wrote them (for the message).
fn check_full_scale(v: &[f64; 6], written: &[&str]) -> Result<(), String> {
    use sim::plausible::{ACCEL_RANGE_M_S2, GYRO_RANGE_RAD_S};
    for (k, &x) in v.iter().enumerate() {
        let range = if k < 3 {
            &GYRO_RANGE_RAD_S
        } else {
            &ACCEL_RANGE_M_S2
        };
        if x.abs() > range.hi {
            return Err(format!(
                "{} = {} {} is beyond any IMU's full scale (±{} {}: {})",
                IMU_NAMES[k + 1],
                written[k].trim(),
                range.unit,
                range.hi,
                range.unit,
                range.basis
            ));
        }
    }
    Ok(())
}

/// Parses `imu0/data.csv` text; `path` names the source in errors.
pub fn parse_imu_csv(text: &str, path: &Path) -> Result<Vec<ImuSample>, DatasetError> {
    let mut out: Vec<ImuSample> = Vec::new();
    for (line, content) in data_lines(text) {
        let row = (|| {
            let f = split_csv(content, 7, "timestamp, 3 gyro, 3 accel")?;
            let t = parse_stamp_ns(f[0], IMU_NAMES[0])?;
            let v: [f64; 6] = parse_numbers(&f[1..], &IMU_NAMES[1..])?;
            check_full_scale(&v, &f[1..])?;
            Ok(ImuSample {
                t_ns: t,
                gyro: Vector3::new(v[0], v[1], v[2]),
                accel: Vector3::new(v[3], v[4], v[5]),
            })
        })()
        .map_err(|m: String| parse_error(path, line, m))?;
        check_increasing(path, line, out.last().map(|s| s.t_ns), row.t_ns)?;
        out.push(row);
    }
    Ok(out)
}

/// Reads `imu0/data.csv`.
pub fn read_imu_csv(path: impl AsRef<Path>) -> Result<Vec<ImuSample>, DatasetError> {
    let path = path.as_ref();
    parse_imu_csv(&read_text(path)?, path)
}

/// Formats IMU samples as `imu0/data.csv` text.
pub fn format_imu_csv(samples: &[ImuSample], path: &Path) -> Result<String, DatasetError> {
    check_increasing_write(path, samples.iter().map(|s| s.t_ns))?;
    let mut s = String::with_capacity(80 * (samples.len() + 1));
    s.push_str(IMU_HEADER);
    s.push('\n');
    for (i, m) in samples.iter().enumerate() {
        let v = [
            m.gyro.x, m.gyro.y, m.gyro.z, m.accel.x, m.accel.y, m.accel.z,
        ];
        check_finite(path, i, &v)?;
        push_row(&mut s, m.t_ns, &v);
    }
    Ok(s)
}

/// Writes `imu0/data.csv` (creating parent folders).
pub fn write_imu_csv(path: impl AsRef<Path>, samples: &[ImuSample]) -> Result<(), DatasetError> {
    let path = path.as_ref();
    write_text(path, &format_imu_csv(samples, path)?)
}

// ---------------------------------------------------------------------------------------------
// Ground truth

const GT_NAMES: [&str; 17] = [
    "timestamp",
    "p_x",
    "p_y",
    "p_z",
    "q_w",
    "q_x",
    "q_y",
    "q_z",
    "v_x",
    "v_y",
    "v_z",
    "b_w_x",
    "b_w_y",
    "b_w_z",
    "b_a_x",
    "b_a_y",
    "b_a_z",
];

/// Parses `state_groundtruth_estimate0/data.csv` text; `path` names the source in errors.
pub fn parse_groundtruth_csv(
    text: &str,
    path: &Path,
) -> Result<Vec<GroundTruthState>, DatasetError> {
    let mut out: Vec<GroundTruthState> = Vec::new();
    for (line, content) in data_lines(text) {
        let row = (|| {
            let f = split_csv(content, 17, "timestamp, p, q (w x y z), v, b_w, b_a")?;
            let t = parse_stamp_ns(f[0], GT_NAMES[0])?;
            let v: [f64; 16] = parse_numbers(&f[1..], &GT_NAMES[1..])?;
            let q = unit_quaternion(v[3], v[4], v[5], v[6])?;
            Ok(GroundTruthState {
                t_ns: t,
                pose: Pose::new(q, Vector3::new(v[0], v[1], v[2])),
                velocity: Vector3::new(v[7], v[8], v[9]),
                gyro_bias: Vector3::new(v[10], v[11], v[12]),
                accel_bias: Vector3::new(v[13], v[14], v[15]),
            })
        })()
        .map_err(|m: String| parse_error(path, line, m))?;
        check_increasing(path, line, out.last().map(|s| s.t_ns), row.t_ns)?;
        out.push(row);
    }
    Ok(out)
}

/// Reads `state_groundtruth_estimate0/data.csv`.
pub fn read_groundtruth_csv(path: impl AsRef<Path>) -> Result<Vec<GroundTruthState>, DatasetError> {
    let path = path.as_ref();
    parse_groundtruth_csv(&read_text(path)?, path)
}

/// Formats ground-truth states as `state_groundtruth_estimate0/data.csv` text.
pub fn format_groundtruth_csv(
    states: &[GroundTruthState],
    path: &Path,
) -> Result<String, DatasetError> {
    check_increasing_write(path, states.iter().map(|s| s.t_ns))?;
    let mut s = String::with_capacity(200 * (states.len() + 1));
    s.push_str(GROUNDTRUTH_HEADER);
    s.push('\n');
    for (i, g) in states.iter().enumerate() {
        let q = g.pose.q.quaternion();
        let p = g.pose.p;
        let v = [
            p.x,
            p.y,
            p.z,
            q.w,
            q.i,
            q.j,
            q.k,
            g.velocity.x,
            g.velocity.y,
            g.velocity.z,
            g.gyro_bias.x,
            g.gyro_bias.y,
            g.gyro_bias.z,
            g.accel_bias.x,
            g.accel_bias.y,
            g.accel_bias.z,
        ];
        check_finite(path, i, &v)?;
        push_row(&mut s, g.t_ns, &v);
    }
    Ok(s)
}

/// Writes `state_groundtruth_estimate0/data.csv` (creating parent folders).
pub fn write_groundtruth_csv(
    path: impl AsRef<Path>,
    states: &[GroundTruthState],
) -> Result<(), DatasetError> {
    let path = path.as_ref();
    write_text(path, &format_groundtruth_csv(states, path)?)
}

// ---------------------------------------------------------------------------------------------
// Camera frame lists

/// Parses a camera `data.csv` text; `path` names the source in errors.
pub fn parse_camera_csv(text: &str, path: &Path) -> Result<Vec<CameraFrame>, DatasetError> {
    let mut out: Vec<CameraFrame> = Vec::new();
    for (line, content) in data_lines(text) {
        let row = (|| {
            let f = split_csv(content, 2, "timestamp, filename")?;
            let t = parse_stamp_ns(f[0], "timestamp")?;
            if f[1].is_empty() {
                return Err("filename is empty".to_string());
            }
            Ok(CameraFrame {
                t_ns: t,
                filename: f[1].to_string(),
            })
        })()
        .map_err(|m: String| parse_error(path, line, m))?;
        check_increasing(path, line, out.last().map(|s| s.t_ns), row.t_ns)?;
        out.push(row);
    }
    Ok(out)
}

/// Reads a camera `data.csv`.
pub fn read_camera_csv(path: impl AsRef<Path>) -> Result<Vec<CameraFrame>, DatasetError> {
    let path = path.as_ref();
    parse_camera_csv(&read_text(path)?, path)
}

/// Formats camera frames as `data.csv` text (use [`CameraFrame::at`] for the EuRoC naming).
pub fn format_camera_csv(frames: &[CameraFrame], path: &Path) -> Result<String, DatasetError> {
    check_increasing_write(path, frames.iter().map(|f| f.t_ns))?;
    let mut s = String::with_capacity(48 * (frames.len() + 1));
    s.push_str(CAMERA_HEADER);
    s.push('\n');
    for (i, f) in frames.iter().enumerate() {
        if f.filename.is_empty() || f.filename.contains([',', '\n', '\r']) {
            return Err(invalid(
                path,
                format!(
                    "cannot write row {i}: file name `{}` is empty or holds `,` or a line break",
                    f.filename
                ),
            ));
        }
        let _ = writeln!(s, "{},{}", f.t_ns, f.filename);
    }
    Ok(s)
}

/// Writes a camera `data.csv` (creating parent folders).
pub fn write_camera_csv(
    path: impl AsRef<Path>,
    frames: &[CameraFrame],
) -> Result<(), DatasetError> {
    let path = path.as_ref();
    write_text(path, &format_camera_csv(frames, path)?)
}

// ---------------------------------------------------------------------------------------------
// Whole folders

/// Writes an EuRoC ASL `mav0` folder: `imu0/data.csv` (+ `sensor.yaml` when given),
/// `state_groundtruth_estimate0/data.csv` when there is ground truth, and `cam<i>/data.csv`
/// (+ `sensor.yaml`) per camera. Image files are not written.
pub fn write_euroc(mav0: impl AsRef<Path>, data: &EurocDataset) -> Result<(), DatasetError> {
    let mav0 = mav0.as_ref();
    write_imu_csv(mav0.join("imu0/data.csv"), &data.imu)?;
    if let Some(imu) = &data.imu_sensor {
        write_sensor_yaml(mav0.join("imu0/sensor.yaml"), &SensorYaml::Imu(imu.clone()))?;
    }
    if !data.groundtruth.is_empty() {
        write_groundtruth_csv(
            mav0.join("state_groundtruth_estimate0/data.csv"),
            &data.groundtruth,
        )?;
    }
    for (i, cam) in data.cameras.iter().enumerate() {
        let dir = mav0.join(format!("cam{i}"));
        write_camera_csv(dir.join("data.csv"), &cam.frames)?;
        if let Some(s) = &cam.sensor {
            write_sensor_yaml(dir.join("sensor.yaml"), &SensorYaml::Camera(s.clone()))?;
        }
    }
    Ok(())
}

fn expect_camera(path: PathBuf, s: SensorYaml) -> Result<CameraSensor, DatasetError> {
    match s {
        SensorYaml::Camera(c) => Ok(c),
        SensorYaml::Imu(_) => Err(invalid(
            &path,
            "expected `sensor_type: camera`, found `imu`",
        )),
    }
}

/// Reads an EuRoC ASL `mav0` folder: `imu0/data.csv` is required; `imu0/sensor.yaml`, the ground
/// truth and the camera folders `cam0`, `cam1`, ... (read in order until one is missing) are
/// optional. An IMU log or ground truth that is there but holds no data rows (0 bytes, or a
/// header only) is an error naming it, never taken for an absent one.
pub fn read_euroc(mav0: impl AsRef<Path>) -> Result<EurocDataset, DatasetError> {
    read_euroc_cameras(mav0, usize::MAX)
}

/// [`read_euroc`] reading at most `max_cameras` camera folders (`cam0` … ): the folders a run
/// does not use are not read, so a stray `cam2/` cannot stop a stereo run.
pub fn read_euroc_cameras(
    mav0: impl AsRef<Path>,
    max_cameras: usize,
) -> Result<EurocDataset, DatasetError> {
    let mav0 = mav0.as_ref();
    if !mav0.is_dir() {
        return Err(invalid(
            mav0,
            "not a folder (expected an EuRoC `mav0` folder)",
        ));
    }
    let marker = mav0.join(INCOMPLETE_MARKER);
    if marker.exists() {
        return Err(invalid(
            &marker,
            "an export into this folder did not finish (it was stopped, or is still running): its files may be partial or mixed with an older export's; export again",
        ));
    }
    let no_rows = |p: PathBuf, what: &str| {
        invalid(
            &p,
            format!("holds no {what} (0 bytes or a header only); remove it if there is none"),
        )
    };
    let imu_csv = mav0.join("imu0/data.csv");
    let imu = read_imu_csv(&imu_csv)?;
    if imu.is_empty() {
        return Err(no_rows(imu_csv, "IMU samples"));
    }
    let imu_yaml = mav0.join("imu0/sensor.yaml");
    let imu_sensor = if imu_yaml.is_file() {
        match read_sensor_yaml(&imu_yaml)? {
            SensorYaml::Imu(s) => Some(s),
            SensorYaml::Camera(_) => {
                return Err(invalid(
                    &imu_yaml,
                    "expected `sensor_type: imu`, found `camera`",
                ));
            }
        }
    } else {
        None
    };
    let gt_csv = mav0.join("state_groundtruth_estimate0/data.csv");
    let groundtruth = if gt_csv.exists() {
        if !gt_csv.is_file() {
            return Err(invalid(&gt_csv, "not a regular file"));
        }
        let rows = read_groundtruth_csv(&gt_csv)?;
        if rows.is_empty() {
            return Err(no_rows(gt_csv, "ground-truth rows"));
        }
        rows
    } else {
        Vec::new()
    };
    let mut cameras = Vec::new();
    for i in 0..max_cameras {
        let dir = mav0.join(format!("cam{i}"));
        if !dir.is_dir() {
            break;
        }
        // An empty frame list is legitimate here: `vio export` of feature-level cameras lists
        // no images (the run refuses it when it needs images).
        let frames = read_camera_csv(dir.join("data.csv"))?;
        let yaml = dir.join("sensor.yaml");
        let sensor = if yaml.is_file() {
            Some(expect_camera(yaml.clone(), read_sensor_yaml(&yaml)?)?)
        } else {
            None
        };
        cameras.push(EurocCamera { sensor, frames });
    }
    Ok(EurocDataset {
        imu,
        imu_sensor,
        groundtruth,
        cameras,
    })
}
