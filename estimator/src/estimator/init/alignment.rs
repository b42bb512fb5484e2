//! Initialization helpers: gravity from the accelerometer, gyroscope bias from visual rotations,
//! and the visual-inertial alignment of velocities and gravity (VINS-Mono §V, with metric scale
//! known from stereo).

use nalgebra::{DMatrix, DVector, Matrix3, UnitQuaternion, Vector3};

use crate::geometry::{Pose, so3_log};
use crate::imu::{ImuSample, O_R, Preintegration};

/// The rotation `R_w_b` whose z-axis makes the mean specific force point up (yaw zero), from
/// samples taken while the body is not accelerating much.
pub fn gravity_aligned_rotation(samples: &[ImuSample]) -> Option<UnitQuaternion<f64>> {
    if samples.is_empty() {
        return None;
    }
    let mean = samples.iter().map(|s| s.accel).sum::<Vector3<f64>>() / samples.len() as f64;
    if mean.norm() < 1e-3 {
        return None;
    }
    // R · f̂ = e_z: the minimal rotation taking the measured "up" to the world's up.
    UnitQuaternion::rotation_between(&mean, &Vector3::z()).or_else(|| {
        Some(UnitQuaternion::from_axis_angle(
            &Vector3::x_axis(),
            std::f64::consts::PI,
        ))
    })
}

/// Gyroscope bias that best explains the visual relative rotations:
/// `min Σ ‖Log(γ̂ᵢⱼ(bg)ᵀ R_iᵀ R_j)‖²`, linearized about each interval's linearization bias.
/// `intervals[k]` is the preintegration from `poses[k]` to `poses[k + 1]`.
pub fn estimate_gyro_bias(poses: &[Pose], intervals: &[&Preintegration]) -> Option<Vector3<f64>> {
    let mut a = Matrix3::zeros();
    let mut b = Vector3::zeros();
    let bg0 = *intervals.first()?.linearized_bg();
    for (k, p) in intervals.iter().enumerate() {
        let j: Matrix3<f64> = p.bias_jacobian().fixed_view::<3, 3>(O_R, 3).into();
        // Residual at bg0 + δ: Log(γ̂ᵀ R_iᵀR_j) − J δ (first order, with γ̂ at the interval's
        // own linearization bias shifted to bg0).
        let (_, _, gamma) = p.corrected_deltas(p.linearized_ba(), &bg0);
        let rel = poses[k].q.inverse() * poses[k + 1].q;
        let r = so3_log(&(gamma.inverse() * rel));
        a += j.transpose() * j;
        b += j.transpose() * r;
    }
    let delta = a.cholesky()?.solve(&b);
    Some(bg0 + delta)
}

/// Velocities (world frame of `poses`) and gravity from visual poses with metric scale and
/// preintegrated deltas, by linear least squares; then gravity is rescaled to `g_norm` and the
/// velocities re-solved with it fixed. Returns `(velocities, gravity)`.
pub fn align_velocities_and_gravity(
    poses: &[Pose],
    intervals: &[&Preintegration],
    ba: &Vector3<f64>,
    bg: &Vector3<f64>,
    g_norm: f64,
) -> Option<(Vec<Vector3<f64>>, Vector3<f64>)> {
    let n = poses.len();
    if n < 3 || intervals.len() != n - 1 {
        return None;
    }
    let solve = |fixed_g: Option<Vector3<f64>>| -> Option<(Vec<Vector3<f64>>, Vector3<f64>)> {
        let unknowns = 3 * n + if fixed_g.is_none() { 3 } else { 0 };
        let rows = 6 * (n - 1);
        let mut a = DMatrix::<f64>::zeros(rows, unknowns);
        let mut b = DVector::<f64>::zeros(rows);
        for (k, p) in intervals.iter().enumerate() {
            let dt = p.dt();
            let ri_t = poses[k].q.inverse().to_rotation_matrix().into_inner();
            let (alpha, beta, _) = p.corrected_deltas(ba, bg);
            let r0 = 6 * k;
            // α = R_iᵀ(p_j − p_i − v_i dt − ½ g dt²)
            let mut rhs_a = alpha - ri_t * (poses[k + 1].p - poses[k].p);
            // β = R_iᵀ(v_j − v_i − g dt)
            let mut rhs_b = beta;
            a.view_mut((r0, 3 * k), (3, 3)).copy_from(&(-ri_t * dt));
            a.view_mut((r0 + 3, 3 * k), (3, 3)).copy_from(&-ri_t);
            a.view_mut((r0 + 3, 3 * (k + 1)), (3, 3)).copy_from(&ri_t);
            match fixed_g {
                None => {
                    a.view_mut((r0, 3 * n), (3, 3))
                        .copy_from(&(-ri_t * (0.5 * dt * dt)));
                    a.view_mut((r0 + 3, 3 * n), (3, 3)).copy_from(&(-ri_t * dt));
                }
                Some(g) => {
                    rhs_a += ri_t * g * (0.5 * dt * dt);
                    rhs_b += ri_t * g * dt;
                }
            }
            b.rows_mut(r0, 3).copy_from(&rhs_a);
            b.rows_mut(r0 + 3, 3).copy_from(&rhs_b);
        }
        let ata = a.transpose() * &a;
        let atb = a.transpose() * b;
        let x = ata.cholesky()?.solve(&atb);
        let v = (0..n)
            .map(|k| x.fixed_rows::<3>(3 * k).into_owned())
            .collect();
        let g = fixed_g.unwrap_or_else(|| x.fixed_rows::<3>(3 * n).into_owned());
        Some((v, g))
    };
    let (_, g) = solve(None)?;
    if !(g.norm() > 0.5 * g_norm && g.norm() < 1.5 * g_norm) {
        return None;
    }
    solve(Some(g.normalize() * g_norm))
}
