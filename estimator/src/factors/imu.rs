//! The IMU preintegration factor.

use nalgebra::{Matrix3, SMatrix, UnitQuaternion, Vector3};

use crate::bias_process::BiasProcess;
use crate::geometry::{Pose, right_jacobian, right_jacobian_inv, skew, so3_log};
use crate::imu::{BiasJacobian, ImuError, O_BA, O_BG, O_P, O_R, O_V, Preintegration};
use crate::problem::{Factor, write_row_major};

/// 15-D residual between two consecutive states from preintegrated IMU measurements.
///
/// Parameter blocks: `pose_i` (7), `speed_bias_i` (9: v, ba, bg), `pose_j` (7), `speed_bias_j`.
/// Residual `[r_p, r_θ, r_v, r_ba, r_bg]`, whitened by the preintegration covariance:
/// `r_p = R_iᵀ(p_j − p_i − v_i Δt − ½gΔt²) − α̂`, `r_θ = Log(γ̂ᵀ R_iᵀ R_j)`,
/// `r_v = R_iᵀ(v_j − v_i − gΔt) − β̂`, `r_ba = ba_j − ba_i`, `r_bg = bg_j − bg_i`,
/// where α̂, β̂, γ̂ are the first-order bias-corrected deltas.
///
/// With a bias process ([`ImuFactor::with_bias_process`]) a fifth block holds the biases'
/// constant mean `c = [c_a, c_g]` (6) and the bias rows are the Gauss–Markov step
/// `r_ba = ba_j − φ ba_i − (1 − φ) c_a` (likewise `r_bg`), `φ = e^{−Δt/T}`, the wander's drive
/// variance `σ_b²(1 − φ²)` added to the random walk's ([`crate::bias_process`]).
#[derive(Clone, Debug)]
pub struct ImuFactor {
    dt: f64,
    delta_p: Vector3<f64>,
    delta_v: Vector3<f64>,
    delta_q: UnitQuaternion<f64>,
    lin_ba: Vector3<f64>,
    lin_bg: Vector3<f64>,
    bias_jacobian: BiasJacobian,
    sqrt_info: SMatrix<f64, 15, 15>,
    /// `φ` of the bias process over the interval; `None`: the biases random-walk (`φ = 1`, no
    /// mean).
    keep: Option<f64>,
}

const SIZES: [usize; 4] = [7, 9, 7, 9];
const TANGENTS: [usize; 4] = [6, 9, 6, 9];
const SIZES_WITH_MEAN: [usize; 5] = [7, 9, 7, 9, 6];
const TANGENTS_WITH_MEAN: [usize; 5] = [6, 9, 6, 9, 6];

impl ImuFactor {
    /// Snapshots `preint` into a factor. Fails if the interval is empty or its covariance is not
    /// positive definite.
    pub fn new(preint: &Preintegration) -> Result<Self, ImuError> {
        Self::build(preint, None)
    }

    /// [`ImuFactor::new`] with the biases' Gauss–Markov wander about a mean: the factor then
    /// takes the mean `[c_a, c_g]` as its fifth block.
    pub fn with_bias_process(
        preint: &Preintegration,
        process: &BiasProcess,
    ) -> Result<Self, ImuError> {
        Self::build(preint, Some(process))
    }

    fn build(preint: &Preintegration, process: Option<&BiasProcess>) -> Result<Self, ImuError> {
        if preint.dt() <= 0.0 {
            return Err(ImuError::NonIncreasingTime {
                t_ns: preint.end_ns(),
                prev_t_ns: preint.start_ns(),
            });
        }
        let mut cov = *preint.covariance();
        if let Some(p) = process {
            let (var_a, var_g) = p.drive_variances(preint.dt());
            for i in 0..3 {
                cov[(O_BA + i, O_BA + i)] += var_a;
                cov[(O_BG + i, O_BG + i)] += var_g;
            }
        }
        let sym = 0.5 * (cov + cov.transpose());
        // Σ = C Cᵀ ⇒ Σ⁻¹ = C⁻ᵀ C⁻¹, so C⁻¹ whitens the residual.
        let chol = sym.cholesky().ok_or(ImuError::NonFiniteSample {
            t_ns: preint.end_ns(),
        })?;
        let l = chol.l();
        let sqrt_info = l
            .solve_lower_triangular(&SMatrix::<f64, 15, 15>::identity())
            .ok_or(ImuError::NonFiniteSample {
                t_ns: preint.end_ns(),
            })?;
        Ok(Self {
            dt: preint.dt(),
            delta_p: *preint.delta_p(),
            delta_v: *preint.delta_v(),
            delta_q: *preint.delta_q(),
            lin_ba: *preint.linearized_ba(),
            lin_bg: *preint.linearized_bg(),
            bias_jacobian: *preint.bias_jacobian(),
            sqrt_info,
            keep: process.map(|p| p.keep(preint.dt())),
        })
    }

