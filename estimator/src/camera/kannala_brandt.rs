//! Kannala-Brandt equidistant fisheye model (Kalibr `pinhole-equi`, OpenCV `fisheye`).

use nalgebra::{Matrix2x3, Vector2, Vector3};

use super::{CameraError, CameraModel, check_finite, check_intrinsics, in_image};

/// Below `r < SMALL_R · z` the projection uses the on-axis limit `d(θ)/r → 1/z`; there the
/// neglected terms are `O((r/z)²) ≤ 1e-20` relative.
const SMALL_R: f64 = 1e-10;
/// Iteration cap of the safeguarded Newton solve in `unproject`.
const MAX_ITERATIONS: usize = 40;
/// Converged when the Newton step is below this times θ…
const STEP_TOL: f64 = 1e-14;
/// …or the residual `|d(θ) − rd|` below this times `rd`.
const RESIDUAL_TOL: f64 = 4.0 * f64::EPSILON;
/// Grid steps on `[0, π]` used to find the first maximum of `d(θ)`.
const SCAN_STEPS: usize = 4096;

/// Kannala-Brandt equidistant fisheye: `θ = atan2(r, Z)` with `r = √(X² + Y²)`,
/// `d(θ) = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)`, `u = fx·d·X/r + cx`, `v = fy·d·Y/r + cy`.
///
/// Valid for θ below the first maximum of `d(θ)` (or below π if `d` increases on all of
/// `[0, π]`).
#[derive(Clone, Debug, PartialEq)]
pub struct KannalaBrandt {
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
    /// Coefficient of θ³.
    pub k1: f64,
    /// Coefficient of θ⁵.
    pub k2: f64,
    /// Coefficient of θ⁷.
    pub k3: f64,
    /// Coefficient of θ⁹.
    pub k4: f64,
    /// Cached: first maximum of `d(θ)` in `(0, π]`, or π.
    theta_max: f64,
    /// Cached: `d(theta_max)`.
    d_max: f64,
}

