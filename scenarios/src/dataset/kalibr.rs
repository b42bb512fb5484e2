//! Kalibr calibration files as a scenario rig: `camchain-imucam.yaml` (every camera's model,
//! intrinsics, distortion, resolution and `T_cam_imu`) and `imu.yaml` (noise densities and
//! rate), turned into the scenario's `[[rig.cameras]]` and `[rig.imu]` tables.
//!
//! Models: `pinhole` + `radtan` → `pinhole_radtan`, `pinhole` + `equidistant` →
//! `kannala_brandt`, `omni` + `radtan` → `mei` (intrinsics `[xi, fu, fv, pu, pv]`), `ds` + `none`
//! → `double_sphere` (intrinsics `[xi, alpha, fu, fv, pu, pv]`). `T_cam_imu` maps IMU to camera
//! coordinates, so the rig's `T_b_c` is its inverse. `timeshift_cam_imu` is not used (set
//! `rig.time_offset_s` / `estimator.td_s` for it).

use estimator::geometry::Pose;
use estimator::imu::ImuNoise;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::{CameraSensor, ImuSensor};

use super::yaml::{Doc, Entry, list};

/// An error naming the Kalibr file, key and line.
#[derive(Clone, Debug, PartialEq)]
pub struct KalibrError {
    /// The file.
    pub file: String,
    /// Its key (`cam1.T_cam_imu`).
    pub key: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// What was wrong.
    pub message: String,
}

