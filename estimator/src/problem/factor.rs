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

    /// [`Factor::evaluate`] with the rotation matrices of the factor's blocks computed by the
    /// caller: `rotations[k]` is `R(q)` of block k's quaternion (see
    /// [`crate::problem::Manifold::rotation_offset`]), converted by
    /// [`rotation_matrix`], or `None` for blocks without a rotation. Must give exactly the
    /// results of `evaluate`; factors that need those matrices override it to skip the
    /// conversions (the solver converts each block once per pass instead of once per factor).
    /// Default: `evaluate`.
    fn evaluate_with_rotations(
        &self,
        params: &[&[f64]],
        rotations: &[Option<&nalgebra::Matrix3<f64>>],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let _ = rotations;
        self.evaluate(params, residuals, jacobians)
    }

    /// Optionally, the factor's Gauss-Newton contribution computed directly: `h = JᵀJ`
    /// (row-major, `T × T` with `T` the sum of the tangent sizes, blocks in parameter order),
    /// `g = Jᵀr`, returning `‖r‖²`. Factors with many residual rows over many blocks (the
    /// marginalization prior) can do this far cheaper than the solver's `JᵀJ`. `r` is taken at
    /// `params`, `J` at `lin_params` (the first-estimate linearization points; the same
    /// slices as `params` when there are none). An empty `h` asks for `g` and `‖r‖²` only.
    /// `None` (the default) means "use `evaluate`". Must agree with `evaluate` exactly up to
    /// round-off.
    fn normal_equations(
        &self,
        _params: &[&[f64]],
        _lin_params: &[&[f64]],
        _h: &mut [f64],
        _g: &mut [f64],
    ) -> Option<f64> {
        None
    }

    /// The `h` that [`Factor::normal_equations`] would write at `lin_params`, where the factor
    /// holds it as a constant matrix (a linear prior at its own linearization points): the
    /// solver then reads it in place instead of having it copied. `None` (the default)
    /// otherwise.
    fn constant_hessian(&self, _lin_params: &[&[f64]]) -> Option<&[f64]> {
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

/// The rotation matrix of a unit quaternion stored `[qx, qy, qz, qw]` (the conversion every
/// rotation-matrix user shares, so that precomputed and recomputed matrices agree bit for bit).
#[inline]
pub fn rotation_matrix(q_xyzw: &[f64]) -> nalgebra::Matrix3<f64> {
    crate::geometry::quat_from_xyzw(q_xyzw)
        .to_rotation_matrix()
        .into_inner()
}
