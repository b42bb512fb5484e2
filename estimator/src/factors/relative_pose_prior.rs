//! Calibration priors that tie estimated extrinsics together.

use nalgebra::{Matrix3, SMatrix, Vector3};

use crate::geometry::{Pose, quat_from_xyzw, right_jacobian_inv, skew, so3_log};
use crate::problem::{Factor, write_row_major};

/// The relative pose of two cameras of a rig, held near its configured value while both
/// cameras' extrinsics `T_b_a`, `T_b_b` are estimated:
///
/// `r = [W_t (R_aᵀ(p_b − p_a) − t_ab); W_r log(R_abᵀ R_aᵀ R_b)]`
///
/// with `(t_ab, R_ab)` the configured `T_a_b`. A stereo rig's baseline comes from its own
/// (stereo) calibration and is known far better than where the rig sits on the IMU; two free
/// extrinsics with only their absolute priors let the baseline, and with it the metric scale of
/// every stereo depth, wander while the camera–IMU pose converges. Blocks: `T_b_a` (7/6),
/// `T_b_b` (7/6); tangents `[δp, δθ]` with the rotation perturbed on the right.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct RelativePosePrior {
    /// The configured `T_a_b`.
    pub T_a_b: Pose,
    /// σ of the relative translation (m).
    pub sigma_m: f64,
    /// σ of the relative rotation (rad).
    pub sigma_rad: f64,
}

impl Factor for RelativePosePrior {
    fn residual_dim(&self) -> usize {
        6
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 7]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let (a, b) = (params[0], params[1]);
        let (q_a, q_b) = (quat_from_xyzw(&a[3..7]), quat_from_xyzw(&b[3..7]));
        let (r_a, r_b) = (
            q_a.to_rotation_matrix().into_inner(),
            q_b.to_rotation_matrix().into_inner(),
        );
        let (p_a, p_b) = (
            Vector3::new(a[0], a[1], a[2]),
            Vector3::new(b[0], b[1], b[2]),
        );
        let (wt, wr) = (1.0 / self.sigma_m, 1.0 / self.sigma_rad);
        let x = r_a.transpose() * (p_b - p_a);
        let r_ab = r_a.transpose() * r_b;
        let q_err = self.T_a_b.q.inverse() * q_a.inverse() * q_b;
        let e = so3_log(&q_err);
        let rt = wt * (x - self.T_a_b.p);
        let rr = wr * e;
        residuals[..3].copy_from_slice(rt.as_slice());
        residuals[3..6].copy_from_slice(rr.as_slice());
        if let Some(jacs) = jacobians {
            let jr_inv = right_jacobian_inv(&e);
            let block = |dp: Matrix3<f64>, dt: Matrix3<f64>, dr: Matrix3<f64>| {
                let mut m = SMatrix::<f64, 6, 6>::zeros();
                m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(wt * dp));
                m.fixed_view_mut::<3, 3>(0, 3).copy_from(&(wt * dt));
                m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(wr * dr));
                m
            };
            if let Some(j) = jacs[0].as_deref_mut() {
                // Exp(−δθ_a) on the left of R_aᵀ: x + [x]× δθ_a, and the rotation error
                // moves by −Jr⁻¹(e) R_abᵀ δθ_a.
                let m = block(-r_a.transpose(), skew(&x), -jr_inv * r_ab.transpose());
                write_row_major(&m, j);
            }
            if let Some(j) = jacs[1].as_deref_mut() {
                let m = block(r_a.transpose(), Matrix3::zeros(), jr_inv);
                write_row_major(&m, j);
            }
        }
        residuals[..6].iter().all(|x| x.is_finite())
    }
}
