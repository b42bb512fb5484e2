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

/// Velocities, gravity and metric scale from an up-to-scale visual reconstruction
/// (VINS-Mono §V-B): `cam_positions[k]` is camera k's position in the SfM world (unknown
/// scale `s`), `body_rotations[k]` the body attitude `R_w_b` there, `t_b_c` the camera's
/// position in the body frame (metric). Solves `[v₀ … vₙ, g, s]` by linear least squares
/// from the preintegrated deltas, rejects |‖g‖ − `g_norm`| > 1 m/s² or `s ≤ 0`, then refines
/// gravity on its two-dimensional tangent space with its norm fixed (four relinearizations).
/// Returns `(velocities, gravity, scale)` in the SfM world's axes.
pub fn align_with_scale(
    cam_positions: &[Vector3<f64>],
    body_rotations: &[Matrix3<f64>],
    t_b_c: &Vector3<f64>,
    intervals: &[&Preintegration],
    bg: &Vector3<f64>,
    g_norm: f64,
) -> Option<(Vec<Vector3<f64>>, Vector3<f64>, f64)> {
    let n = cam_positions.len();
    if n < 3 || intervals.len() != n - 1 || body_rotations.len() != n {
        return None;
    }
    let ba = Vector3::zeros();
    // `tangent`: gravity = g₀ + B w with unknown w (2), else gravity is 3 unknowns.
    let solve = |tangent: Option<(Vector3<f64>, nalgebra::Matrix3x2<f64>)>| {
        let g_cols = if tangent.is_some() { 2 } else { 3 };
        let (g_at, s_at) = (3 * n, 3 * n + g_cols);
        let mut a = DMatrix::<f64>::zeros(6 * (n - 1), s_at + 1);
        let mut b = DVector::<f64>::zeros(6 * (n - 1));
        for (k, p) in intervals.iter().enumerate() {
            let dt = p.dt();
            let ri_t = body_rotations[k].transpose();
            let (alpha, beta, _) = p.corrected_deltas(&ba, bg);
            let r0 = 6 * k;
            // α + Rᵢᵀ(Rⱼ − Rᵢ) t_bc = s Rᵢᵀ(c̄ⱼ − c̄ᵢ) − Rᵢᵀ vᵢ dt − ½ Rᵢᵀ g dt²
            // β = Rᵢᵀ(vⱼ − vᵢ − g dt)
            let mut rhs_a = alpha + ri_t * (body_rotations[k + 1] - body_rotations[k]) * t_b_c;
            let mut rhs_b = beta;
            a.view_mut((r0, 3 * k), (3, 3)).copy_from(&(-ri_t * dt));
            a.view_mut((r0, s_at), (3, 1))
                .copy_from(&(ri_t * (cam_positions[k + 1] - cam_positions[k])));
            a.view_mut((r0 + 3, 3 * k), (3, 3)).copy_from(&-ri_t);
            a.view_mut((r0 + 3, 3 * (k + 1)), (3, 3)).copy_from(&ri_t);
            let (ga, gb) = (-ri_t * (0.5 * dt * dt), -ri_t * dt);
            match tangent {
                None => {
                    a.view_mut((r0, g_at), (3, 3)).copy_from(&ga);
                    a.view_mut((r0 + 3, g_at), (3, 3)).copy_from(&gb);
                }
                Some((g0, basis)) => {
                    rhs_a -= ga * g0;
                    rhs_b -= gb * g0;
                    a.view_mut((r0, g_at), (3, 2)).copy_from(&(ga * basis));
                    a.view_mut((r0 + 3, g_at), (3, 2)).copy_from(&(gb * basis));
                }
            }
            b.rows_mut(r0, 3).copy_from(&rhs_a);
            b.rows_mut(r0 + 3, 3).copy_from(&rhs_b);
        }
        let x = (a.transpose() * &a).cholesky()?.solve(&(a.transpose() * b));
        let v: Vec<Vector3<f64>> = (0..n)
            .map(|k| x.fixed_rows::<3>(3 * k).into_owned())
            .collect();
        let g = match tangent {
            None => x.fixed_rows::<3>(g_at).into_owned(),
            Some((g0, basis)) => g0 + basis * x.fixed_rows::<2>(g_at),
        };
        Some((v, g, x[s_at]))
    };
    let (_, g, s) = solve(None)?;
    if (g.norm() - g_norm).abs() > 1.0 || s.is_nan() || s <= 0.0 {
        return None;
    }
    let mut g = g.normalize() * g_norm;
    let mut out = None;
    for _ in 0..4 {
        let dir = g.normalize();
        let helper = if dir.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let b1 = (helper - dir * dir.dot(&helper)).normalize();
        let b2 = dir.cross(&b1);
        let basis = nalgebra::Matrix3x2::from_columns(&[b1, b2]);
        let (v, g_new, s) = solve(Some((g, basis)))?;
        g = g_new.normalize() * g_norm;
        out = Some((v, g, s));
    }
    let (v, g, s) = out?;
    (s > 0.0 && s.is_finite()).then_some((v, g, s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::so3_exp;
    use crate::imu::ImuNoise;

    /// Body pose at `t` of a smooth test motion (position, attitude).
    fn motion(t: f64) -> (Vector3<f64>, UnitQuaternion<f64>) {
        let p = Vector3::new(
            2.0 * (0.4 * t).sin(),
            (0.8 * t).sin(),
            0.2 * (0.5 * t).cos(),
        );
        let q = so3_exp(&Vector3::new(0.1 * (0.7 * t).sin(), 0.05 * t, 0.3 * t));
        (p, q)
    }

    /// The noise-free IMU reading `(gyro, accel)` at `t`, by finite differences of `motion`.
    fn sample(t: f64) -> (Vector3<f64>, Vector3<f64>) {
        let h = 1e-4;
        let (p0, q0) = motion(t - h);
        let (p1, q1) = motion(t);
        let (p2, q2) = motion(t + h);
        let acc = (p2 - 2.0 * p1 + p0) / (h * h);
        let gyro = so3_log(&(q0.inverse() * q2)) / (2.0 * h);
        (gyro, q1.inverse() * (acc - crate::gravity_w()))
    }

    /// Noise-free data and the true scale: the alignment recovers velocities, gravity and the
    /// scale of an SfM reconstruction shrunk by 1/2.5 and expressed in a rotated, shifted world.
    #[test]
    fn scale_alignment_recovers_the_truth() {
        let noise = ImuNoise {
            gyroscope_noise_density: 1.7e-4,
            accelerometer_noise_density: 2e-3,
            gyroscope_random_walk: 1.9e-5,
            accelerometer_random_walk: 3e-3,
        };
        let t_b_c = Pose::new(
            so3_exp(&Vector3::new(0.1, -1.5, 0.2)),
            Vector3::new(0.05, 0.1, -0.02),
        );
        let frames: Vec<f64> = (0..10).map(|k| 0.2 * k as f64).collect();
        // The SfM world: rotated and shifted from the gravity-aligned one, scale 1/2.5.
        let t_sfm_w = Pose::new(
            so3_exp(&Vector3::new(0.3, 0.2, -0.4)),
            Vector3::new(1.0, 2.0, 3.0),
        );
        let s_true = 2.5;
        let mut cams = Vec::new();
        let mut rots = Vec::new();
        for &t in &frames {
            let (p, q) = motion(t);
            let t_w_c = Pose::new(q, p).compose(&t_b_c);
            let c = t_sfm_w.compose(&t_w_c);
            cams.push(c.p / s_true);
            rots.push((c.q * t_b_c.q.inverse()).to_rotation_matrix().into_inner());
        }
        let mut pre = Vec::new();
        for w in frames.windows(2) {
            let n = ((w[1] - w[0]) / 0.005).round() as i64;
            let mk = |k: i64| {
                let t = w[0] + k as f64 * 0.005;
                let (g, a) = sample(t);
                ImuSample::new((t * 1e9).round() as i64, g, a).unwrap()
            };
            let mut p =
                Preintegration::new(mk(0), Vector3::zeros(), Vector3::zeros(), noise).unwrap();
            for k in 1..=n {
                p.push(mk(k)).unwrap();
            }
            pre.push(p);
        }
        let intervals: Vec<&Preintegration> = pre.iter().collect();
        let (v, g, s) = align_with_scale(
            &cams,
            &rots,
            &t_b_c.p,
            &intervals,
            &Vector3::zeros(),
            crate::GRAVITY,
        )
        .expect("aligned");
        assert!((s - s_true).abs() < 1e-3 * s_true, "scale {s}");
        let g_true = t_sfm_w.q * crate::gravity_w();
        assert!((g - g_true).norm() < 1e-3, "gravity {g:?} vs {g_true:?}");
        let h = 1e-4;
        let v0 = (motion(h).0 - motion(-h).0) / (2.0 * h);
        assert!((v[0] - t_sfm_w.q * v0).norm() < 1e-3, "v0 {:?}", v[0]);
    }
}
