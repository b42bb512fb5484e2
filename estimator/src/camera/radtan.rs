//! Radial-tangential ("radtan", Brown–Conrady as in OpenCV and Kalibr) distortion of
//! normalized-plane coordinates, its Jacobian, and its inversion by Gauss-Newton.

use nalgebra::Matrix2;

/// Iteration cap of [`Radtan::undistort`].
const MAX_ITERATIONS: usize = 20;
/// Converged when the residual norm (normalized units) falls below this…
const RESIDUAL_TOL: f64 = 1e-15;
/// …or the step norm below this times `max(1, ‖x‖)`.
const STEP_TOL: f64 = 1e-14;
/// Step halvings allowed when a step would leave the monotonic region.
const MAX_HALVINGS: usize = 30;

/// Radial-tangential coefficients.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Radtan {
    pub k1: f64,
    pub k2: f64,
    pub p1: f64,
    pub p2: f64,
}

impl Radtan {
    /// Distorts normalized coordinates: `xd = x·radial + 2p1·xy + p2(r² + 2x²)`,
    /// `yd = y·radial + p1(r² + 2y²) + 2p2·xy`, `radial = 1 + k1 r² + k2 r⁴`.
    #[inline(always)]
    pub(crate) fn distort(&self, x: f64, y: f64) -> (f64, f64) {
        let x2 = x * x;
        let y2 = y * y;
        let xy = x * y;
        let r2 = x2 + y2;
        let radial = 1.0 + r2 * (self.k1 + self.k2 * r2);
        let xd = x * radial + 2.0 * self.p1 * xy + self.p2 * (r2 + 2.0 * x2);
        let yd = y * radial + self.p1 * (r2 + 2.0 * y2) + 2.0 * self.p2 * xy;
        (xd, yd)
    }

    /// The 2×2 Jacobian `∂(xd, yd)/∂(x, y)` (symmetric).
    #[inline(always)]
    pub(crate) fn jacobian(&self, x: f64, y: f64) -> Matrix2<f64> {
        let x2 = x * x;
        let y2 = y * y;
        let xy = x * y;
        let r2 = x2 + y2;
        let radial = 1.0 + r2 * (self.k1 + self.k2 * r2);
        // d radial / d r², and ∂r²/∂x = 2x.
        let dradial = self.k1 + 2.0 * self.k2 * r2;
        let j00 = radial + 2.0 * x2 * dradial + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
        let j01 = 2.0 * xy * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let j11 = radial + 2.0 * y2 * dradial + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
        Matrix2::new(j00, j01, j01, j11)
    }

    /// Largest `r²` up to which the radial map `r ↦ r(1 + k1 r² + k2 r⁴)` is increasing: the
    /// smallest positive root of `1 + 3k1 s + 5k2 s²` (`s = r²`), or `∞` if there is none.
    pub(crate) fn monotonic_r2_max(k1: f64, k2: f64) -> f64 {
        let a = 5.0 * k2;
        let b = 3.0 * k1;
        if a == 0.0 {
            return if b < 0.0 { -1.0 / b } else { f64::INFINITY };
        }
        let disc = b * b - 4.0 * a;
        if disc < 0.0 {
            return f64::INFINITY;
        }
        // Stable roots of a s² + b s + 1: q/a and 1/q (q ≠ 0 because a ≠ 0).
        let q = -0.5 * (b + b.signum() * disc.sqrt());
        [q / a, 1.0 / q]
            .into_iter()
            .filter(|s| *s > 0.0)
            .fold(f64::INFINITY, f64::min)
    }

    /// Inverts [`Radtan::distort`] by Gauss-Newton (Newton on the square 2-D system) from
    /// `(xd, yd)`; steps that would leave `r² < r2_max` are halved. Returns `None` if it has not
    /// converged after 20 iterations, or the solution is outside the monotonic region or where
    /// the distortion is not locally invertible.
    #[inline]
    pub(crate) fn undistort(&self, xd: f64, yd: f64, r2_max: f64) -> Option<(f64, f64)> {
        if !(xd.is_finite() && yd.is_finite()) {
            return None;
        }
        let (mut x, mut y) = (xd, yd);
        if !(x * x + y * y < r2_max) {
            // Start inside the valid region, on the same ray.
            let s = (0.5 * r2_max / (x * x + y * y)).sqrt();
            x *= s;
            y *= s;
        }
        for _ in 0..MAX_ITERATIONS {
            let (fx, fy) = self.distort(x, y);
            let ex = fx - xd;
            let ey = fy - yd;
            let j = self.jacobian(x, y);
            let det = j[(0, 0)] * j[(1, 1)] - j[(0, 1)] * j[(1, 0)];
            if !(det > 0.0) {
                return None;
            }
            if ex * ex + ey * ey <= RESIDUAL_TOL * RESIDUAL_TOL {
                return Some((x, y));
            }
            // Newton step δ = J⁻¹ e.
            let mut dx = (j[(1, 1)] * ex - j[(0, 1)] * ey) / det;
            let mut dy = (j[(0, 0)] * ey - j[(1, 0)] * ex) / det;
            let mut halvings = 0;
            while !((x - dx) * (x - dx) + (y - dy) * (y - dy) < r2_max) {
                halvings += 1;
                if halvings > MAX_HALVINGS {
                    return None;
                }
                dx *= 0.5;
                dy *= 0.5;
            }
            x -= dx;
            y -= dy;
            let step2 = dx * dx + dy * dy;
            if halvings == 0 && step2 <= STEP_TOL * STEP_TOL * (x * x + y * y).max(1.0) {
                let j = self.jacobian(x, y);
                let det = j[(0, 0)] * j[(1, 1)] - j[(0, 1)] * j[(1, 0)];
                return (det > 0.0).then_some((x, y));
            }
        }
        None
    }
}
