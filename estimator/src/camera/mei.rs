//! Mei unified omnidirectional model (Mei & Rives, ICRA 2007; Kalibr `omni-radtan`).

use nalgebra::{Matrix2x3, Vector2, Vector3};

use super::radtan::Radtan;
use super::{CameraError, CameraModel, check_finite, check_intrinsics, check_range, in_image};

/// Smallest accepted margin of `Xs.z` above the model's limit (`−xi`, or `−1/xi` for xi > 1).
const MIN_MARGIN: f64 = 1e-9;

/// Unified omnidirectional camera: the point is projected onto the unit sphere,
/// `Xs = P/‖P‖`, then from a centre shifted by `xi` along −z onto the normalized plane,
/// `m = (Xs.x, Xs.y)/(Xs.z + xi)`, then distorted by radial-tangential coefficients and mapped
/// by `K`.
///
/// Valid where `Xs.z + xi > 1e-9`, where the lift back to the sphere is real
/// (`Xs.z > −1/xi` for `xi > 1`), and where the radial distortion is monotonic.
#[derive(Clone, Debug, PartialEq)]
pub struct Mei {
    /// Image width (px).
    pub width: u32,
    /// Image height (px).
    pub height: u32,
    /// Mirror parameter ξ ≥ 0 (0 = pinhole, 1 = parabolic).
    pub xi: f64,
    /// Generalized focal length along x (px).
    pub fx: f64,
    /// Generalized focal length along y (px).
    pub fy: f64,
    /// Principal point x (px).
    pub cx: f64,
    /// Principal point y (px).
    pub cy: f64,
    /// First radial coefficient.
    pub k1: f64,
    /// Second radial coefficient.
    pub k2: f64,
    /// First tangential coefficient.
    pub p1: f64,
    /// Second tangential coefficient.
    pub p2: f64,
    /// Cached: largest `r²` on the normalized plane where the radial distortion is monotonic.
    r2_max: f64,
    /// Cached: `min(xi, 1/xi)`; valid points have `Xs.z > −limit`.
    limit: f64,
}

impl Mei {
    /// Checked constructor: finite values, `xi ≥ 0`, `fx, fy > 0`, non-zero image size.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: u32,
        height: u32,
        xi: f64,
        fx: f64,
        fy: f64,
        cx: f64,
        cy: f64,
        k1: f64,
        k2: f64,
        p1: f64,
        p2: f64,
    ) -> Result<Self, CameraError> {
        check_intrinsics(width, height, fx, fy, cx, cy)?;
        check_range("xi", xi, |v| v >= 0.0, ">= 0")?;
        check_finite("k1", k1)?;
        check_finite("k2", k2)?;
        check_finite("p1", p1)?;
        check_finite("p2", p2)?;
        Ok(Self {
            width,
            height,
            xi,
            fx,
            fy,
            cx,
            cy,
            k1,
            k2,
            p1,
            p2,
            r2_max: Radtan::monotonic_r2_max(k1, k2),
            limit: if xi > 1.0 { 1.0 / xi } else { xi },
        })
    }

    /// Largest normalized-plane `r²` the distortion accepts (`∞` if monotonic everywhere).
    #[inline]
    pub fn max_r2(&self) -> f64 {
        self.r2_max
    }

    #[inline(always)]
    fn radtan(&self) -> Radtan {
        Radtan {
            k1: self.k1,
            k2: self.k2,
            p1: self.p1,
            p2: self.p2,
        }
    }

    /// Shared body of `project` and `project_with_jacobian` (identical arithmetic for `uv`).
    #[inline(always)]
    fn project_impl<const JAC: bool>(
        &self,
        p: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let (x, y, z) = (p.x, p.y, p.z);
        let rho = (x * x + y * y + z * z).sqrt();
        // Xs.z > −limit + margin, written without dividing by ρ (false for ρ = 0 and NaN).
        if !(z > (MIN_MARGIN - self.limit) * rho) {
            return None;
        }
        // m = (X, Y)/(Z + ξρ), equal to (Xs.x, Xs.y)/(Xs.z + ξ); den > 0 here.
        let den = z + self.xi * rho;
        let iden = 1.0 / den;
        let mx = x * iden;
        let my = y * iden;
        if !(mx * mx + my * my < self.r2_max) {
            return None;
        }
        let d = self.radtan();
        let (xd, yd) = d.distort(mx, my);
        let uv = Vector2::new(self.fx * xd + self.cx, self.fy * yd + self.cy);
        let mut jac = Matrix2x3::zeros();
        if JAC {
            // ∂den/∂P = (ξX/ρ, ξY/ρ, 1 + ξZ/ρ); ∂m/∂P = (e_xy − m ∂den/∂P)/den.
            let xr = self.xi / rho;
            let dden = Vector3::new(xr * x, xr * y, 1.0 + xr * z);
            let dm = Matrix2x3::new(
                iden - mx * dden.x * iden,
                -mx * dden.y * iden,
                -mx * dden.z * iden,
                -my * dden.x * iden,
                iden - my * dden.y * iden,
                -my * dden.z * iden,
            );
            let j = d.jacobian(mx, my);
            let mut full = j * dm;
            full.row_mut(0).scale_mut(self.fx);
            full.row_mut(1).scale_mut(self.fy);
            jac = full;
        }
        Some((uv, jac))
    }
}

impl CameraModel for Mei {
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

    fn unproject(&self, uv: &Vector2<f64>) -> Option<Vector3<f64>> {
        let xd = (uv.x - self.cx) / self.fx;
        let yd = (uv.y - self.cy) / self.fy;
        let (mx, my) = self.radtan().undistort(xd, yd, self.r2_max)?;
        let r2 = mx * mx + my * my;
        // Lift to the sphere: Xs = (f·mx, f·my, f − ξ), f = (ξ + √(1 + (1 − ξ²)r²))/(1 + r²).
        let arg = 1.0 + (1.0 - self.xi * self.xi) * r2;
        if !(arg >= 0.0) {
            return None;
        }
        let f = (self.xi + arg.sqrt()) / (1.0 + r2);
        let b = Vector3::new(f * mx, f * my, f - self.xi).normalize();
        // Only bearings the model projects (the lift's other branch and the margin are excluded).
        (b.z > MIN_MARGIN - self.limit).then_some(b)
    }

    #[inline]
    fn is_valid(&self, uv: &Vector2<f64>) -> bool {
        in_image(self.width, self.height, uv) && self.unproject(uv).is_some()
    }
}
