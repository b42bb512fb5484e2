//! The `Factor` trait: a residual block over parameter blocks (Ceres' `CostFunction`).

/// A residual `r(x₁, …, xₙ)` over parameter blocks, with analytic Jacobians.
///
/// Jacobians are taken with respect to each block's **tangent-space** perturbation,
/// `∂r(xₖ ⊞ δ)/∂δ` at `δ = 0`, so no ambient-to-tangent product is needed in the solver (a
/// departure from Ceres, which returns ambient Jacobians and multiplies by the manifold's
/// plus-Jacobian). Each block is a row-major `residual_dim × tangent_size` buffer.
pub trait Factor: Send + Sync {
    /// Number of residuals.
    fn residual_dim(&self) -> usize;
    /// Stored (ambient) size of each parameter block, in order.
    fn parameter_block_sizes(&self) -> &[usize];
    /// Tangent size of each parameter block, in order (the Jacobian column counts).
    fn parameter_tangent_sizes(&self) -> &[usize];
    /// Evaluates residuals and, where `jacobians` holds `Some(buffer)` for block k, that block's
    /// Jacobian. Returns `false` when the residual cannot be evaluated at these parameters
    /// (e.g. a point behind the camera); the caller then rejects the step.
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool;

    /// Optionally, the factor's Gauss-Newton contribution computed directly: `h = JᵀJ`
    /// (row-major, `T × T` with `T` the sum of the tangent sizes, blocks in parameter order),
    /// `g = Jᵀr`, returning `‖r‖²`. Factors with many residual rows over many blocks (the
    /// marginalization prior) can do this far cheaper than the solver's `JᵀJ`. `None` (the
    /// default) means "use `evaluate`". Must agree with `evaluate` exactly up to round-off.
    fn normal_equations(&self, _params: &[&[f64]], _h: &mut [f64], _g: &mut [f64]) -> Option<f64> {
        None
    }
}

/// Copies a column-major nalgebra matrix into a row-major buffer.
#[inline]
pub fn write_row_major<const R: usize, const C: usize>(
    m: &nalgebra::SMatrix<f64, R, C>,
    out: &mut [f64],
) {
    for r in 0..R {
        for c in 0..C {
            out[r * C + c] = m[(r, c)];
        }
    }
}
