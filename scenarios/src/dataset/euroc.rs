//! The EuRoC ASL folder layout (`mav0/...`): IMU and ground-truth CSV files, camera frame lists
//! and `sensor.yaml` files.
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

use estimator::geometry::Pose;
use estimator::imu::{ImuNoise, ImuSample};
use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion, Vector3};

use super::yaml::{Doc, list, scalar};
use super::{
    DatasetError, RowResult, check_finite, data_lines, fmt_f64, invalid, parse_error, parse_f64,
    parse_i64, read_text, unit_quaternion, write_text,
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

/// A camera `sensor.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraSensor {
    /// Free-text description.
    pub comment: String,
    /// Extrinsic `T_B_S` (sensor to body).
    pub t_bs: Pose,
    /// Frame rate (Hz).
    pub rate_hz: f64,
    /// Image width and height (px).
    pub resolution: [u32; 2],
    /// Projection model, e.g. `pinhole`.
    pub camera_model: String,
    /// Model parameters, for `pinhole` `[fu, fv, cu, cv]`.
    pub intrinsics: Vec<f64>,
    /// Distortion model, e.g. `radial-tangential` or `equidistant`.
    pub distortion_model: String,
    /// Distortion coefficients, for `radial-tangential` `[k1, k2, p1, p2]`.
    pub distortion_coefficients: Vec<f64>,
}

/// An IMU `sensor.yaml` with the Kalibr noise values.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuSensor {
    /// Free-text description.
    pub comment: String,
    /// Extrinsic `T_B_S` (sensor to body; identity when the body frame is the IMU frame).
    pub t_bs: Pose,
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// Kalibr continuous-time noise densities.
    pub noise: ImuNoise,
}

