//! Alignment of an estimate to the ground truth: Umeyama (SE3, Sim3) and position+yaw.

use std::fmt;
use std::str::FromStr;

use estimator::geometry::Pose;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::MetricsError;

/// Which transform aligns the estimate to the ground truth before the errors are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Alignment {
    /// No alignment.
    None,
    /// Rotation + translation (Umeyama without scale; `evo_ape -a`).
    #[default]
    Se3,
    /// Rotation + translation + scale (Umeyama; `evo_ape -a --correct_scale`).
    Sim3,
    /// Translation + rotation about the gravity (z) axis: the 4 DoF unobservable in VIO.
    PosYaw,
}

impl Alignment {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Alignment::None => "none",
            Alignment::Se3 => "se3",
            Alignment::Sim3 => "sim3",
            Alignment::PosYaw => "posyaw",
        }
    }
}

impl fmt::Display for Alignment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Alignment {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(Alignment::None),
            "se3" => Ok(Alignment::Se3),
            "sim3" => Ok(Alignment::Sim3),
            "posyaw" => Ok(Alignment::PosYaw),
            _ => Err(format!(
                "unknown alignment `{s}` (expected se3, sim3, posyaw or none)"
            )),
        }
    }
}

/// A similarity transform `x ↦ s R x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sim3 {
    /// Rotation `R`.
    pub rotation: Rotation3<f64>,
    /// Translation `t`.
    pub translation: Vector3<f64>,
    /// Scale `s` (1 for SE3 and 4-DoF alignment).
    pub scale: f64,
}

impl Sim3 {
    /// The identity.
    pub fn identity() -> Self {
        Self {
            rotation: Rotation3::identity(),
            translation: Vector3::zeros(),
            scale: 1.0,
        }
    }

    /// `s R x + t`.
    pub fn transform_point(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * (x * self.scale) + self.translation
    }

    /// Applies the transform to a pose `T_w_b` (as evo does: scale the position, then
    /// left-multiply by `[R | t]`).
    pub fn transform_pose(&self, p: &Pose) -> Pose {
        let q = UnitQuaternion::from_rotation_matrix(&self.rotation) * p.q;
        Pose::new(q, self.transform_point(&p.p))
    }
}

fn mean(points: &[Vector3<f64>]) -> Vector3<f64> {
    points.iter().sum::<Vector3<f64>>() / points.len() as f64
}

/// Umeyama's closed form (IEEE PAMI 1991): the `s, R, t` minimizing `Σ ‖dst_i − (s R src_i + t)‖²`
/// (`s = 1` unless `with_scale`). Needs at least three non-collinear points.
pub fn umeyama(
    src: &[Vector3<f64>],
    dst: &[Vector3<f64>],
    with_scale: bool,
) -> Result<Sim3, MetricsError> {
    if src.len() != dst.len() {
        return Err(MetricsError::LengthMismatch {
            gt: dst.len(),
            est: src.len(),
        });
    }
    let n = src.len();
    if n < 3 {
        return Err(MetricsError::TooFewPoses {
            what: "Umeyama alignment",
            have: n,
            need: 3,
        });
    }
    let mx = mean(src);
    let my = mean(dst);
    let mut sigma_x = 0.0;
    let mut cov = Matrix3::zeros();
    for (x, y) in src.iter().zip(dst) {
        let dx = x - mx;
        sigma_x += dx.norm_squared();
        cov += (y - my) * dx.transpose();
    }
    let inv_n = 1.0 / n as f64;
    sigma_x *= inv_n;
    cov *= inv_n;
    let svd = cov.svd(true, true); // singular values sorted in decreasing order
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(MetricsError::Degenerate("SVD did not converge".into()));
    };
    let d = svd.singular_values;
    if !(d[0].is_finite() && d[0] > 0.0) || d[1] <= d[0] * 1e-12 {
        return Err(MetricsError::Degenerate(
            "the positions are (nearly) collinear or identical: Umeyama alignment is not possible"
                .into(),
        ));
    }
    let mut s = Matrix3::identity();
    if u.determinant() * v_t.determinant() < 0.0 {
        s[(2, 2)] = -1.0;
    }
    let r = u * s * v_t;
    let scale = if with_scale {
        (d[0] * s[(0, 0)] + d[1] * s[(1, 1)] + d[2] * s[(2, 2)]) / sigma_x
    } else {
        1.0
    };
    let t = my - r * mx * scale;
    Ok(Sim3 {
        rotation: Rotation3::from_matrix_unchecked(r),
        translation: t,
        scale,
    })
}

/// Position + yaw alignment (4 DoF): the rotation about z and the translation minimizing
/// `Σ ‖dst_i − (R_z(ψ) src_i + t)‖²`. Closed form: with centred points `a_i`, `b_i`,
/// `ψ = atan2(Σ a_x b_y − a_y b_x, Σ a_x b_x + a_y b_y)` and `t = mean(dst) − R_z(ψ) mean(src)`.
pub fn align_position_yaw(
    src: &[Vector3<f64>],
    dst: &[Vector3<f64>],
) -> Result<Sim3, MetricsError> {
    if src.len() != dst.len() {
        return Err(MetricsError::LengthMismatch {
            gt: dst.len(),
            est: src.len(),
        });
    }
    let n = src.len();
    if n < 2 {
        return Err(MetricsError::TooFewPoses {
            what: "position+yaw alignment",
            have: n,
            need: 2,
        });
    }
    let py = estimator::geometry::position_yaw(src, dst).ok_or_else(|| {
        MetricsError::Degenerate("the horizontal positions do not determine a yaw".into())
    })?;
    let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), py.yaw);
    Ok(Sim3 {
        rotation,
        translation: py.mean_dst - rotation * py.mean_src,
        scale: 1.0,
    })
}

/// The alignment of `est` onto `gt` (equal-length, associated pose lists) by positions.
pub fn estimate_alignment(
    gt: &[Pose],
    est: &[Pose],
    alignment: Alignment,
) -> Result<Sim3, MetricsError> {
    let src: Vec<Vector3<f64>> = est.iter().map(|p| p.p).collect();
    let dst: Vec<Vector3<f64>> = gt.iter().map(|p| p.p).collect();
    match alignment {
        Alignment::None => {
            if src.len() != dst.len() {
                return Err(MetricsError::LengthMismatch {
                    gt: dst.len(),
                    est: src.len(),
                });
            }
            Ok(Sim3::identity())
        }
        Alignment::Se3 => umeyama(&src, &dst, false),
        Alignment::Sim3 => umeyama(&src, &dst, true),
        Alignment::PosYaw => align_position_yaw(&src, &dst),
    }
}
