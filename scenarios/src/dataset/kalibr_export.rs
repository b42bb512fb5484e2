//! Kalibr calibration files written from a rig: `camchain-imucam.yaml` (each camera's model,
//! intrinsics, distortion, resolution, `T_cam_imu`, `timeshift_cam_imu`, and `T_cn_cnm1` from
//! the second camera on) and `imu.yaml` (noise densities, random walks, rate), as Kalibr writes
//! them and as OpenVINS-style estimators read them.
//!
//! Beside Kalibr's keys, each camera carries documented extra keys that other readers ignore:
//! the rig's exact `T_b_c` (`vio_T_b_c_*`), the pixel σ the estimator is told
//! (`vio_pixel_sigma_px`), and a rolling shutter's readout and direction
//! (`vio_rolling_shutter_readout_s`, `vio_rolling_shutter_direction`, beside Kalibr's own
//! `line_delay_nanoseconds`). `timeshift_cam_imu` follows Kalibr: `t_imu = t_cam + shift`; it is the
//! scenario's `rig.time_offset_s` (a frame taken at IMU time `t` is stamped `t − offset`, so
//! with a positive offset the first camera stamps, in `features.csv` and `cam<i>/data.csv`, can
//! be negative).
//!
//! The round trip through [`super::kalibr`] is exact: every number is written in its shortest
//! round-trip form (with a decimal point and a signed exponent, so YAML 1.1 readers such as
//! PyYAML take it as a float), Kalibr's `T_cam_imu` rotation is the transpose of the rig's (exact),
//! and its translation is chosen among the neighbours of `−Rᵀ·t` (a few units in the last place)
//! so that the reader's inversion gives back the rig's own translation: exactly for axis-aligned
//! cameras and for rigs read from Kalibr files, to a few units in the last place otherwise.

use estimator::imu::ImuNoise;
use nalgebra::{Matrix3, Vector3};

use super::kalibr::{QUATERNION_KEY, TRANSLATION_KEY, invert_rigid};

/// The extra key of a camera's pixel noise σ (px): what the estimator is told.
pub const PIXEL_SIGMA_KEY: &str = "vio_pixel_sigma_px";
/// The extra key of a rolling shutter's readout (s): first row to one past the last.
pub const READOUT_KEY: &str = "vio_rolling_shutter_readout_s";
/// The extra key of a rolling shutter's direction (`top_to_bottom`, `bottom_to_top`).
pub const DIRECTION_KEY: &str = "vio_rolling_shutter_direction";