/// A `sensor.yaml` file of a supported sensor type.
#[derive(Clone, Debug, PartialEq)]
pub enum SensorYaml {
    /// `sensor_type: camera`.
    Camera(CameraSensor),
    /// `sensor_type: imu`.
    Imu(ImuSensor),
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

/// Parses `imu0/data.csv` text; `path` names the source in errors.
pub fn parse_imu_csv(text: &str, path: &Path) -> Result<Vec<ImuSample>, DatasetError> {
    let mut out: Vec<ImuSample> = Vec::new();
    for (line, content) in data_lines(text) {
        let row = (|| {
            let f = split_csv(content, 7, "timestamp, 3 gyro, 3 accel")?;
            let t = parse_i64(f[0], IMU_NAMES[0])?;
            let v: [f64; 6] = parse_numbers(&f[1..], &IMU_NAMES[1..])?;
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
            let t = parse_i64(f[0], GT_NAMES[0])?;
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
            let t = parse_i64(f[0], "timestamp")?;
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
// sensor.yaml

/// Formats a YAML float that always reads back as a float (`1.0`, not `1`).
fn yaml_f64(v: f64) -> String {
    let s = fmt_f64(v);
    if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    }
}

fn yaml_list(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|&v| yaml_f64(v)).collect();
    format!("[{}]", items.join(", "))
}

fn yaml_string(s: &str) -> String {
    // Quote when the plain scalar would be misread.
    let plain = !s.is_empty()
        && !s.contains([':', '#', '\'', '"', '[', ']', '{', '}', ',', '\n'])
        && s.trim() == s;
    if plain {
        s.to_string()
    } else {
        format!(
            "\"{}\"",
            s.replace('\\', "\\\\")
                .replace('"', "\\\"")
                .replace('\n', " ")
        )
    }
}

fn t_bs_block(t: &Pose) -> String {
    let r = t.q.to_rotation_matrix();
    let m = r.matrix();
    let rows: Vec<String> = (0..4)
        .map(|i| {
            let row: Vec<String> = if i < 3 {
                vec![m[(i, 0)], m[(i, 1)], m[(i, 2)], t.p[i]]
            } else {
                vec![0.0, 0.0, 0.0, 1.0]
            }
            .into_iter()
            .map(yaml_f64)
            .collect();
            row.join(", ")
        })
        .collect();
    format!(
        "# Sensor extrinsics wrt. the body-frame.\nT_BS:\n  cols: 4\n  rows: 4\n  data: [{}]\n",
        rows.join(",\n         ")
    )
}

/// Formats a `sensor.yaml` in the EuRoC layout.
pub fn format_sensor_yaml(sensor: &SensorYaml, path: &Path) -> Result<String, DatasetError> {
    let mut s = String::new();
    match sensor {
        SensorYaml::Camera(c) => {
            let mut nums = vec![c.rate_hz];
            nums.extend(c.t_bs.to_array());
            nums.extend(&c.intrinsics);
            nums.extend(&c.distortion_coefficients);
            check_finite(path, 0, &nums)?;
            s.push_str("# General sensor definitions.\nsensor_type: camera\n");
            let _ = writeln!(s, "comment: {}\n", yaml_string(&c.comment));
            s.push_str(&t_bs_block(&c.t_bs));
            s.push_str("\n# Camera specific definitions.\n");
            let _ = writeln!(s, "rate_hz: {}", fmt_f64(c.rate_hz));
            let _ = writeln!(s, "resolution: [{}, {}]", c.resolution[0], c.resolution[1]);
            let _ = writeln!(s, "camera_model: {}", yaml_string(&c.camera_model));
            let note = if c.camera_model == "pinhole" && c.intrinsics.len() == 4 {
                " #fu, fv, cu, cv"
            } else {
                ""
            };
            let _ = writeln!(s, "intrinsics: {}{note}", yaml_list(&c.intrinsics));
            let _ = writeln!(s, "distortion_model: {}", yaml_string(&c.distortion_model));
            let _ = writeln!(
                s,
                "distortion_coefficients: {}",
                yaml_list(&c.distortion_coefficients)
            );
        }
        SensorYaml::Imu(m) => {
            let n = &m.noise;
            let mut nums = vec![
                m.rate_hz,
                n.gyroscope_noise_density,
                n.gyroscope_random_walk,
                n.accelerometer_noise_density,
                n.accelerometer_random_walk,
            ];
            nums.extend(m.t_bs.to_array());
            check_finite(path, 0, &nums)?;
            s.push_str("#Default imu sensor yaml file\nsensor_type: imu\n");
            let _ = writeln!(s, "comment: {}\n", yaml_string(&m.comment));
            s.push_str(&t_bs_block(&m.t_bs));
            let _ = writeln!(s, "rate_hz: {}", fmt_f64(m.rate_hz));
            s.push_str("\n# inertial sensor noise model parameters (static)\n");
            let _ = writeln!(
                s,
                "gyroscope_noise_density: {}     # [ rad / s / sqrt(Hz) ]   ( gyro \"white noise\" )",
                yaml_f64(n.gyroscope_noise_density)
            );
            let _ = writeln!(
                s,
                "gyroscope_random_walk: {}       # [ rad / s^2 / sqrt(Hz) ] ( gyro bias diffusion )",
                yaml_f64(n.gyroscope_random_walk)
            );
            let _ = writeln!(
                s,
                "accelerometer_noise_density: {}  # [ m / s^2 / sqrt(Hz) ]  ( accel \"white noise\" )",
                yaml_f64(n.accelerometer_noise_density)
            );
            let _ = writeln!(
                s,
                "accelerometer_random_walk: {}    # [ m / s^3 / sqrt(Hz) ].  ( accel bias diffusion )",
                yaml_f64(n.accelerometer_random_walk)
            );
        }
    }
    Ok(s)
}

/// Writes a `sensor.yaml` (creating parent folders).
pub fn write_sensor_yaml(path: impl AsRef<Path>, sensor: &SensorYaml) -> Result<(), DatasetError> {
    let path = path.as_ref();
    write_text(path, &format_sensor_yaml(sensor, path)?)
}

struct YamlReader<'a> {
    doc: Doc,
    path: &'a Path,
}

impl YamlReader<'_> {
    fn entry(&self, key: &str) -> Result<&super::yaml::Entry, DatasetError> {
        self.doc
            .get(key)
            .ok_or_else(|| invalid(self.path, format!("missing key `{key}`")))
    }

    fn err(&self, key: &str, m: String) -> DatasetError {
        let line = self.doc.get(key).map_or(0, |e| e.line);
        parse_error(self.path, line, format!("`{key}`: {m}"))
    }

    fn string(&self, key: &str) -> Result<String, DatasetError> {
        Ok(scalar(&self.entry(key)?.value))
    }

    fn f64(&self, key: &str) -> Result<f64, DatasetError> {
        let v = scalar(&self.entry(key)?.value);
        parse_f64(&v, "value").map_err(|m| self.err(key, m))
    }

    fn positive(&self, key: &str) -> Result<f64, DatasetError> {
        let v = self.f64(key)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(key, format!("must be > 0, got {v}")))
        }
    }

    fn f64_list(&self, key: &str) -> Result<Vec<f64>, DatasetError> {
        let items = list(&self.entry(key)?.value).map_err(|m| self.err(key, m))?;
        items
            .iter()
            .map(|s| parse_f64(s, "list item"))
            .collect::<RowResult<Vec<f64>>>()
            .map_err(|m| self.err(key, m))
    }

    fn t_bs(&self) -> Result<Pose, DatasetError> {
        for dim in ["T_BS.rows", "T_BS.cols"] {
            if self.doc.get(dim).is_some() && self.f64(dim)? != 4.0 {
                return Err(self.err(dim, "must be 4".into()));
            }
        }
        let key = "T_BS.data";
        let d = self.f64_list(key)?;
        if d.len() != 16 {
            return Err(self.err(
                key,
                format!("expected 16 values (4×4 row-major), found {}", d.len()),
            ));
        }
        let m = Matrix4::from_row_slice(&d);
        let bottom = [m[(3, 0)], m[(3, 1)], m[(3, 2)], m[(3, 3)]];
        if bottom
            .iter()
            .zip([0.0, 0.0, 0.0, 1.0])
            .any(|(a, b)| (a - b).abs() > 1e-9)
        {
            return Err(self.err(
                key,
                format!("last row must be [0, 0, 0, 1], found {bottom:?}"),
            ));
        }
        let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
        let orth = (r.transpose() * r - Matrix3::identity()).abs().max();
        if orth > 1e-6 || r.determinant() <= 0.0 {
            return Err(self.err(
                key,
                format!(
                    "rotation part is not a rotation (|RᵀR − I|max = {orth:.3e}, det = {:.6})",
                    r.determinant()
                ),
            ));
        }
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&r));
        Ok(Pose::new(q, Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)])))
    }
}

