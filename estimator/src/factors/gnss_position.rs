//! The GNSS-like position receiver's factor ([`GnssPositionFactor`]) on one window frame's pose
//! and speed-bias and on the 4-dof alignment `T_g_w` between the odometry world frame and the
//! receiver's frame.
//!
//! Tangent conventions are the window's: pose `[δp (world), δθ (body, right)]`, speed-bias
//! `[δv, δba, δbg]`, alignment `[δt (3), δψ]` (Euclidean: `T_g_w` is a rotation by yaw `ψ`
//! about z followed by the translation `t`; both world frames are gravity-aligned, so this is
//! all that can differ between them).

use nalgebra::{Matrix3, Vector3};

use super::row_blocks::blocks;
use crate::geometry::skew;
use crate::problem::{Factor, rotation_matrix, write_row_major};

/// Size of the alignment block `[tx, ty, tz, ψ]` (ambient = tangent).
pub const ALIGNMENT_SIZE: usize = 4;

/// Rotation by `yaw` about z and its derivative with respect to `yaw`.
pub fn yaw_rotation(yaw: f64) -> (Matrix3<f64>, Matrix3<f64>) {
    let (s, c) = yaw.sin_cos();
    (
        Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
        Matrix3::new(-s, -c, 0.0, c, -s, 0.0, 0.0, 0.0, 0.0),
    )
}

/// A position fix of the receiver's antenna in the receiver's frame `g`:
///
/// `r = W · (R_z(ψ)·(p + R·l + v·dt) + t − z)`
///
/// with the frame's pose `(p, R)` and velocity `v`, the antenna's lever arm `l` in the body
/// frame, `dt` the fix time minus the frame time (the position at the fix is taken along the
/// frame's velocity; the rotation over `dt` is neglected, `|ω|·|dt|·|l|`, about 1 cm for a 0.5 m
/// lever arm turning at 1 rad/s 25 ms away), and `W = diag(1/σ)` the fix's reported accuracy.
/// Blocks: pose (7/6), speed-bias (9/9), alignment `[t, ψ]` (4/4).
#[derive(Clone, Debug)]
pub struct GnssPositionFactor {
    /// The fix `z` (m, receiver frame).
    pub z: Vector3<f64>,
    /// `1/σ` per axis (1/m).
    pub weight: Vector3<f64>,
    /// Antenna lever arm in the body frame (m).
    pub lever_arm_b: Vector3<f64>,
    /// Fix time minus frame time (s).
    pub dt_s: f64,
}

impl Factor for GnssPositionFactor {
    fn residual_dim(&self) -> usize {
        3
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 9, ALIGNMENT_SIZE]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 9, ALIGNMENT_SIZE]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let (pose, sb, align) = (params[0], params[1], params[2]);
        let p = Vector3::new(pose[0], pose[1], pose[2]);
        let r_wb = rotation_matrix(&pose[3..7]);
        let v = Vector3::new(sb[0], sb[1], sb[2]);
        let t = Vector3::new(align[0], align[1], align[2]);
        let (r_gw, d_r_gw) = yaw_rotation(align[3]);
        let antenna_w = p + r_wb * self.lever_arm_b + v * self.dt_s;
        let e = r_gw * antenna_w + t - self.z;
        let w = Matrix3::from_diagonal(&self.weight);
        let r = w * e;
        residuals[..3].copy_from_slice(r.as_slice());
        if let Some(jacs) = jacobians {
            let wr = w * r_gw;
            if let Some(j) = jacs[0].as_deref_mut() {
                // ∂/∂δp = W R_z; ∂/∂δθ = −W R_z R [l]×.
                let j_theta = -wr * r_wb * skew(&self.lever_arm_b);
                write_row_major(&blocks::<6>(&[(0, wr), (3, j_theta)]), j);
            }
            if let Some(j) = jacs[1].as_deref_mut() {
                // Only the velocity enters.
                write_row_major(&blocks::<9>(&[(0, wr * self.dt_s)]), j);
            }
            if let Some(j) = jacs[2].as_deref_mut() {
                let mut m = blocks::<ALIGNMENT_SIZE>(&[(0, w)]);
                m.set_column(3, &(w * d_r_gw * antenna_w));
                write_row_major(&m, j);
            }
        }
        residuals[..3].iter().all(|x| x.is_finite())
    }
}
