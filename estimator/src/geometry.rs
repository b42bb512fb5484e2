//! Lie-group helpers for SO(3) and SE(3).
//!
//! Conventions (see `ARCHITECTURE.md`):
//! - Rotations are Hamilton unit quaternions (`nalgebra::UnitQuaternion`); parameter blocks store
//!   them as `[qx, qy, qz, qw]`.
//! - Perturbations are on the **right**: `R ⊕ δ = R · Exp(δ)`, `R₁ ⊖ R₀ = Log(R₀ᵀ R₁)`.
//! - `Jr` is the right Jacobian of SO(3): `Exp(φ + δ) ≈ Exp(φ) · Exp(Jr(φ) δ)`.
//!
//! Every function here is exact (closed form with Taylor expansions where the closed form loses
//! precision) for angles from 0 up to and including π.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// Below this angle (rad) the closed forms switch to Taylor expansions.
const SMALL_ANGLE: f64 = 1e-4;

/// The skew-symmetric matrix `[v]×` with `[v]× w = v × w`.
#[inline]
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Inverse of [`skew`]: the vector of a skew-symmetric matrix (the antisymmetric part is used).
#[inline]
pub fn vee(m: &Matrix3<f64>) -> Vector3<f64> {
    Vector3::new(
        0.5 * (m[(2, 1)] - m[(1, 2)]),
        0.5 * (m[(0, 2)] - m[(2, 0)]),
        0.5 * (m[(1, 0)] - m[(0, 1)]),
    )
}

/// Exponential map of SO(3): rotation vector `phi` (axis · angle, rad) to a unit quaternion.
#[inline]
pub fn so3_exp(phi: &Vector3<f64>) -> UnitQuaternion<f64> {
    let theta_sq = phi.norm_squared();
    let theta = theta_sq.sqrt();
    let (w, k) = if theta < SMALL_ANGLE {
        // cos(θ/2) and sin(θ/2)/θ to O(θ⁴).
        (
            1.0 - theta_sq / 8.0 + theta_sq * theta_sq / 384.0,
            0.5 - theta_sq / 48.0 + theta_sq * theta_sq / 3840.0,
        )
    } else {
        let half = 0.5 * theta;
        (half.cos(), half.sin() / theta)
    };
    UnitQuaternion::new_unchecked(Quaternion::new(w, k * phi.x, k * phi.y, k * phi.z))
}

/// Logarithm map of SO(3): the rotation vector of `q` with angle in `[0, π]`.
#[inline]
pub fn so3_log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let q = q.quaternion();
    // q and −q are the same rotation: pick w ≥ 0 so the angle is in [0, π].
    let (w, v) = if q.w < 0.0 {
        (-q.w, -q.imag())
    } else {
        (q.w, q.imag())
    };
    let n_sq = v.norm_squared();
    let n = n_sq.sqrt();
    if n < SMALL_ANGLE * 0.5 {
        // θ = 2 atan(n / w); 2 atan(x)/n ≈ (2/w)(1 − n²/(3w²)).
        let w_sq = w * w;
        v * (2.0 / w) * (1.0 - n_sq / (3.0 * w_sq))
    } else {
        // atan2 stays accurate as w → 0 (angle → π).
        v * (2.0 * n.atan2(w) / n)
    }
}

/// Right Jacobian `Jr(φ)` of SO(3).
pub fn right_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta_sq = phi.norm_squared();
    let theta = theta_sq.sqrt();
    let k = skew(phi);
    let (a, b) = if theta < SMALL_ANGLE {
        // (1 − cos θ)/θ² and (θ − sin θ)/θ³.
        (
            0.5 - theta_sq / 24.0 + theta_sq * theta_sq / 720.0,
            1.0 / 6.0 - theta_sq / 120.0 + theta_sq * theta_sq / 5040.0,
        )
    } else {
        (
            (1.0 - theta.cos()) / theta_sq,
            (theta - theta.sin()) / (theta_sq * theta),
        )
    };
    Matrix3::identity() - k * a + k * k * b
}