impl KannalaBrandt {
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
        k3: f64,
        k4: f64,
    ) -> Result<Self, CameraError> {
        check_intrinsics(width, height, fx, fy, cx, cy)?;
        check_finite("k1", k1)?;
        check_finite("k2", k2)?;
        check_finite("k3", k3)?;
        check_finite("k4", k4)?;
        let mut cam = Self {
            width,
            height,
            fx,
            fy,
            cx,
            cy,
            k1,
            k2,
            k3,
            k4,
            theta_max: std::f64::consts::PI,
            d_max: 0.0,
        };
        cam.theta_max = cam.first_maximum();
        cam.d_max = cam.distortion(cam.theta_max);
        Ok(cam)
    }

    /// Largest incidence angle θ (rad, exclusive) the model projects.
    #[inline]
    pub fn max_theta(&self) -> f64 {
        self.theta_max
    }

    /// `d(θ) = θ(1 + k1θ² + k2θ⁴ + k3θ⁶ + k4θ⁸)`.
    #[inline(always)]
    fn distortion(&self, theta: f64) -> f64 {
        let s = theta * theta;
        theta * (1.0 + s * (self.k1 + s * (self.k2 + s * (self.k3 + s * self.k4))))
    }

    /// `d'(θ) = 1 + 3k1θ² + 5k2θ⁴ + 7k3θ⁶ + 9k4θ⁸`.
    #[inline(always)]
    fn distortion_derivative(&self, theta: f64) -> f64 {
        let s = theta * theta;
        1.0 + s * (3.0 * self.k1 + s * (5.0 * self.k2 + s * (7.0 * self.k3 + s * 9.0 * self.k4)))
    }

    /// First θ in `(0, π]` where `d'(θ)` reaches zero (grid scan then bisection), or π.
    fn first_maximum(&self) -> f64 {
        let pi = std::f64::consts::PI;
        let mut prev = 0.0;
        for i in 1..=SCAN_STEPS {
            let theta = pi * i as f64 / SCAN_STEPS as f64;
            if !(self.distortion_derivative(theta) > 0.0) {
                let (mut lo, mut hi) = (prev, theta);
                // d' > 0 at lo, ≤ 0 at hi.
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if mid <= lo || mid >= hi {
                        break;
                    }
                    if self.distortion_derivative(mid) > 0.0 {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                return lo;
            }
            prev = theta;
        }
        pi
    }

    /// Shared body of `project` and `project_with_jacobian` (identical arithmetic for `uv`).
    #[inline(always)]
    fn project_impl<const JAC: bool>(
        &self,
        p: &Vector3<f64>,
    ) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let (x, y, z) = (p.x, p.y, p.z);
        let r2 = x * x + y * y;
        let r = r2.sqrt();
        if !(r.is_finite() && z.is_finite()) {
            return None;
        }
        let mut jac = Matrix2x3::zeros();
        if z > 0.0 && r <= SMALL_R * z {
            // On the optical axis: θ → r/z, d(θ)/r → 1/z (pinhole to first order).
            let iz = 1.0 / z;
            let uv = Vector2::new(self.fx * x * iz + self.cx, self.fy * y * iz + self.cy);
            if JAC {
                jac = Matrix2x3::new(
                    self.fx * iz,
                    0.0,
                    -self.fx * x * iz * iz,
                    0.0,
                    self.fy * iz,
                    -self.fy * y * iz * iz,
                );
            }
            return Some((uv, jac));
        }
        if r == 0.0 {
            // The origin, or straight behind the camera: no direction.
            return None;
        }
        let theta = r.atan2(z);
        if !(theta < self.theta_max) {
            return None;
        }
        // g = d(θ)/r, so u = fx·X·g + cx.
        let g = self.distortion(theta) / r;
        let uv = Vector2::new(self.fx * x * g + self.cx, self.fy * y * g + self.cy);
        if JAC {
            // ∂θ/∂r = Z/ρ², ∂θ/∂Z = −r/ρ² with ρ² = r² + Z²; ∂r/∂X = X/r.
            // h = (∂g/∂r)/r = (d'·Z/ρ² − g)/r², gz = ∂g/∂Z = −d'/ρ².
            let dd = self.distortion_derivative(theta);
            let rho2 = r2 + z * z;
            let h = (dd * z / rho2 - g) / r2;
            let gz = -dd / rho2;
            let xyh = x * y * h;
            jac = Matrix2x3::new(
                self.fx * (g + x * x * h),
                self.fx * xyh,
                self.fx * x * gz,
                self.fy * xyh,
                self.fy * (g + y * y * h),
                self.fy * y * gz,
            );
        }
        Some((uv, jac))
    }

    /// Solves `d(θ) = rd` for θ in `[0, theta_max)` by Newton's method safeguarded with
    /// bisection (`d` is increasing there); `None` if it does not converge.
    fn solve_theta(&self, rd: f64) -> Option<f64> {
        let (mut lo, mut hi) = (0.0, self.theta_max);
        let mut theta = if rd < hi { rd } else { 0.5 * hi };
        for _ in 0..MAX_ITERATIONS {
            let f = self.distortion(theta) - rd;
            // At the rounding level of `d` (near the maximum, where d' → 0, the Newton step
            // of a rounding-level residual can stay above the step tolerance).
            if f.abs() <= RESIDUAL_TOL * rd {
                return Some(theta);
            }
            if f < 0.0 {
                lo = theta;
            } else {
                hi = theta;
            }
            let dd = self.distortion_derivative(theta);
            let step = f / dd;
            let next = theta - step;
            if dd > 0.0 && next >= lo && next <= hi {
                if step.abs() <= STEP_TOL * next {
                    return Some(next);
                }
                theta = next;
            } else {
                theta = 0.5 * (lo + hi);
                if hi - lo <= STEP_TOL * theta {
                    return Some(theta);
                }
            }
        }
        None
    }
}

impl CameraModel for KannalaBrandt {
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
        let mx = (uv.x - self.cx) / self.fx;
        let my = (uv.y - self.cy) / self.fy;
        let rd = mx.hypot(my);
        if !rd.is_finite() {
            return None;
        }
        if rd == 0.0 {
            return Some(Vector3::z());
        }
        if !(rd < self.d_max) {
            return None;
        }
        let theta = self.solve_theta(rd)?;
        if !(theta < self.theta_max) {
            return None;
        }
        let (s, c) = theta.sin_cos();
        Some(Vector3::new(s * mx / rd, s * my / rd, c))
    }

    #[inline]
    fn is_valid(&self, uv: &Vector2<f64>) -> bool {
        in_image(self.width, self.height, uv) && self.unproject(uv).is_some()
    }
}
