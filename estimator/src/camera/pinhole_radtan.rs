//! Pinhole projection with radial-tangential distortion (OpenCV `plumb_bob`, Kalibr
//! `pinhole-radtan`).

use nalgebra::{Matrix2x3, Vector2, Vector3};

use super::radtan::Radtan;
use super::{CameraError, CameraModel, check_finite, check_intrinsics, in_image};

/// Smallest depth `z` (m) a point may have to be projected.
const MIN_DEPTH: f64 = 1e-6;

/// Pinhole camera with radial-tangential distortion: `x = X/Z, y = Y/Z`,
/// `r² = x² + y²`, `radial = 1 + k1 r² + k2 r⁴`, `xd = x·radial + 2p1·xy + p2(r² + 2x²)`,
/// `yd = y·radial + p1(r² + 2y²) + 2p2·xy`, `u = fx·xd + cx`, `v = fy·yd + cy`.
///
/// Valid for `Z > 1e-6` and `r²` below the first radius where `r·radial` stops increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct PinholeRadtan {
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
    /// First radial coefficient.
    pub k1: f64,
    /// Second radial coefficient.
    pub k2: f64,
    /// First tangential coefficient.
    pub p1: f64,
    /// Second tangential coefficient.
    pub p2: f64,
    /// Cached: largest undistorted `r²` where the radial distortion is still monotonic.
    r2_max: f64,
}

impl PinholeRadtan {
    /// Checked constructor: finite values, `fx, fy > 0`, non-zero image size.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: u32,
        height: u32,
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
        check_finite("k1", k1)?;
        check_finite("k2", k2)?;
        check_finite("p1", p1)?;
        check_finite("p2", p2)?;
        Ok(Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            k1,
            k2,
            p1,
            p2,
            r2_max: Radtan::monotonic_r2_max(k1, k2),
        })
    }

    /// EuRoC MAV `cam0` (752×480, Kalibr calibration of the VI-Sensor).
    pub fn euroc_cam0() -> Self {
        Self::new(
            752,
            480,
            458.654,
            457.296,
            367.215,
            248.375,
            -0.28340811,
            0.07395907,
            0.00019359,
            1.76187114e-05,
        )
        .expect("EuRoC cam0 parameters are valid")
    }

    /// Largest normalized-plane `r²` the model accepts (`∞` if the distortion is monotonic
    /// everywhere).
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
        if !(p.z > MIN_DEPTH) {
            return None;
        }
        let iz = 1.0 / p.z;
        let x = p.x * iz;
        let y = p.y * iz;
        if !(x * x + y * y < self.r2_max) {
            return None;
        }
        let d = self.radtan();
        let (xd, yd) = d.distort(x, y);
        let uv = Vector2::new(self.fx * xd + self.cx, self.fy * yd + self.cy);
        let mut jac = Matrix2x3::zeros();
        if JAC {
            // ∂(x, y)/∂P = (1/Z)[[1, 0, −x], [0, 1, −y]].
            let j = d.jacobian(x, y);
            let fxz = self.fx * iz;
            let fyz = self.fy * iz;
            jac = Matrix2x3::new(
                fxz * j[(0, 0)],
                fxz * j[(0, 1)],
                -fxz * (j[(0, 0)] * x + j[(0, 1)] * y),
                fyz * j[(1, 0)],
                fyz * j[(1, 1)],
                -fyz * (j[(1, 0)] * x + j[(1, 1)] * y),
            );
        }
        Some((uv, jac))
    }
}

impl CameraModel for PinholeRadtan {
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
        let (x, y) = self.radtan().undistort(xd, yd, self.r2_max)?;
        let b = Vector3::new(x, y, 1.0).normalize();
        // The unit bearing itself must be projectable.
        (b.z > MIN_DEPTH).then_some(b)
    }

    #[inline]
    fn is_valid(&self, uv: &Vector2<f64>) -> bool {
        in_image(self.width, self.height, uv) && self.unproject(uv).is_some()
    }
}