/// `Exp(φ)` and `Jr(φ)` together, sharing one sine/cosine evaluation (the IMU integrator's hot
/// path).
pub fn so3_exp_and_right_jacobian(phi: &Vector3<f64>) -> (UnitQuaternion<f64>, Matrix3<f64>) {
    let theta_sq = phi.norm_squared();
    if theta_sq < SMALL_ANGLE * SMALL_ANGLE {
        return (so3_exp(phi), right_jacobian(phi));
    }
    let theta = theta_sq.sqrt();
    let (sh, ch) = (0.5 * theta).sin_cos();
    let k = sh / theta;
    let q = UnitQuaternion::new_unchecked(Quaternion::new(ch, k * phi.x, k * phi.y, k * phi.z));
    // cos θ = 1 − 2 sin²(θ/2), sin θ = 2 sin(θ/2) cos(θ/2).
    let a = 2.0 * sh * sh / theta_sq;
    let b = (theta - 2.0 * sh * ch) / (theta_sq * theta);
    let m = skew(phi);
    (q, Matrix3::identity() - m * a + m * m * b)
}

/// Inverse right Jacobian `Jr⁻¹(φ)` of SO(3) (finite for |φ| < 2π).
pub fn right_jacobian_inv(phi: &Vector3<f64>) -> Matrix3<f64> {
    let theta_sq = phi.norm_squared();
    let theta = theta_sq.sqrt();
    let k = skew(phi);
    // c = 1/θ² − cot(θ/2)/(2θ); cot(θ/2) is well conditioned up to θ = π.
    let c = if theta < SMALL_ANGLE {
        1.0 / 12.0 + theta_sq / 720.0 + theta_sq * theta_sq / 30240.0
    } else {
        let half = 0.5 * theta;
        1.0 / theta_sq - half.cos() / (half.sin() * 2.0 * theta)
    };
    Matrix3::identity() + k * 0.5 + k * k * c
}

/// Left Jacobian `Jl(φ) = Jr(−φ)` of SO(3).
pub fn left_jacobian(phi: &Vector3<f64>) -> Matrix3<f64> {
    right_jacobian(&-phi)
}

/// Two unit vectors `(b1, b2)` orthogonal to the unit vector `dir` and to each other
/// (`b2 = dir × b1`): the tangent basis of the unit sphere at `dir`, for updates of a direction
/// or of gravity with its norm fixed.
pub fn sphere_tangent_basis(dir: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let helper = if dir.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let b1 = dir.cross(&helper).normalize();
    (b1, dir.cross(&b1))
}

/// Quaternion ⊕ with right perturbation: `q · Exp(delta)`, renormalized.
#[inline]
pub fn quat_plus(q: &UnitQuaternion<f64>, delta: &Vector3<f64>) -> UnitQuaternion<f64> {
    let r = q.quaternion() * so3_exp(delta).quaternion();
    UnitQuaternion::new_normalize(r)
}

/// Quaternion ⊖: `Log(q0⁻¹ · q1)`, the right perturbation taking `q0` to `q1`.
#[inline]
pub fn quat_minus(q1: &UnitQuaternion<f64>, q0: &UnitQuaternion<f64>) -> Vector3<f64> {
    so3_log(&(q0.inverse() * q1))
}

/// Reads a unit quaternion stored `[qx, qy, qz, qw]` **without** renormalizing.
///
/// Precondition: the four values have unit norm (checked in debug builds to 1e-6). Parameter
/// blocks stay unit because every update goes through [`quat_plus`].
#[inline]
pub fn quat_from_xyzw(s: &[f64]) -> UnitQuaternion<f64> {
    debug_assert!(
        (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3] - 1.0).abs() < 1e-6,
        "quaternion block is not unit: {s:?}"
    );
    UnitQuaternion::new_unchecked(Quaternion::new(s[3], s[0], s[1], s[2]))
}

/// Reads a quaternion stored `[qx, qy, qz, qw]` from user input, rejecting non-finite values and
/// norms further than 1e-6 from one, then renormalizing exactly.
pub fn quat_from_xyzw_checked(s: &[f64]) -> Result<UnitQuaternion<f64>, GeometryError> {
    if s.len() != 4 || s.iter().any(|v| !v.is_finite()) {
        return Err(GeometryError::NonFinite);
    }
    let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2] + s[3] * s[3]).sqrt();
    if (n - 1.0).abs() > 1e-6 {
        return Err(GeometryError::NotUnit(n));
    }
    Ok(UnitQuaternion::new_normalize(Quaternion::new(
        s[3], s[0], s[1], s[2],
    )))
}

