//! Robust loss functions and their application to residuals and Jacobians (Triggs correction).

/// A robust loss `ρ(s)` of the squared residual norm `s = ‖r‖²`.
pub trait LossFunction: Send + Sync + std::fmt::Debug {
    /// Returns `[ρ(s), ρ'(s), ρ''(s)]`.
    fn evaluate(&self, s: f64) -> [f64; 3];
}

/// Huber loss with threshold `delta` on the residual norm: quadratic inside, linear outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HuberLoss {
    /// Residual norm where the loss becomes linear (> 0).
    pub delta: f64,
}

impl LossFunction for HuberLoss {
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
    let sqrt_rho1 = rho[1].max(0.0).sqrt();
    // α solves ½α² − α − (ρ''/ρ') s = 0 (smaller root); no correction where ρ'' ≥ 0 or s = 0.
    let (residual_scaling, alpha_sq_norm) = if s == 0.0 || rho[2] >= 0.0 || rho[1] <= 0.0 {
        (sqrt_rho1, 0.0)
    } else {
        let d = (1.0 + 2.0 * s * rho[2] / rho[1]).max(0.0);
        let alpha = 1.0 - d.sqrt();
        (sqrt_rho1 / (1.0 - alpha), alpha / s)
    };
    let m = residuals.len();
    for jac in jacobians.iter_mut().flatten() {
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
