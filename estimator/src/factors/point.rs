//! Reprojection of a world point into a camera: the bundle-adjustment residual of a structure
//! from motion, where every view (the first one included) measures the point.

use nalgebra::{Matrix2x3, Matrix3, Vector2, Vector3};

use super::point_form::PointForm;
use super::reprojection::{FeatureMeasurement, write_pose};
use crate::geometry::{Pose, skew};
use crate::problem::{Factor, write_row_major};

/// `weight · ∂π/∂p` for the pinhole projection `π(p) = (p_x/p_z, p_y/p_z)` at `p`.
#[inline]
fn weighted_projection_derivative(p: &Vector3<f64>, weight: f64) -> Matrix2x3<f64> {
    let z_inv = 1.0 / p.z;
    Matrix2x3::new(
        z_inv,
        0.0,
        -p.x * z_inv * z_inv,
        0.0,
        z_inv,
        -p.y * z_inv * z_inv,
    ) * weight
}

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
            let d_proj = weighted_projection_derivative(&x_c, self.weight);
            if let Some(j) = jac[0].as_deref_mut() {
                write_pose(j, &(-d_proj * r_t), &(d_proj * skew(&x_c)));
            }
            if let Some(j) = jac[1].as_deref_mut() {
                write_row_major(&(d_proj * r_t), j);
            }
        }
        true
    }
}

/// A persistent landmark's world point `X_w` seen by camera `c` of body frame `b`: the window's
/// form of a landmark that outlives its anchor keyframe and is carried through
/// marginalization (every view, the first included, is a residual, as in [`PointProjection`]).
/// `r = weight · (π(R_b_cᵀ (R_w_bᵀ (X_w − p_w_b) − p_b_c)) − z(td))` with `z(td)` the
/// measurement shifted to the time offset along its image velocity; `X_w` is given by the
/// point's coordinates `c` in its [`PointForm`] (the projection is evaluated on the ray
/// scaled by the form's positive scale, so a point at infinity stays finite).
///
/// Parameter blocks: `T_w_b` (7/6), `T_b_c` (7/6), `c` (3/3), `td` (1/1).
#[derive(Clone, Debug)]
pub struct WorldPointProjection {
    /// The observation.
    pub obs: FeatureMeasurement,
    /// Square-root information on the normalized plane (focal / pixel σ).
    pub weight: f64,
    /// What the point block's coordinates are.
    pub form: PointForm,
}

impl Factor for WorldPointProjection {
    fn residual_dim(&self) -> usize {
        2
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 7, 3, 1]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6, 3, 1]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        self.evaluate_with_rotations(params, &[None, None], residuals, jacobians)
    }

    fn evaluate_with_rotations(
        &self,
        params: &[&[f64]],
        rotations: &[Option<&Matrix3<f64>>],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let t_w_b = Pose::from_slice(params[0]);
        let t_b_c = Pose::from_slice(params[1]);
        let c = Vector3::new(params[2][0], params[2][1], params[2][2]);
        let td = params[3][0];
        let rotation = |k: usize, pose: &Pose| match rotations.get(k).copied().flatten() {
            Some(r) => *r,
            None => pose.q.to_rotation_matrix().into_inner(),
        };
        let rb_t: Matrix3<f64> = rotation(0, &t_w_b).transpose();
        let rc_t: Matrix3<f64> = rotation(1, &t_b_c).transpose();
        // `s·p_b` and `s·p_c` with the form's scale `s > 0`: the projection needs only their
        // direction.
        let ray = self.form.ray_from(&c, &t_w_b.p);
        let p_b = rb_t * ray.h;
        let p_c = rc_t * (p_b - t_b_c.p * ray.scale);
        if !(p_c.z.is_finite() && p_c.z > 1e-9) {
            return false;
        }
        let z_inv = 1.0 / p_c.z;
        let z = self.obs.point_at_td(td);
        residuals[0] = self.weight * (p_c.x * z_inv - z.x);
        residuals[1] = self.weight * (p_c.y * z_inv - z.y);
        if let Some(jac) = jacobians {
            let d = weighted_projection_derivative(&p_c, self.weight);
            // ∂r/∂(s·p_b), then s·p_b = Exp(−δθ_b) R_bᵀ s(X − p − δp),
            // s·p_c = Exp(−δθ_c) R_cᵀ(s·p_b − s(t + δt)).
            let d_b = d * rc_t;
            if let Some(j) = jac[0].as_deref_mut() {
                write_pose(j, &(-d_b * rb_t * ray.scale), &(d_b * skew(&p_b)));
            }
            if let Some(j) = jac[1].as_deref_mut() {
                write_pose(j, &(-d_b * ray.scale), &(d * skew(&p_c)));
            }
            if let Some(j) = jac[2].as_deref_mut() {
                // World coordinates: the general form with ∂h/∂c = I and ∂s/∂c = 0.
                let d_c = match self.form {
                    PointForm::World => d_b * rb_t,
                    PointForm::InverseDistance { .. } => {
                        d_b * (rb_t * ray.dh - t_b_c.p * ray.dscale)
                    }
                };
                write_row_major(&d_c, j);
            }
            if let Some(j) = jac[3].as_deref_mut() {
                j[0] = self.weight * self.obs.velocity.x;
                j[1] = self.weight * self.obs.velocity.y;
            }
        }
        true
    }
}