impl std::fmt::Display for KalibrError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        if !self.key.is_empty() {
            write!(f, ": key `{}`", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

/// Errors of `file`: `(key, line, message)` → [`KalibrError`].
fn located(file: &str) -> impl Fn(&str, Option<usize>, String) -> KalibrError + '_ {
    move |key, line, message| KalibrError {
        file: file.into(),
        key: key.into(),
        line,
        message,
    }
}

fn numbers(v: &str) -> Result<Vec<f64>, String> {
    list(v)?
        .iter()
        .map(|x| {
            x.parse::<f64>()
                .ok()
                .filter(|f| f.is_finite())
                .ok_or_else(|| format!("`{x}` is not a finite number"))
        })
        .collect()
}

/// The camchain key of a camera's exact translation `t_b_c` (m), beside `T_cam_imu` (written by
/// `vio export`; other readers ignore it).
pub const TRANSLATION_KEY: &str = "vio_T_b_c_translation_m";
/// The camchain key of a camera's rotation `R_b_c` as the quaternion `[qx, qy, qz, qw]` the rig
/// was given as, beside `T_cam_imu`.
pub const QUATERNION_KEY: &str = "vio_T_b_c_quaternion_xyzw";
/// How far the exact keys may lie from `T_cam_imu`'s inversion: translation (m), rotation (rad).
/// Rounding leaves them ~1e-16 apart; further means one was edited without the other.
const EXACT_AGREEMENT: f64 = 1e-9;

/// The inverse `(Rᵀ, −Rᵀ·t)` of the rigid transform `(R, t)`: `T_b_c` of Kalibr's `T_cam_imu`
/// (and back). The writer ([`super::kalibr_export`]) chooses the digits it writes so that this
/// very computation gives back the rig's own values.
pub(crate) fn invert_rigid(r: &Matrix3<f64>, t: &Vector3<f64>) -> (Matrix3<f64>, Vector3<f64>) {
    let r_inv = r.transpose();
    let t_inv = -(r_inv * t);
    (r_inv, t_inv)
}

/// `[[rig.cameras]]` tables (TOML text) for the cameras of a Kalibr camchain, each with
/// `pixel_sigma_px`.
pub fn cameras_toml(text: &str, file: &str, pixel_sigma_px: f64) -> Result<String, KalibrError> {
    let f = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut out = String::new();
    for c in read_cameras(text, file)? {
        let r = &c.r_b_c;
        out.push_str(&format!(
            "\n[[rig.cameras]]\nname = {}\nmodel = \"{}\"\nresolution = [{}]\nintrinsics = [{}]\ndistortion = [{}]\n",
            toml::Value::String(c.name.clone()),
            c.model,
            c.resolution.join(", "),
            f(&c.intrinsics),
            f(&c.distortion)
        ));
        if let Some(x) = c.xi {
            out.push_str(&format!("xi = {x:?}\n"));
        }
        if let Some(a) = c.alpha {
            out.push_str(&format!("alpha = {a:?}\n"));
        }
        let rotation = match c.quaternion_xyzw {
            Some(q) => format!("quaternion_xyzw = [{}]", f(&q)),
            None => format!(
                "rotation = [[{}], [{}], [{}]]",
                f(&[r[(0, 0)], r[(0, 1)], r[(0, 2)]]),
                f(&[r[(1, 0)], r[(1, 1)], r[(1, 2)]]),
                f(&[r[(2, 0)], r[(2, 1)], r[(2, 2)]]),
            ),
        };
        out.push_str(&format!(
            "T_b_c = {{ translation_m = [{}], {rotation} }}\npixel_sigma_px = {pixel_sigma_px:?}\n",
            f(c.t_b_c.as_slice()),
        ));
    }
    Ok(out)
}

/// One camera of a camchain as read, in the scenario's terms.
pub(crate) struct CameraRead {
    /// The file's key (`cam0`).
    pub name: String,
    /// The scenario's model name (`pinhole_radtan`, `kannala_brandt`, `mei`, `double_sphere`).
    pub model: &'static str,
    /// `[fu, fv, pu, pv]`.
    pub intrinsics: Vec<f64>,
    /// Distortion coefficients.
    pub distortion: Vec<f64>,
    /// Mei's / double sphere's ξ.
    pub xi: Option<f64>,
    /// Double sphere's α.
    pub alpha: Option<f64>,
    /// `[width, height]` as written (whole numbers) or as the numbers they are.
    pub resolution: Vec<String>,
    /// `T_b_c = T_cam_imu⁻¹`.
    pub r_b_c: Matrix3<f64>,
    /// `T_b_c = T_cam_imu⁻¹`, or the exact translation ([`TRANSLATION_KEY`]).
    pub t_b_c: Vector3<f64>,
    /// The rotation as the quaternion `[qx, qy, qz, qw]` the rig was given as
    /// ([`QUATERNION_KEY`]).
    pub quaternion_xyzw: Option<[f64; 4]>,
    /// The line of its `resolution` key.
    pub resolution_line: usize,
}

/// Every camera of a camchain, checked (see [`cameras_toml`]).
pub(crate) fn read_cameras(text: &str, file: &str) -> Result<Vec<CameraRead>, KalibrError> {
    let err = located(file);
    let doc = Doc::parse(text).map_err(|(l, m)| err("", Some(l), m))?;
    let mut names: Vec<&str> = doc
        .entries
        .iter()
        .filter(|e| !e.key.contains('.'))
        .map(|e| e.key.as_str())
        .collect();
    names.retain(|n| n.starts_with("cam"));
    if names.is_empty() {
        return Err(err("", None, "no `cam0:` … entries".into()));
    }
    let mut out = Vec::new();
    for cam in names {
        let get = |k: &str| -> Result<&Entry, KalibrError> {
            let key = format!("{cam}.{k}");
            doc.get(&key)
                .ok_or_else(|| err(&key, None, format!("missing `{k}` for {cam}")))
        };
        let nums = |k: &str| -> Result<Vec<f64>, KalibrError> {
            let e = get(k)?;
            numbers(&e.value).map_err(|m| err(&e.key, Some(e.line), m))
        };
        let model = get("camera_model")?;
        let dist = get("distortion_model")?;
        let intr = nums("intrinsics")?;
        let coeffs = nums("distortion_coeffs").or_else(|e| {
            if dist.value.trim() == "none" {
                Ok(Vec::new())
            } else {
                Err(e)
            }
        })?;
        let res_entry = get("resolution")?;
        // Whole numbers are passed on as written (the scenario's checks then quote them, and
        // the error is pointed back here); others as the numbers they are.
        let res: Vec<String> = list(&res_entry.value)
            .map_err(|m| err(&res_entry.key, Some(res_entry.line), m))?
            .into_iter()
            .map(|x| {
                let whole = x
                    .trim_start_matches('-')
                    .chars()
                    .all(|c| c.is_ascii_digit())
                    && x.trim_start_matches('-').len() < 20
                    && !x.trim_start_matches('-').is_empty();
                match x.parse::<f64>() {
                    Ok(_) if whole => Ok(x),
                    Ok(v) if v.is_finite() => Ok(format!("{v:?}")),
                    _ => Err(err(
                        &res_entry.key,
                        Some(res_entry.line),
                        format!("`{x}` is not a finite number"),
                    )),
                }
            })
            .collect::<Result<_, _>>()?;
        let need = |n: usize, what: &str, e: &Entry| {
            if intr.len() == n {
                Ok(())
            } else {
                Err(err(
                    &format!("{cam}.intrinsics"),
                    Some(e.line),
                    format!("the {what} model needs {n} intrinsics, got {}", intr.len()),
                ))
            }
        };
        let (ours, intrinsics, xi, alpha) = match (model.value.trim(), dist.value.trim()) {
            ("pinhole", "radtan") => {
                need(4, "pinhole", model)?;
                ("pinhole_radtan", &intr[..], None, None)
            }
            ("pinhole", "equidistant") => {
                need(4, "pinhole", model)?;
                ("kannala_brandt", &intr[..], None, None)
            }
            ("omni", "radtan") => {
                need(5, "omni", model)?;
                ("mei", &intr[1..], Some(intr[0]), None)
            }
            ("ds", "none") => {
                need(6, "ds", model)?;
                ("double_sphere", &intr[2..], Some(intr[0]), Some(intr[1]))
            }
            (m, d) => {
                return Err(err(
                    &format!("{cam}.camera_model"),
                    Some(model.line),
                    format!(
                        "`{m}` with `{d}` distortion is not supported (pinhole/radtan, pinhole/equidistant, omni/radtan, ds/none)"
                    ),
                ));
            }
        };
        let t = get("T_cam_imu")?;
        let rows: Vec<Vec<f64>> = t
            .items
            .iter()
            .map(|(r, line)| numbers(r).map_err(|m| err(&t.key, Some(*line), m)))
            .collect::<Result<_, _>>()?;
        if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
            return Err(err(
                &t.key,
                Some(t.line),
                "expected a 4×4 matrix as four `- [a, b, c, d]` rows".into(),
            ));
        }
        // A rigid transform's last row is [0, 0, 0, 1]: anything else is not a camera pose
        // (a projective matrix, or rows out of order).
        if rows[3]
            .iter()
            .zip([0.0, 0.0, 0.0, 1.0])
            .any(|(a, b)| (a - b).abs() > 1e-9)
        {
            return Err(err(
                &t.key,
                Some(t.items[3].1),
                format!("its last row must be [0, 0, 0, 1], found {:?}", rows[3]),
            ));
        }
        let r_c_b = Matrix3::from_fn(|i, j| rows[i][j]);
        let t_c_b = Vector3::new(rows[0][3], rows[1][3], rows[2][3]);
        if (r_c_b.transpose() * r_c_b - Matrix3::identity()).amax() > 1e-6
            || (r_c_b.determinant() - 1.0).abs() > 1e-6
        {
            return Err(err(
                &t.key,
                Some(t.line),
                "its rotation is not a rotation matrix (to 1e-6)".into(),
            ));
        }
        let (r_b_c, mut t_b_c) = invert_rigid(&r_c_b, &t_c_b);
        let disagrees = |e: &Entry, by: String| {
            err(
                &e.key,
                Some(e.line),
                format!(
                    "disagrees with `T_cam_imu` by {by} (edit both, or delete the `vio_` keys)"
                ),
            )
        };
        if let Some(e) = doc.get(&format!("{cam}.{TRANSLATION_KEY}")) {
            let v = numbers(&e.value).map_err(|m| err(&e.key, Some(e.line), m))?;
            let [x, y, z] = v[..] else {
                return Err(err(
                    &e.key,
                    Some(e.line),
                    format!("expected 3 numbers, got {}", v.len()),
                ));
            };
            let exact = Vector3::new(x, y, z);
            let off = (exact - t_b_c).amax();
            if off > EXACT_AGREEMENT {
                return Err(disagrees(e, format!("{off:.3e} m")));
            }
            t_b_c = exact;
        }
        let mut quaternion_xyzw = None;
        if let Some(e) = doc.get(&format!("{cam}.{QUATERNION_KEY}")) {
            let v = numbers(&e.value).map_err(|m| err(&e.key, Some(e.line), m))?;
            let q = estimator::geometry::quat_from_xyzw_checked(&v).map_err(|m| {
                err(
                    &e.key,
                    Some(e.line),
                    format!("expected a unit quaternion [qx, qy, qz, qw]: {m}"),
                )
            })?;
            let r = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r_b_c));
            let angle = q.angle_to(&r);
            if angle > EXACT_AGREEMENT {
                return Err(disagrees(e, format!("{angle:.3e} rad")));
            }
            quaternion_xyzw = Some([v[0], v[1], v[2], v[3]]);
        }
        out.push(CameraRead {
            name: cam.to_string(),
            model: ours,
            intrinsics: intrinsics.to_vec(),
            distortion: coeffs,
            xi,
            alpha,
            resolution: res,
            r_b_c,
            t_b_c,
            quaternion_xyzw,
            resolution_line: res_entry.line,
        });
    }
    Ok(out)
}

