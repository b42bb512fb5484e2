//! Wheel odometry's factor ([`BodyVelocityFactor`]) on one window frame's pose and speed-bias
//! (tangents as the window's: pose `[δp (world), δθ (body, right)]`, speed-bias `[δv, δba, δbg]`).

use nalgebra::{Matrix3, Vector3};

use super::row_blocks::blocks;
use crate::geometry::skew;
use crate::problem::{Factor, rotation_matrix, write_row_major};

/// Wheel odometry: the body-frame velocity `u = Rᵀ·v` against the wheels' forward speed `s`,
/// with the non-holonomic constraint of a vehicle that neither slides sideways nor jumps:
///
/// `r = [(u_x − s)/σ_s, u_y/σ_n, u_z/σ_n]`
///
/// The body frame is the vehicle frame (x forward, the IMU at the rear axle's centre, so the
/// wheels' speed is the body origin's). Blocks: pose (7/6), speed-bias (9/9).
#[derive(Clone, Debug)]
pub struct BodyVelocityFactor {
    /// Measured forward speed (m/s).
    pub speed_m_s: f64,
    /// σ of the forward speed (m/s).
    pub speed_sigma: f64,
    /// σ of the lateral and vertical velocity (m/s).
    pub lateral_sigma: f64,
}

impl Factor for BodyVelocityFactor {
    fn residual_dim(&self) -> usize {
        3
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 9]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 9]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let (pose, sb) = (params[0], params[1]);
        let r_wb = rotation_matrix(&pose[3..7]);
        let v = Vector3::new(sb[0], sb[1], sb[2]);
        let u = r_wb.transpose() * v;
        let w = Vector3::new(
            1.0 / self.speed_sigma,
            1.0 / self.lateral_sigma,
            1.0 / self.lateral_sigma,
        );
        residuals[0] = w[0] * (u.x - self.speed_m_s);
        residuals[1] = w[1] * u.y;
        residuals[2] = w[2] * u.z;
        if let Some(jacs) = jacobians {
            let wm = Matrix3::from_diagonal(&w);
            if let Some(j) = jacs[0].as_deref_mut() {
                // (R·Exp(δθ))ᵀ v ≈ u + [u]× δθ; the position does not enter.
                write_row_major(&blocks::<6>(&[(3, wm * skew(&u))]), j);
            }
            if let Some(j) = jacs[1].as_deref_mut() {
                // Only the velocity enters.
                write_row_major(&blocks::<9>(&[(0, wm * r_wb.transpose())]), j);
            }
        }
        residuals[..3].iter().all(|x| x.is_finite())
    }
}