    /// The whitening matrix `C⁻¹` (lower triangular) with `Σ = C Cᵀ`.
    pub fn sqrt_information(&self) -> &SMatrix<f64, 15, 15> {
        &self.sqrt_info
    }

    /// Unwhitened residual at the given states (for diagnostics and tests); with a bias
    /// process, at a zero bias mean.
    pub fn raw_residual(
        &self,
        pose_i: &Pose,
        sb_i: &[f64],
        pose_j: &Pose,
        sb_j: &[f64],
    ) -> SMatrix<f64, 15, 1> {
        let mut r = SMatrix::<f64, 15, 1>::zeros();
        let mut pi = [0.0; 7];
        let mut pj = [0.0; 7];
        pose_i.write_slice(&mut pi);
        pose_j.write_slice(&mut pj);
        let mean = [0.0; 6];
        self.compute(
            &[&pi, sb_i, &pj, sb_j, &mean],
            r.as_mut_slice(),
            None,
            false,
        );
        r
    }

    fn compute(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
        whiten: bool,
    ) {
        let pose_i = Pose::from_slice(params[0]);
        let pose_j = Pose::from_slice(params[2]);
        let sb_i = params[1];
        let sb_j = params[3];
        let v3 = |s: &[f64], o: usize| Vector3::new(s[o], s[o + 1], s[o + 2]);
        let (vi, bai, bgi) = (v3(sb_i, 0), v3(sb_i, 3), v3(sb_i, 6));
        let (vj, baj, bgj) = (v3(sb_j, 0), v3(sb_j, 3), v3(sb_j, 6));
        let keep = self.keep.unwrap_or(1.0);
        let (mean_a, mean_g) = match self.keep {
            Some(_) => (v3(params[4], 0), v3(params[4], 3)),
            None => (Vector3::zeros(), Vector3::zeros()),
        };

        let dt = self.dt;
        let g = crate::gravity_w();
        let dba = bai - self.lin_ba;
        let dbg = bgi - self.lin_bg;
        let j = &self.bias_jacobian;
        let j_p_ba: Matrix3<f64> = j.fixed_view::<3, 3>(O_P, 0).into();
        let j_p_bg: Matrix3<f64> = j.fixed_view::<3, 3>(O_P, 3).into();
        let j_q_bg: Matrix3<f64> = j.fixed_view::<3, 3>(O_R, 3).into();
        let j_v_ba: Matrix3<f64> = j.fixed_view::<3, 3>(O_V, 0).into();
        let j_v_bg: Matrix3<f64> = j.fixed_view::<3, 3>(O_V, 3).into();
        let alpha = self.delta_p + j_p_ba * dba + j_p_bg * dbg;
        let beta = self.delta_v + j_v_ba * dba + j_v_bg * dbg;
        let phi_b = j_q_bg * dbg;
        let gamma = self.delta_q * crate::geometry::so3_exp(&phi_b);

        let ri_t = pose_i.q.inverse().to_rotation_matrix().into_inner();
        let rj = pose_j.q.to_rotation_matrix().into_inner();
        let dp_w = pose_j.p - pose_i.p - vi * dt - 0.5 * g * dt * dt;
        let dv_w = vj - vi - g * dt;
        let e = gamma.inverse() * pose_i.q.inverse() * pose_j.q;
        let r_theta = so3_log(&e);

        let mut r = SMatrix::<f64, 15, 1>::zeros();
        r.fixed_rows_mut::<3>(O_P).copy_from(&(ri_t * dp_w - alpha));
        r.fixed_rows_mut::<3>(O_R).copy_from(&r_theta);
        r.fixed_rows_mut::<3>(O_V).copy_from(&(ri_t * dv_w - beta));
        r.fixed_rows_mut::<3>(O_BA)
            .copy_from(&(baj - keep * bai - (1.0 - keep) * mean_a));
        r.fixed_rows_mut::<3>(O_BG)
            .copy_from(&(bgj - keep * bgi - (1.0 - keep) * mean_g));
        if whiten {
            r = self.sqrt_info * r;
        }
        residuals[..15].copy_from_slice(r.as_slice());

        let Some(jacobians) = jacobians else {
            return;
        };
        let jr_inv = right_jacobian_inv(&r_theta);
        let i3 = Matrix3::identity();
        if let Some(out) = jacobians[0].as_deref_mut() {
            let mut jm = SMatrix::<f64, 15, 6>::zeros();
            jm.fixed_view_mut::<3, 3>(O_P, 0).copy_from(&-ri_t);
            jm.fixed_view_mut::<3, 3>(O_P, 3)
                .copy_from(&skew(&(ri_t * dp_w)));
            jm.fixed_view_mut::<3, 3>(O_R, 3)
                .copy_from(&(-jr_inv * rj.transpose() * ri_t.transpose()));
            jm.fixed_view_mut::<3, 3>(O_V, 3)
                .copy_from(&skew(&(ri_t * dv_w)));
            let jm = if whiten { self.sqrt_info * jm } else { jm };
            write_row_major(&jm, out);
        }
        if let Some(out) = jacobians[1].as_deref_mut() {
            let mut jm = SMatrix::<f64, 15, 9>::zeros();
            jm.fixed_view_mut::<3, 3>(O_P, 0).copy_from(&(-ri_t * dt));
            jm.fixed_view_mut::<3, 3>(O_P, 3).copy_from(&-j_p_ba);
            jm.fixed_view_mut::<3, 3>(O_P, 6).copy_from(&-j_p_bg);
            let e_t = e.inverse().to_rotation_matrix().into_inner();
            jm.fixed_view_mut::<3, 3>(O_R, 6)
                .copy_from(&(-jr_inv * e_t * right_jacobian(&phi_b) * j_q_bg));
            jm.fixed_view_mut::<3, 3>(O_V, 0).copy_from(&-ri_t);
            jm.fixed_view_mut::<3, 3>(O_V, 3).copy_from(&-j_v_ba);
            jm.fixed_view_mut::<3, 3>(O_V, 6).copy_from(&-j_v_bg);
            jm.fixed_view_mut::<3, 3>(O_BA, 3).copy_from(&(-keep * i3));
            jm.fixed_view_mut::<3, 3>(O_BG, 6).copy_from(&(-keep * i3));
            let jm = if whiten { self.sqrt_info * jm } else { jm };
            write_row_major(&jm, out);
        }
        if let Some(out) = jacobians[2].as_deref_mut() {
            let mut jm = SMatrix::<f64, 15, 6>::zeros();
            jm.fixed_view_mut::<3, 3>(O_P, 0).copy_from(&ri_t);
            jm.fixed_view_mut::<3, 3>(O_R, 3).copy_from(&jr_inv);
            let jm = if whiten { self.sqrt_info * jm } else { jm };
            write_row_major(&jm, out);
        }
        if let Some(out) = jacobians[3].as_deref_mut() {
            let mut jm = SMatrix::<f64, 15, 9>::zeros();
            jm.fixed_view_mut::<3, 3>(O_V, 0).copy_from(&ri_t);
            jm.fixed_view_mut::<3, 3>(O_BA, 3).copy_from(&i3);
            jm.fixed_view_mut::<3, 3>(O_BG, 6).copy_from(&i3);
            let jm = if whiten { self.sqrt_info * jm } else { jm };
            write_row_major(&jm, out);
        }
        if self.keep.is_some()
            && let Some(out) = jacobians.get_mut(4).and_then(|j| j.as_deref_mut())
        {
            let mut jm = SMatrix::<f64, 15, 6>::zeros();
            jm.fixed_view_mut::<3, 3>(O_BA, 0)
                .copy_from(&(-(1.0 - keep) * i3));
            jm.fixed_view_mut::<3, 3>(O_BG, 3)
                .copy_from(&(-(1.0 - keep) * i3));
            let jm = if whiten { self.sqrt_info * jm } else { jm };
            write_row_major(&jm, out);
        }
    }
}

impl Factor for ImuFactor {
    fn residual_dim(&self) -> usize {
        15
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        match self.keep {
            Some(_) => &SIZES_WITH_MEAN,
            None => &SIZES,
        }
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        match self.keep {
            Some(_) => &TANGENTS_WITH_MEAN,
            None => &TANGENTS,
        }
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        self.compute(params, residuals, jacobians, true);
        residuals[..15].iter().all(|v| v.is_finite())
    }
}