/// The `[rig.imu]` table (TOML text) of a Kalibr `imu.yaml` (keys at the top level or under
/// `imu0:`).
pub fn imu_toml(text: &str, file: &str) -> Result<String, KalibrError> {
    let mut out = String::from("\n[rig.imu]\n");
    for (ours, v) in read_imu(text, file)? {
        out.push_str(&format!("{ours} = {v:?}\n"));
    }
    Ok(out)
}

/// The IMU values of an `imu.yaml` under the scenario's names, in the order `rate_hz`,
/// `gyroscope_noise_density`, `accelerometer_noise_density`, `gyroscope_random_walk`,
/// `accelerometer_random_walk`.
fn read_imu(text: &str, file: &str) -> Result<[(&'static str, f64); 5], KalibrError> {
    let err = located(file);
    let doc = Doc::parse(text).map_err(|(l, m)| err("", Some(l), m))?;
    let prefix = if doc.get("imu0").is_some() {
        "imu0."
    } else {
        ""
    };
    let mut out = [("", 0.0); 5];
    for (slot, (kalibr, ours)) in out.iter_mut().zip([
        ("update_rate", "rate_hz"),
        ("gyroscope_noise_density", "gyroscope_noise_density"),
        ("accelerometer_noise_density", "accelerometer_noise_density"),
        ("gyroscope_random_walk", "gyroscope_random_walk"),
        ("accelerometer_random_walk", "accelerometer_random_walk"),
    ]) {
        let key = format!("{prefix}{kalibr}");
        let e = doc
            .get(&key)
            .ok_or_else(|| err(&key, None, format!("missing `{kalibr}`")))?;
        let v: f64 = e
            .value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite())
            .ok_or_else(|| err(&key, Some(e.line), format!("`{}` is not a number", e.value)))?;
        *slot = (ours, v);
    }
    Ok(out)
}