/// One camera of a Kalibr camchain.
#[derive(Clone, Debug, PartialEq)]
pub struct KalibrCamera {
    /// Its key in the file (`cam0`, …).
    pub name: String,
    /// `pinhole`, `omni` or `ds`.
    pub camera_model: String,
    /// In Kalibr's order (`[fu, fv, pu, pv]`, omni `[xi, fu, fv, pu, pv]`, ds
    /// `[xi, alpha, fu, fv, pu, pv]`).
    pub intrinsics: Vec<f64>,
    /// `radtan`, `equidistant` or `none`.
    pub distortion_model: String,
    /// The distortion coefficients.
    pub distortion_coeffs: Vec<f64>,
    /// `[width, height]` (px).
    pub resolution: [u32; 2],
    /// The camera's rotation in the body (IMU) frame, `R_b_c`.
    pub r_b_c: Matrix3<f64>,
    /// The camera's position in the body frame (m), `t_b_c`.
    pub t_b_c: Vector3<f64>,
    /// The rig's rotation `R_b_c` as the quaternion `[qx, qy, qz, qw]` it was given as, when it
    /// was given as one (a matrix of doubles cannot carry a quaternion bit for bit).
    pub quaternion_xyzw: Option<[f64; 4]>,
    /// The image topic of the recording (`/cam0/image_raw`).
    pub rostopic: String,
    /// `t_imu = t_cam + timeshift_cam_imu` (s).
    pub timeshift_cam_imu: f64,
    /// A rolling shutter's time from one row to the next (ns; Kalibr's rolling-shutter key
    /// `line_delay_nanoseconds`), its readout (s) and which row is read first (`top_to_bottom`,
    /// `bottom_to_top`); `None`: a global shutter.
    pub rolling_shutter: Option<(f64, f64, &'static str)>,
    /// The pixel noise σ (px) the estimator is told, when known.
    pub pixel_sigma_px: Option<f64>,
}

/// The IMU of a Kalibr `imu.yaml`.
#[derive(Clone, Debug, PartialEq)]
pub struct KalibrImu {
    /// Noise densities and random walks (continuous time).
    pub noise: ImuNoise,
    /// Sample rate (Hz).
    pub rate_hz: f64,
    /// The IMU topic of the recording (`/imu0`).
    pub rostopic: String,
}

/// A number as YAML 1.1 and 1.2 readers both take it for the exact `f64`: the shortest
/// round-trip digits, with a decimal point before any exponent and the exponent signed
/// (`2.0e-5`, `1.0e+20`).
pub fn yaml_f64(v: f64) -> String {
    let s = format!("{v:?}");
    match s.split_once('e') {
        None => s,
        Some((mantissa, exp)) => {
            let mantissa = if mantissa.contains('.') {
                mantissa.to_string()
            } else {
                format!("{mantissa}.0")
            };
            let exp = if exp.starts_with('-') {
                exp.to_string()
            } else {
                format!("+{exp}")
            };
            format!("{mantissa}e{exp}")
        }
    }
}

fn yaml_list(v: &[f64]) -> String {
    let items: Vec<String> = v.iter().map(|x| yaml_f64(*x)).collect();
    format!("[{}]", items.join(", "))
}

/// How far [`camera_from_imu`] looks on each axis (representable steps; its documentation says
/// 8).
const STEPS: u32 = 8;

/// The values within [`STEPS`] representable steps of `x` (and `-x` when `x` is a zero), with
/// their distance in steps, nearest first.
fn neighbours(x: f64) -> Vec<(f64, u32)> {
    let mut out = vec![(x, 0)];
    if x == 0.0 {
        out.push((-x, 0));
    }
    let (mut up, mut down) = (x, x);
    for k in 1..=STEPS {
        up = up.next_up();
        down = down.next_down();
        out.push((up, k));
        out.push((down, k));
    }
    out
}

/// Kalibr's `T_cam_imu` for a camera at `(r_b_c, t_b_c)`: the rotation transposed, and of the
/// translations within 8 units in the last place of `−R⁻¹·t` per axis, the nearest from which
/// the Kalibr reader's inversion `−R·t` gives back `t_b_c` exactly (a zero's sign aside);
/// `−R⁻¹·t` itself when none does (the inversion is then off by rounding only).
pub fn camera_from_imu(r_b_c: &Matrix3<f64>, t_b_c: &Vector3<f64>) -> (Matrix3<f64>, Vector3<f64>) {
    let r_c_b = r_b_c.transpose();
    // The reader computes t_b_c = −R_b_c·t_c_b with the written rotation, which a file's rounded
    // digits leave short of orthonormal (1e-12 for Kalibr's): solve with that very matrix.
    let t_c_b = -(r_b_c.try_inverse().unwrap_or(r_c_b) * t_b_c);
    let (xs, ys, zs) = (
        neighbours(t_c_b.x),
        neighbours(t_c_b.y),
        neighbours(t_c_b.z),
    );
    let mut candidates: Vec<(u32, Vector3<f64>)> = Vec::new();
    for &(x, a) in &xs {
        for &(y, b) in &ys {
            for &(z, c) in &zs {
                candidates.push((a + b + c, Vector3::new(x, y, z)));
            }
        }
    }
    // Stable: among equally near candidates, the order above (the plain values first).
    candidates.sort_by_key(|(cost, _)| *cost);
    candidates
        .into_iter()
        .map(|(_, t)| t)
        .find(|t| invert_rigid(&r_c_b, t).1 == *t_b_c)
        .map_or((r_c_b, t_c_b), |t| (r_c_b, t))
}

fn write_matrix(out: &mut String, key: &str, r: &Matrix3<f64>, t: &Vector3<f64>) {
    out.push_str(&format!("  {key}:\n"));
    for i in 0..3 {
        out.push_str(&format!(
            "  - {}\n",
            yaml_list(&[r[(i, 0)], r[(i, 1)], r[(i, 2)], t[i]])
        ));
    }
    out.push_str("  - [0.0, 0.0, 0.0, 1.0]\n");
}

/// `camchain-imucam.yaml` for `cameras` (in order: `cam0`, `cam1`, …); `header` is written as
/// comment lines first.
pub fn format_camchain(cameras: &[KalibrCamera], header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        out.push_str(&format!("# {line}\n"));
    }
    let mut previous: Option<(Matrix3<f64>, Vector3<f64>)> = None;
    for (i, c) in cameras.iter().enumerate() {
        let (r_c_b, t_c_b) = camera_from_imu(&c.r_b_c, &c.t_b_c);
        out.push_str(&format!("{}:\n", c.name));
        write_matrix(&mut out, "T_cam_imu", &r_c_b, &t_c_b);
        if let Some((r_p_b, t_p_b)) = previous {
            // T_cn_cnm1 = T_cn_imu · T_imu_cnm1 (information: readers use T_cam_imu).
            let (r_b_p, t_b_p) = invert_rigid(&r_p_b, &t_p_b);
            let r = r_c_b * r_b_p;
            let t = r_c_b * t_b_p + t_c_b;
            write_matrix(&mut out, "T_cn_cnm1", &r, &t);
        }
        let overlaps: Vec<String> = (0..cameras.len())
            .filter(|&j| j != i)
            .map(|j| j.to_string())
            .collect();
        out.push_str(&format!("  cam_overlaps: [{}]\n", overlaps.join(", ")));
        out.push_str(&format!("  camera_model: {}\n", c.camera_model));
        out.push_str(&format!(
            "  distortion_coeffs: {}\n",
            yaml_list(&c.distortion_coeffs)
        ));
        out.push_str(&format!("  distortion_model: {}\n", c.distortion_model));
        out.push_str(&format!("  intrinsics: {}\n", yaml_list(&c.intrinsics)));
        out.push_str(&format!(
            "  resolution: [{}, {}]\n",
            c.resolution[0], c.resolution[1]
        ));
        out.push_str(&format!("  rostopic: {}\n", c.rostopic));
        out.push_str(&format!(
            "  timeshift_cam_imu: {}\n",
            yaml_f64(c.timeshift_cam_imu)
        ));
        if let Some((line_delay_ns, _, _)) = c.rolling_shutter {
            // Kalibr's rolling-shutter calibration writes the row-to-row delay.
            out.push_str(&format!(
                "  line_delay_nanoseconds: {}\n",
                yaml_f64(line_delay_ns)
            ));
        }
        // The rig's own values: T_cam_imu's inversion in doubles gives the translation back
        // only to rounding for a generic rotation (see `camera_from_imu`).
        out.push_str(
            "  # vio: the rig's T_b_c as given, exact (other readers ignore these keys)\n",
        );
        out.push_str(&format!(
            "  {TRANSLATION_KEY}: {}\n",
            yaml_list(c.t_b_c.as_slice())
        ));
        if let Some(q) = c.quaternion_xyzw {
            out.push_str(&format!("  {QUATERNION_KEY}: {}\n", yaml_list(&q)));
        }
        if let Some(sigma) = c.pixel_sigma_px {
            out.push_str(&format!("  {PIXEL_SIGMA_KEY}: {}\n", yaml_f64(sigma)));
        }
        if let Some((_, readout_s, direction)) = c.rolling_shutter {
            // Row r of an image is read r · line_delay after its stamp (the first row's).
            out.push_str(&format!(
                "  {READOUT_KEY}: {}\n  {DIRECTION_KEY}: {direction}\n",
                yaml_f64(readout_s)
            ));
        }
        previous = Some((r_c_b, t_c_b));
    }
    out
}

