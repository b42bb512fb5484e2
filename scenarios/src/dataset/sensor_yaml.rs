//! EuRoC `sensor.yaml` files: the camera's (`T_BS`, rate, resolution, intrinsics, distortion)
//! and the IMU's (`T_BS`, rate, Kalibr noise values), read with file, line and key in every
//! error and written so that write → read → write is byte-identical.

use std::fmt::Write as _;
use std::path::Path;

use estimator::camera::{Camera, KannalaBrandt, PinholeRadtan};
use estimator::geometry::Pose;
use estimator::imu::ImuNoise;
use nalgebra::{Matrix3, Matrix4, Rotation3, UnitQuaternion, Vector3};
use sim::plausible::{self, Plausible};

use super::yaml::{Doc, list, scalar};
use super::{
    DatasetError, RowResult, check_finite, fmt_f64, invalid, parse_error, parse_f64, read_text,
    write_text,
};

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

impl CameraSensor {
    /// The estimator's camera (`pinhole` with `radial-tangential` or `equidistant`
    /// distortion); the error says which value is wrong, for the caller to name the file.
    pub fn camera(&self) -> Result<Camera, String> {
        let [w, h] = self.resolution;
        let i = &self.intrinsics;
        let d = &self.distortion_coefficients;
        if self.camera_model != "pinhole" || i.len() != 4 {
            return Err(format!(
                "camera_model `{}` with {} intrinsics: expected `pinhole` [fu, fv, cu, cv]",
                self.camera_model,
                i.len()
            ));
        }
        if d.len() != 4 {
            return Err(format!(
                "distortion_coefficients: expected 4, got {}",
                d.len()
            ));
        }
        let bad = |e: estimator::camera::CameraError| format!("intrinsics: {e}");
        Ok(match self.distortion_model.as_str() {
            "radial-tangential" | "radtan" => Camera::PinholeRadtan(
                PinholeRadtan::new(w, h, i[0], i[1], i[2], i[3], d[0], d[1], d[2], d[3])
                    .map_err(bad)?,
            ),
            "equidistant" => Camera::KannalaBrandt(
                KannalaBrandt::new(w, h, i[0], i[1], i[2], i[3], d[0], d[1], d[2], d[3])
                    .map_err(bad)?,
            ),
            other => {
                return Err(format!(
                    "distortion_model `{other}`: expected `radial-tangential` or `equidistant`"
                ));
            }
        })
    }
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

    /// The value at `key` in its physical range ([`sim::plausible`]).
    fn plausible(&self, key: &str, range: &Plausible) -> Result<f64, DatasetError> {
        let v = self.positive(key)?;
        range.check(v).map_err(|m| self.err(key, m))?;
        Ok(v)
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
    plausible::CAMERA_OFFSET_M
        .check(t_bs.p.norm())
        .map_err(|m| {
            r.err(
                "T_BS.data",
                format!("the sensor {} m from the body origin: {m}", t_bs.p.norm()),
            )
        })?;
    let rate_hz = r.positive("rate_hz")?;
    match sensor_type.as_str() {
        "camera" => {
            plausible::CAMERA_RATE_HZ
                .check(rate_hz)
                .map_err(|m| r.err("rate_hz", m))?;
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
            let intrinsics = r.f64_list("intrinsics")?;
            let longer = res[0].max(res[1]);
            for f in intrinsics.iter().take(2) {
                plausible::check_focal_length(*f, longer).map_err(|m| r.err("intrinsics", m))?;
            }
            let distortion_coefficients = r.f64_list("distortion_coefficients")?;
            for d in &distortion_coefficients {
                plausible::DISTORTION_COEFFICIENT
                    .check(*d)
                    .map_err(|m| r.err("distortion_coefficients", m))?;
            }
            Ok(SensorYaml::Camera(CameraSensor {
                comment,
                t_bs,
                rate_hz,
                resolution: [res[0] as u32, res[1] as u32],
                camera_model: r.string("camera_model")?,
                intrinsics,
                distortion_model: r.string("distortion_model")?,
                distortion_coefficients,
            }))
        }
        "imu" => {
            let noise = ImuNoise {
                gyroscope_noise_density: r.plausible(
                    "gyroscope_noise_density",
                    &plausible::GYROSCOPE_NOISE_DENSITY,
                )?,
                accelerometer_noise_density: r.plausible(
                    "accelerometer_noise_density",
                    &plausible::ACCELEROMETER_NOISE_DENSITY,
                )?,
                gyroscope_random_walk: r
                    .plausible("gyroscope_random_walk", &plausible::GYROSCOPE_RANDOM_WALK)?,
                accelerometer_random_walk: r.plausible(
                    "accelerometer_random_walk",
                    &plausible::ACCELEROMETER_RANDOM_WALK,
                )?,
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