/// The IMU of an `imu.yaml` as a `sensor.yaml` would give it (body = IMU frame): what a recorded
/// run needs of it. Densities must be positive.
pub fn imu_sensor(text: &str, file: &str) -> Result<ImuSensor, KalibrError> {
    let [rate, gn, an, gw, aw] = read_imu(text, file)?.map(|(_, v)| v);
    for (key, v) in [
        ("update_rate", rate),
        ("gyroscope_noise_density", gn),
        ("accelerometer_noise_density", an),
        ("gyroscope_random_walk", gw),
        ("accelerometer_random_walk", aw),
    ] {
        if v <= 0.0 {
            return Err(located(file)(
                key,
                None,
                format!("{v}: expected a positive value"),
            ));
        }
    }
    Ok(ImuSensor {
        comment: format!("Kalibr {file}"),
        t_bs: Pose::identity(),
        rate_hz: rate,
        noise: ImuNoise {
            gyroscope_noise_density: gn,
            accelerometer_noise_density: an,
            gyroscope_random_walk: gw,
            accelerometer_random_walk: aw,
        },
    })
}

/// The cameras of a camchain as `sensor.yaml` calibrations (pinhole cameras with radial-tangential
/// or equidistant distortion; `T_BS` = `T_cam_imu⁻¹`, its rotation made a quaternion as a scenario's
/// rotation rows are): what a recorded run needs of them. `rate_hz` is 0 (Kalibr does not say).
pub fn camera_sensors(text: &str, file: &str) -> Result<Vec<CameraSensor>, KalibrError> {
    let err = located(file);
    read_cameras(text, file)?
        .into_iter()
        .map(|c| {
            let distortion_model = match c.model {
                "pinhole_radtan" => "radial-tangential",
                "kannala_brandt" => "equidistant",
                other => {
                    return Err(err(
                        &format!("{}.camera_model", c.name),
                        None,
                        format!("a {other} camera: recorded runs take pinhole cameras (radtan or equidistant)"),
                    ));
                }
            };
            let mut resolution = [0u32; 2];
            for (slot, v) in resolution.iter_mut().zip(&c.resolution) {
                *slot = v.parse().ok().filter(|&r| r > 0).ok_or_else(|| {
                    err(
                        &format!("{}.resolution", c.name),
                        Some(c.resolution_line),
                        format!("`{v}` is not a positive whole number of pixels"),
                    )
                })?;
            }
            // The quaternion was checked when read; the same rule as a scenario's rig.
            let q = match &c.quaternion_xyzw {
                Some(q) => estimator::geometry::quat_from_xyzw_as_written(q),
                None => UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&c.r_b_c)),
            };
            Ok(CameraSensor {
                comment: format!("Kalibr {file} {}", c.name),
                t_bs: Pose::new(q, c.t_b_c),
                rate_hz: 0.0,
                resolution,
                camera_model: "pinhole".into(),
                intrinsics: c.intrinsics,
                distortion_model: distortion_model.into(),
                distortion_coefficients: c.distortion,
            })
        })
        .collect()
}