/// A rig quaternion `[qx, qy, qz, qw]` as written: taken as it is when its squared norm is 1 to
/// rounding (within [`UNIT_TO_ROUNDING`]: as `vio export` writes a unit quaternion, so that a rig
/// written out and read back is the same to the last bit), else normalized. Precondition:
/// finite and near unit (the callers check their input first).
pub fn quat_from_xyzw_as_written(s: &[f64; 4]) -> UnitQuaternion<f64> {
    let q = Quaternion::new(s[3], s[0], s[1], s[2]);
    if (q.norm_squared() - 1.0).abs() <= UNIT_TO_ROUNDING {
        UnitQuaternion::new_unchecked(q)
    } else {
        UnitQuaternion::new_normalize(q)
    }
}

/// How far from 1 a quaternion's squared norm may be for [`quat_from_xyzw_as_written`] to take
/// it as written (rounding of a unit quaternion's components: a few units of `f64::EPSILON`).
pub const UNIT_TO_ROUNDING: f64 = 4.0 * f64::EPSILON;

/// Writes `q` as `[qx, qy, qz, qw]`.
#[inline]
pub fn quat_to_xyzw(q: &UnitQuaternion<f64>, out: &mut [f64]) {
    let c = q.quaternion().coords; // nalgebra stores (i, j, k, w)
    out[..4].copy_from_slice(c.as_slice());
}

/// A rigid transform `T_a_b` (maps points from frame b to frame a): rotation and translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Rotation `R_a_b`.
    pub q: UnitQuaternion<f64>,
    /// Translation `p_a_b` (origin of b expressed in a).
    pub p: Vector3<f64>,
}

impl Pose {
    /// Identity transform.
    pub fn identity() -> Self {
        Self {
            q: UnitQuaternion::identity(),
            p: Vector3::zeros(),
        }
    }

    /// Builds a pose from rotation and translation.
    pub fn new(q: UnitQuaternion<f64>, p: Vector3<f64>) -> Self {
        Self { q, p }
    }

    /// Reads the parameter-block layout `[px, py, pz, qx, qy, qz, qw]` (quaternion must be unit).
    #[inline]
    pub fn from_slice(s: &[f64]) -> Self {
        Self {
            p: Vector3::new(s[0], s[1], s[2]),
            q: quat_from_xyzw(&s[3..7]),
        }
    }

    /// Writes the parameter-block layout `[px, py, pz, qx, qy, qz, qw]`.
    #[inline]
    pub fn write_slice(&self, out: &mut [f64]) {
        out[..3].copy_from_slice(self.p.as_slice());
        quat_to_xyzw(&self.q, &mut out[3..7]);
    }

    /// The parameter block `[px, py, pz, qx, qy, qz, qw]` as an array.
    pub fn to_array(&self) -> [f64; 7] {
        let mut a = [0.0; 7];
        self.write_slice(&mut a);
        a
    }

    /// Applies the transform to a point: `R p + t`.
    #[inline]
    pub fn transform(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.q * x + self.p
    }

    /// Composition `self · other`.
    #[inline]
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose {
            q: self.q * other.q,
            p: self.q * other.p + self.p,
        }
    }

    /// The inverse transform.
    #[inline]
    pub fn inverse(&self) -> Pose {
        let qi = self.q.inverse();
        Pose {
            q: qi,
            p: -(qi * self.p),
        }
    }

    /// Pose ⊕ in the estimator's decoupled convention: `p + δp`, `q · Exp(δθ)`; tangent `[δp, δθ]`.
    #[inline]
    pub fn plus(&self, delta: &[f64]) -> Pose {
        Pose {
            p: self.p + Vector3::new(delta[0], delta[1], delta[2]),
            q: quat_plus(&self.q, &Vector3::new(delta[3], delta[4], delta[5])),
        }
    }
}

/// Errors from checked geometric constructors.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeometryError {
    /// A value was NaN or infinite, or the slice had the wrong length.
    #[error("quaternion has non-finite components or is not 4 values long")]
    NonFinite,
    /// The quaternion's norm is not one.
    #[error("quaternion norm {0} is not 1 (tolerance 1e-6)")]
    NotUnit(f64),
}