/// `imu.yaml` (Kalibr's `imu0:` form); `header` is written as comment lines first.
pub fn format_imu_yaml(imu: &KalibrImu, header: &str) -> String {
    let mut out = String::new();
    for line in header.lines() {
        out.push_str(&format!("# {line}\n"));
    }
    let n = &imu.noise;
    out.push_str("imu0:\n");
    out.push_str("  T_i_b:\n");
    for row in [
        "[1.0, 0.0, 0.0, 0.0]",
        "[0.0, 1.0, 0.0, 0.0]",
        "[0.0, 0.0, 1.0, 0.0]",
    ] {
        out.push_str(&format!("  - {row}\n"));
    }
    out.push_str("  - [0.0, 0.0, 0.0, 1.0]\n");
    for (key, v, unit) in [
        (
            "accelerometer_noise_density",
            n.accelerometer_noise_density,
            "m / s^2 / sqrt(Hz)",
        ),
        (
            "accelerometer_random_walk",
            n.accelerometer_random_walk,
            "m / s^3 / sqrt(Hz)",
        ),
        (
            "gyroscope_noise_density",
            n.gyroscope_noise_density,
            "rad / s / sqrt(Hz)",
        ),
        (
            "gyroscope_random_walk",
            n.gyroscope_random_walk,
            "rad / s^2 / sqrt(Hz)",
        ),
    ] {
        out.push_str(&format!("  {key}: {}  # [ {unit} ]\n", yaml_f64(v)));
    }
    out.push_str("  model: calibrated\n");
    out.push_str(&format!("  rostopic: {}\n", imu.rostopic));
    out.push_str("  time_offset: 0.0\n");
    out.push_str(&format!("  update_rate: {}\n", yaml_f64(imu.rate_hz)));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, UnitQuaternion};

    #[test]
    fn numbers_read_back_exactly_and_as_yaml_floats() {
        for v in [
            0.0,
            1.0,
            -0.055,
            2e-5,
            1.76187114e-05,
            1e20,
            458.654,
            1e-300,
        ] {
            let s = yaml_f64(v);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{s}");
            // YAML 1.1 (PyYAML): a float has a point; an exponent is signed.
            assert!(s.contains('.'), "{s}");
            if let Some((_, e)) = s.split_once('e') {
                assert!(e.starts_with(['+', '-']), "{s}");
            }
        }
    }

    #[test]
    fn the_written_extrinsic_inverts_to_the_rigs_own_values() {
        // Generic rotations: Rᵀ is exact, the translation comes back to a few units in the
        // last place (the rotation's own rounding, R·Rᵀ ≠ I in floating point, bounds it).
        let mut exact = 0;
        for i in 0..200 {
            let a = i as f64 * 0.37;
            let r = Rotation3::from(UnitQuaternion::from_euler_angles(a, 0.5 * a + 0.1, -a))
                .into_inner();
            let t = Vector3::new(0.0123 * a - 0.1, -0.055 + 0.001 * a, 0.3 / (1.0 + a));
            let (r_c_b, t_c_b) = camera_from_imu(&r, &t);
            let (r_back, t_back) = invert_rigid(&r_c_b, &t_c_b);
            assert_eq!(r_back, r);
            assert!(
                (t_back - t).amax() <= 8.0 * f64::EPSILON * t.amax(),
                "{i}: {t:?} {t_back:?}"
            );
            exact += usize::from(t_back == t);
        }
        // Measured: 45 of the 200 bit for bit (the rest within the bound above): what readers
        // of the matrix alone get; `vio`'s reader takes the exact keys written beside it.
        assert!(exact >= 40, "{exact} of 200");
        // Axis-aligned rigs (every catalog rig): exactly.
        let r = Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
        for t in [
            Vector3::new(0.0, 0.055, 0.0),
            Vector3::new(-0.0, -0.055, 0.0),
            Vector3::new(0.1, 0.2, -0.3),
        ] {
            let (r_c_b, t_c_b) = camera_from_imu(&r, &t);
            assert_eq!(invert_rigid(&r_c_b, &t_c_b).1, t);
        }
    }
}