/// Where a rig key the Kalibr files gave comes from: the Kalibr file's key (`cam1.resolution`,
/// `imu0.update_rate`), its line and its value as written. `camchain` and `imu` are the two
/// files' texts; `key` a scenario key such as `rig.cameras[1].resolution[0]` or
/// `rig.imu.rate_hz`. `None` for a key the files did not give.
pub fn locate(camchain: &str, imu: Option<&str>, key: &str) -> Option<(String, usize, String)> {
    let found = |text: &str, k: String| {
        let doc = Doc::parse(text).ok()?;
        let e = doc.get(&k)?;
        Some((e.key.clone(), e.line, e.value.trim().to_string()))
    };
    if let Some(rest) = key.strip_prefix("rig.cameras[") {
        let (index, field) = rest.split_once(']')?;
        let index: usize = index.parse().ok()?;
        let field = field.trim_start_matches('.');
        let field = field.split(['.', '[']).next().unwrap_or("");
        let kalibr = match field {
            "resolution" => "resolution",
            "intrinsics" | "xi" | "alpha" => "intrinsics",
            "distortion" => "distortion_coeffs",
            "T_b_c" => "T_cam_imu",
            "model" | "" => "camera_model",
            _ => return None,
        };
        let doc = Doc::parse(camchain).ok()?;
        let cam = doc
            .entries
            .iter()
            .filter(|e| !e.key.contains('.') && e.key.starts_with("cam"))
            .nth(index)?
            .key
            .clone();
        return found(camchain, format!("{cam}.{kalibr}"));
    }
    let field = key.strip_prefix("rig.imu.")?;
    let kalibr = match field {
        "rate_hz" => "update_rate",
        f @ ("gyroscope_noise_density"
        | "accelerometer_noise_density"
        | "gyroscope_random_walk"
        | "accelerometer_random_walk") => f,
        _ => return None,
    };
    let text = imu?;
    let doc = Doc::parse(text).ok()?;
    let prefix = if doc.get("imu0").is_some() {
        "imu0."
    } else {
        ""
    };
    found(text, format!("{prefix}{kalibr}"))
}