/// Parses a `sensor.yaml` (camera or IMU); `path` names the source in errors.
pub fn parse_sensor_yaml(text: &str, path: &Path) -> Result<SensorYaml, DatasetError> {
    let doc = Doc::parse(text).map_err(|(line, m)| parse_error(path, line, m))?;
    let r = YamlReader { doc, path };
    let sensor_type = r.string("sensor_type")?;
    let comment = match r.doc.get("comment") {
        Some(e) => scalar(&e.value),
        None => String::new(),
    };
    let t_bs = r.t_bs()?;
    let rate_hz = r.positive("rate_hz")?;
    match sensor_type.as_str() {
        "camera" => {
            let res = r.f64_list("resolution")?;
            let valid = res.len() == 2
                && res
                    .iter()
                    .all(|&v| v >= 1.0 && v.fract() == 0.0 && v <= u32::MAX as f64);
            if !valid {
                return Err(r.err(
                    "resolution",
                    format!("expected [width, height] in pixels, found {res:?}"),
                ));
            }
            Ok(SensorYaml::Camera(CameraSensor {
                comment,
                t_bs,
                rate_hz,
                resolution: [res[0] as u32, res[1] as u32],
                camera_model: r.string("camera_model")?,
                intrinsics: r.f64_list("intrinsics")?,
                distortion_model: r.string("distortion_model")?,
                distortion_coefficients: r.f64_list("distortion_coefficients")?,
            }))
        }
        "imu" => {
            let noise = ImuNoise {
                gyroscope_noise_density: r.positive("gyroscope_noise_density")?,
                accelerometer_noise_density: r.positive("accelerometer_noise_density")?,
                gyroscope_random_walk: r.positive("gyroscope_random_walk")?,
                accelerometer_random_walk: r.positive("accelerometer_random_walk")?,
            };
            Ok(SensorYaml::Imu(ImuSensor {
                comment,
                t_bs,
                rate_hz,
                noise,
            }))
        }
        other => Err(r.err(
            "sensor_type",
            format!("unsupported sensor type `{other}` (expected `camera` or `imu`)"),
        )),
    }
}

/// Reads a `sensor.yaml`.
pub fn read_sensor_yaml(path: impl AsRef<Path>) -> Result<SensorYaml, DatasetError> {
    let path = path.as_ref();
    parse_sensor_yaml(&read_text(path)?, path)
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
