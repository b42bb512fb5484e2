//! Reprojection of a world point into a camera: the bundle-adjustment residual of a structure
//! from motion, where every view (the first one included) measures the point.

use nalgebra::{Matrix2x3, Matrix3, Vector2, Vector3};

#[cfg(doc)]
use super::reprojection::FeatureMeasurement;
use crate::geometry::{Pose, skew};
use crate::problem::{Factor, write_row_major};

/// A world point `X_w` seen by a camera with pose `T_w_c` at the normalized point `obs`:
/// `r = weight · (π(R_w_cᵀ (X_w − p_w_c)) − obs)` with `π(x) = (x/z, y/z)`.
///
/// Parameter blocks: `T_w_c` (pose, 7/6), `X_w` (3/3). Unlike the inverse-depth factors it
/// treats no view as exact, so the Gauss-Newton information gives honest pose covariances.
#[derive(Clone, Debug)]
pub struct PointProjection {
    /// Normalized observation (already shifted to the time offset in use, see
    /// [`FeatureMeasurement::point_at_td`]).
    pub obs: Vector2<f64>,
    /// Square-root information on the normalized plane (focal / pixel σ).
    pub weight: f64,
}

impl Factor for PointProjection {
    fn residual_dim(&self) -> usize {
        2
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 3]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 3]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let t_w_c = Pose::from_slice(params[0]);
        let x_w = Vector3::new(params[1][0], params[1][1], params[1][2]);
        let r_t: Matrix3<f64> = t_w_c.q.to_rotation_matrix().into_inner().transpose();
        let x_c = r_t * (x_w - t_w_c.p);
        if x_c.z.is_nan() || x_c.z <= 1e-9 {
            return false;
        }
        let z_inv = 1.0 / x_c.z;
        let proj = Vector2::new(x_c.x * z_inv, x_c.y * z_inv);
        let r = (proj - self.obs) * self.weight;
        residuals[0] = r.x;
        residuals[1] = r.y;
        if let Some(jac) = jacobians {
            // ∂π/∂x_c, then x_c = Exp(−δθ) Rᵀ(X − p − δp): ∂/∂δp = −Rᵀ, ∂/∂δθ = [x_c]×,
            // ∂/∂X = Rᵀ.
            let d_proj = Matrix2x3::new(
                z_inv,
                0.0,
                -x_c.x * z_inv * z_inv,
                0.0,
                z_inv,
                -x_c.y * z_inv * z_inv,
            ) * self.weight;
            if let Some(j) = jac[0].as_deref_mut() {
                let mut m = nalgebra::SMatrix::<f64, 2, 6>::zeros();
                m.fixed_view_mut::<2, 3>(0, 0).copy_from(&(-d_proj * r_t));
                m.fixed_view_mut::<2, 3>(0, 3)
                    .copy_from(&(d_proj * skew(&x_c)));
                write_row_major(&m, j);
            }
            if let Some(j) = jac[1].as_deref_mut() {
                write_row_major(&(d_proj * r_t), j);
            }
        }
        true
    }
}
