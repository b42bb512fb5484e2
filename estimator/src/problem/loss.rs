//! Robust loss functions and their application to residuals and Jacobians (Triggs correction).

/// A robust loss `ρ(s)` of the squared residual norm `s = ‖r‖²`.
pub trait LossFunction: Send + Sync + std::fmt::Debug {
    /// Returns `[ρ(s), ρ'(s), ρ''(s)]`.
    fn evaluate(&self, s: f64) -> [f64; 3];

    /// The largest `s` for which `evaluate(s)` is exactly `[s, 1, 0]` (the loss is the plain
    /// square there and changes nothing), or a negative number if there is no such region.
    /// The problem skips the loss for residuals inside it. Default: none.
    fn quadratic_up_to(&self) -> f64 {
        -1.0
    }
}

/// Huber loss with threshold `delta` on the residual norm: quadratic inside, linear outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HuberLoss {
    /// Residual norm where the loss becomes linear (> 0).
    pub delta: f64,
}

impl LossFunction for HuberLoss {
    fn quadratic_up_to(&self) -> f64 {
        self.delta * self.delta
    }
    fn evaluate(&self, s: f64) -> [f64; 3] {
        let b = self.delta * self.delta;
        if s <= b {
            [s, 1.0, 0.0]
        } else {
            let r = s.sqrt();
            [
                2.0 * self.delta * r - b,
                self.delta / r,
                -0.5 * self.delta / (s * r),
            ]
        }
    }
}

/// Cauchy loss `c² log(1 + s/c²)` with scale `c` on the residual norm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CauchyLoss {
    /// Scale (> 0).
    pub c: f64,
}

impl LossFunction for CauchyLoss {
    fn evaluate(&self, s: f64) -> [f64; 3] {
        let b = self.c * self.c;
        let inv = 1.0 / b;
        let sum = 1.0 + s * inv;
        let r1 = 1.0 / sum;
        [b * sum.ln(), r1, -inv * r1 * r1]
    }
}

/// Rescales a residual and its Jacobian blocks so that the Gauss-Newton model of `½ρ(‖r‖²)` is
/// `½‖r̃ + J̃ δ‖²` (Triggs et al., "Bundle Adjustment — A Modern Synthesis", §4.3; as in Ceres'
/// `Corrector`). Returns `ρ(‖r‖²)`, the robustified cost contribution ×2.
///
/// `jacobians` are row-major blocks with `residuals.len()` rows each.
pub fn apply_loss(
    loss: &dyn LossFunction,
    residuals: &mut [f64],
    jacobians: &mut [Option<&mut [f64]>],
) -> f64 {
    let s: f64 = residuals.iter().map(|r| r * r).sum();
    let rho = loss.evaluate(s);
    if rho[1] == 1.0 && rho[2] == 0.0 {
        // Inside the quadratic region (most residuals): nothing to change.
        return rho[0];
    }
    let sqrt_rho1 = rho[1].max(0.0).sqrt();
    // α solves ½α² − α − (ρ''/ρ') s = 0 (smaller root). Like Ceres, the curvature correction is
    // applied only where ρ'' > 0: for the usual robust losses (ρ'' ≤ 0) it could make the
    // Gauss-Newton Hessian indefinite (Huber's linear region even gives α = 1, a division by
    // zero), so there the residual and Jacobian are just scaled by √ρ' (IRLS).
    let (residual_scaling, alpha_sq_norm) = if s == 0.0 || rho[2] <= 0.0 || rho[1] <= 0.0 {
        (sqrt_rho1, 0.0)
    } else {
        let d = (1.0 + 2.0 * s * rho[2] / rho[1]).max(0.0);
        let alpha = 1.0 - d.sqrt();
        (sqrt_rho1 / (1.0 - alpha), alpha / s)
    };
    if residual_scaling == 1.0 && sqrt_rho1 == 1.0 && alpha_sq_norm == 0.0 {
        // Inside the quadratic region (most residuals): nothing to change.
        return rho[0];
    }
    let m = residuals.len();
    for jac in jacobians.iter_mut().flatten() {
        if alpha_sq_norm == 0.0 {
            for v in jac.iter_mut() {
                *v *= sqrt_rho1;
            }
            continue;
        }
        let cols = jac.len() / m;
        for c in 0..cols {
            // J̃ = √ρ' (I − α r rᵀ/‖r‖²) J, column by column.
            let mut dot = 0.0;
            for r in 0..m {
                dot += residuals[r] * jac[r * cols + c];
            }
            for r in 0..m {
                let v = jac[r * cols + c] - alpha_sq_norm * residuals[r] * dot;
                jac[r * cols + c] = sqrt_rho1 * v;
            }
        }
    }
    for r in residuals.iter_mut() {
        *r *= residual_scaling;
    }
    rho[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The corrected model's gradient `J̃ᵀ r̃` equals the robust cost's gradient `ρ' Jᵀ r`, and
    /// the scaled residual stays finite, inside and outside the inlier region.
    #[test]
    fn corrected_gradient_is_the_robust_gradient() {
        let losses: [&dyn LossFunction; 2] = [&HuberLoss { delta: 1.0 }, &CauchyLoss { c: 1.0 }];
        for loss in losses {
            for scale in [0.1, 0.9, 3.0, 40.0] {
                let r0 = [0.6 * scale, -0.8 * scale];
                let j0 = [1.0, 2.0, -0.5, 0.3, 0.7, 1.1]; // 2×3 row-major
                let (mut r, mut j) = (r0, j0);
                let s = r0[0] * r0[0] + r0[1] * r0[1];
                let rho = loss.evaluate(s);
                apply_loss(loss, &mut r, &mut [Some(&mut j[..])]);
                assert!(r.iter().chain(&j).all(|v| v.is_finite()));
                for c in 0..3 {
                    let corrected = j[c] * r[0] + j[3 + c] * r[1];
                    let expected = rho[1] * (j0[c] * r0[0] + j0[3 + c] * r0[1]);
                    assert!((corrected - expected).abs() < 1e-12 * (1.0 + expected.abs()));
                }
            }
        }
    }

    #[test]
    fn loss_derivatives_match_finite_differences() {
        let losses: [&dyn LossFunction; 2] = [&HuberLoss { delta: 1.5 }, &CauchyLoss { c: 2.0 }];
        for loss in losses {
            for s in [0.3, 1.0, 5.0, 100.0] {
                let h = 1e-6 * s;
                let [_, d1, d2] = loss.evaluate(s);
                let num1 = (loss.evaluate(s + h)[0] - loss.evaluate(s - h)[0]) / (2.0 * h);
                let num2 = (loss.evaluate(s + h)[1] - loss.evaluate(s - h)[1]) / (2.0 * h);
                assert!((d1 - num1).abs() < 1e-6, "{loss:?} ρ' at {s}");
                assert!((d2 - num2).abs() < 1e-6, "{loss:?} ρ'' at {s}");
            }
        }
    }
}
