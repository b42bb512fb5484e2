//! Double sphere model (Usenko, Demmel, Cremers, "The Double Sphere Camera Model", 3DV 2018).

use nalgebra::{Matrix2x3, Vector2, Vector3};

use super::{CameraError, CameraModel, check_intrinsics, check_range, in_image};

/// Double sphere camera: `d1 = ‖P‖`, `d2 = √(x² + y² + (ξ·d1 + z)²)`,
/// `den = α·d2 + (1 − α)(ξ·d1 + z)`, `u = fx·x/den + cx`, `v = fy·y/den + cy`.
///
/// Projection is valid iff `z > −w2·d1` with `w1 = α/(1 − α)` for α ≤ 0.5, else `(1 − α)/α`,
/// and `w2 = (w1 + ξ)/√(2w1ξ + ξ² + 1)`; unprojection iff α ≤ 0.5 or `r² ≤ 1/(2α − 1)`.
#[derive(Clone, Debug, PartialEq)]
pub struct DoubleSphere {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Focal length along x (px).
    pub fx: f64,
    /// Focal length along y (px).
    pub fy: f64,
    /// Principal point x (px).
    pub cx: f64,
    /// Principal point y (px).
    pub cy: f64,
    /// Distance ξ between the two sphere centres, in (−1, 1).
    pub xi: f64,
    /// Blend α between the second sphere and the image plane, in [0, 1].
    pub alpha: f64,
    /// Cached: `w2`, valid points have `z > −w2·d1`.
    w2: f64,
}

impl DoubleSphere {
    /// Checked constructor: finite values, `fx, fy > 0`, non-zero image size, `α ∈ [0, 1]`,
    /// `ξ ∈ (−1, 1)`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: u32,
        height: u32,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        xi: f64,
        alpha: f64,
    ) -> Result<Self, CameraError> {
        check_intrinsics(width, height, fx, fy, cx, cy)?;
        check_range("xi", xi, |v| v > -1.0 && v < 1.0, "in (-1, 1)")?;
        check_range("alpha", alpha, |v| (0.0..=1.0).contains(&v), "in [0, 1]")?;
        let w1 = if alpha <= 0.5 {
            alpha / (1.0 - alpha)
        } else {
            (1.0 - alpha) / alpha
        };
        let w2 = (w1 + xi) / (2.0 * w1 * xi + xi * xi + 1.0).sqrt();
        Ok(Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            xi,
            alpha,
            w2,
        })
    }

    /// The projection's validity bound `w2`: points with `z ≤ −w2·‖P‖` are rejected.
    #[inline]
    pub fn w2(&self) -> f64 {
        self.w2
    }

    /// Shared body of `project` and `project_with_jacobian` (identical arithmetic for `uv`).
    #[inline(always)]
    fn project_impl<const JAC: bool>(
        &self,
        p: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let (x, y, z) = (p.x, p.y, p.z);
        let r2 = x * x + y * y;
        let d1 = (r2 + z * z).sqrt();
        // False for d1 = 0 and NaN.
        if !(z > -self.w2 * d1) {
            return None;
        }
        let a = self.xi * d1 + z;
        let d2 = (r2 + a * a).sqrt();
        let den = self.alpha * d2 + (1.0 - self.alpha) * a;
        if !(den > 0.0) {
            return None;
        }
        let iden = 1.0 / den;
        let mx = x * iden;
        let my = y * iden;
        let uv = Vector2::new(self.fx * mx + self.cx, self.fy * my + self.cy);
        let mut jac = Matrix2x3::zeros();
        if JAC {
            // ∂d1/∂P = P/d1; ∂a/∂P = ξP/d1 + e_z; ∂d2/∂P = ((x, y, 0) + a ∂a/∂P)/d2;
            // ∂den/∂P = α ∂d2/∂P + (1 − α) ∂a/∂P; ∂m/∂P = (e_xy − m ∂den/∂P)/den.
            let xd1 = self.xi / d1;
            let da = Vector3::new(xd1 * x, xd1 * y, xd1 * z + 1.0);
            let id2 = 1.0 / d2;
            let dd2 = Vector3::new((x + a * da.x) * id2, (y + a * da.y) * id2, a * da.z * id2);
            let dden = dd2 * self.alpha + da * (1.0 - self.alpha);
            let fxd = self.fx * iden;
            let fyd = self.fy * iden;
            jac = Matrix2x3::new(
                fxd * (1.0 - mx * dden.x),
                -fxd * mx * dden.y,
                -fxd * mx * dden.z,
                -fyd * my * dden.x,
                fyd * (1.0 - my * dden.y),
                -fyd * my * dden.z,
            );
        }
        Some((uv, jac))
    }
}

impl CameraModel for DoubleSphere {
    #[inline]
    fn width(&self) -> u32 {
        self.width
    }

    #[inline]
    fn height(&self) -> u32 {
        self.height
    }

    #[inline]
    fn project(&self, p_c: &Vector3<f64>) -> Option<Vector2<f64>> {
        self.project_impl::<false>(p_c).map(|(uv, _)| uv)
    }

    #[inline]
    fn project_with_jacobian(&self, p_c: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        self.project_impl::<true>(p_c)
    }

    #[inline]
    fn unproject(&self, uv: &Vector2<f64>) -> Option<Vector3<f64>> {
        let mx = (uv.x - self.cx) / self.fx;
        let my = (uv.y - self.cy) / self.fy;
        let r2 = mx * mx + my * my;
        let a = self.alpha;
        // 1 − (2α − 1)r² ≥ 0, i.e. r² ≤ 1/(2α − 1) when α > 0.5.
        let arg = 1.0 - (2.0 * a - 1.0) * r2;
        if !(arg >= 0.0) {
            return None;
        }
        let den = a * arg.sqrt() + 1.0 - a;
        if !(den > 0.0) {
            return None;
        }
        let mz = (1.0 - a * a * r2) / den;
        let mz2 = mz * mz;
        let k = (mz * self.xi + (mz2 + (1.0 - self.xi * self.xi) * r2).sqrt()) / (mz2 + r2);
        let b = Vector3::new(k * mx, k * my, k * mz - self.xi).normalize();
        // Only bearings the model projects.
        (b.z > -self.w2 && b.iter().all(|v| v.is_finite())).then_some(b)
    }

    #[inline]
    fn is_valid(&self, uv: &Vector2<f64>) -> bool {
        in_image(self.width, self.height, uv) && self.unproject(uv).is_some()
    }
}