/// The closed-form yaw of a position+yaw (4-dof) alignment of `src` onto `dst` (associated,
/// gravity-aligned point lists), minimizing `Σ ‖dst_i − (R_z(ψ) src_i + t)‖²`: with centred
/// points `a_i`, `b_i`, `ψ = atan2(Σ a_x b_y − a_y b_x, Σ a_x b_x + a_y b_y)`, and
/// `t = mean(dst) − R_z(ψ) mean(src)` for the caller to form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionYaw {
    /// The yaw ψ (rad).
    pub yaw: f64,
    /// Mean of `src`.
    pub mean_src: Vector3<f64>,
    /// Mean of `dst`.
    pub mean_dst: Vector3<f64>,
    /// `Σ |a_i|²` over the horizontal components of the centred `src`.
    pub src_spread2: f64,
}

/// [`PositionYaw`] of two equally long, non-empty point lists; `None` otherwise, or when the
/// horizontal positions do not determine a yaw (all at one place, or no turn between them).
pub fn position_yaw(src: &[Vector3<f64>], dst: &[Vector3<f64>]) -> Option<PositionYaw> {
    if src.len() != dst.len() || src.is_empty() {
        return None;
    }
    let n = src.len() as f64;
    let mean_src = src.iter().sum::<Vector3<f64>>() / n;
    let mean_dst = dst.iter().sum::<Vector3<f64>>() / n;
    let (mut dot, mut cross, mut spread_a, mut spread_b) = (0.0, 0.0, 0.0, 0.0);
    for (x, y) in src.iter().zip(dst) {
        let a = x - mean_src;
        let b = y - mean_dst;
        dot += a.x * b.x + a.y * b.y;
        cross += a.x * b.y - a.y * b.x;
        spread_a += a.x * a.x + a.y * a.y;
        spread_b += b.x * b.x + b.y * b.y;
    }
    if dot.hypot(cross) <= 1e-12 * (spread_a * spread_b).sqrt() || spread_a == 0.0 {
        return None;
    }
    Some(PositionYaw {
        yaw: cross.atan2(dot),
        mean_src,
        mean_dst,
        src_spread2: spread_a,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_log_round_trip_at_pi() {
        let phi = Vector3::new(0.0, 0.0, std::f64::consts::PI);
        let back = so3_log(&so3_exp(&phi));
        assert!((back.norm() - std::f64::consts::PI).abs() < 1e-12);
        assert!(back.z.abs() > 3.0);
    }

    #[test]
    fn tiny_angles_are_exact() {
        let phi = Vector3::new(1e-9, -2e-9, 3e-9);
        let back = so3_log(&so3_exp(&phi));
        assert!((back - phi).norm() < 1e-24);
    }

    #[test]
    fn jr_times_jr_inv_is_identity() {
        for phi in [
            Vector3::new(0.3, -0.2, 0.9),
            Vector3::new(1e-7, 0.0, 0.0),
            Vector3::new(0.0, 3.1, 0.0),
        ] {
            let e = right_jacobian(&phi) * right_jacobian_inv(&phi) - Matrix3::identity();
            assert!(e.norm() < 1e-10, "{phi:?}: {e}");
        }
    }

    #[test]
    fn fused_exp_and_jacobian_agree_with_separate_ones() {
        for phi in [
            Vector3::new(0.3, -0.2, 0.9),
            Vector3::new(1e-7, 0.0, 2e-7),
            Vector3::new(0.0, 3.1, 0.0),
        ] {
            let (q, j) = so3_exp_and_right_jacobian(&phi);
            assert!(q.angle_to(&so3_exp(&phi)) < 1e-15);
            assert!((j - right_jacobian(&phi)).norm() < 1e-14);
        }
    }

    #[test]
    fn skew_vee_inverse() {
        let v = Vector3::new(1.0, -2.0, 3.0);
        assert_eq!(vee(&skew(&v)), v);
        assert_eq!(
            skew(&v) * Vector3::new(0.5, 0.1, -0.7),
            v.cross(&Vector3::new(0.5, 0.1, -0.7))
        );
    }

    #[test]
    fn checked_quaternion_rejects_bad_input() {
        assert!(quat_from_xyzw_checked(&[0.0, 0.0, 0.0, 2.0]).is_err());
        assert!(quat_from_xyzw_checked(&[f64::NAN, 0.0, 0.0, 1.0]).is_err());
        assert!(quat_from_xyzw_checked(&[0.0, 0.0, 0.0, 1.0]).is_ok());
    }
}
