//! The window's Gauss–Newton information: the newest state's marginal covariance, and the
//! window problem itself for analysis (gauge freedoms, consistency).

use nalgebra::{DMatrix, Matrix3, Matrix6, SMatrix};

use super::Estimator;
use super::frame::{BlockRef, WindowFrame};
use super::window_problem::WindowProblem;
use crate::factors::PointForm;
use crate::geometry::{Pose, skew};
use crate::problem::{BlockId, Linearization, Problem};

/// The newest pose relative to an earlier window frame `a`, with its marginal covariance: what
/// a relative-pose consistency test (NEES) compares against the true motion between the two
/// frames. Unlike the absolute pose it is observable, yaw and position included.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct RelativePose {
    /// Time of the earlier frame `a` (IMU clock, ns).
    pub from_t_ns: i64,
    /// `T_a_b = T_w_a⁻¹ · T_w_b`, `b` the newest frame, at the solution.
    pub T_a_b: Pose,
    /// Covariance over `[δp (in a), δθ]` with `p_a_b + δp` and `R_a_b · Exp(δθ)`.
    pub covariance: Matrix6<f64>,
}

/// What the window says of its newest state's uncertainty: see [`newest_covariance`].
pub(super) struct NewestUncertainty {
    /// Pose and speed-bias covariance ([`super::Estimate::covariance`]).
    pub covariance: DMatrix<f64>,
    /// The newest pose relative to an earlier window frame, when there is a variable one.
    pub relative_pose: Option<RelativePose>,
    /// The time offset's marginal σ (s), when it is a variable.
    pub td_sigma_s: Option<f64>,
}

/// The newest state's marginal covariance (pose and speed-bias, see
/// [`super::Estimate::covariance`]), its pose relative to the window frame closest to
/// `interval_s` before it and the time offset's marginal σ, from the window solve's last
/// linearization `lin` (its landmarks eliminated by the Schur complement). One reduced-system
/// factorization serves all three. `None` if a block of the newest frame is constant or
/// absent, or the information is not positive definite.
pub(super) fn newest_covariance(
    built: &WindowProblem,
    lin: &Linearization,
    frames: &[&WindowFrame],
    interval_s: f64,
) -> Option<NewestUncertainty> {
    let (newest, earlier) = frames.split_last()?;
    let mut coords = Vec::new();
    for r in [BlockRef::Pose(newest.seq), BlockRef::SpeedBias(newest.seq)] {
        let Some(id) = built.block(r) else { continue };
        if built.problem.is_constant(id) {
            return None;
        }
        coords.extend(tangent(&built.problem, id));
    }
    let own = coords.len();
    if own == 0 {
        return None;
    }
    let target_ns = newest.t_ns - (interval_s * 1e9).round() as i64;
    let from = earlier
        .iter()
        .filter(|f| built.variable_block(BlockRef::Pose(f.seq)).is_some())
        .min_by_key(|f| ((f.t_ns - target_ns).abs(), f.seq));
    if let Some(a) = from {
        let id = built
            .variable_block(BlockRef::Pose(a.seq))
            .expect("filtered above");
        coords.extend(tangent(&built.problem, id));
    }
    let td = built.variable_block(BlockRef::Td).map(|id| {
        coords.push((id, 0));
        coords.len() - 1
    });
    let cov = lin.marginal_covariance(&coords)?;
    let relative = from.map(|a| {
        // Joint covariance of [pose a, pose b] (tangent order of each: δp world, δθ body).
        let mut joint = SMatrix::<f64, 12, 12>::zeros();
        let at = [own, 0];
        for (i, oi) in at.iter().enumerate() {
            for (j, oj) in at.iter().enumerate() {
                joint
                    .fixed_view_mut::<6, 6>(6 * i, 6 * j)
                    .copy_from(&cov.view((*oi, *oj), (6, 6)));
            }
        }
        relative_pose(a.t_ns, &a.pose, &newest.pose, &joint)
    });
    Some(NewestUncertainty {
        covariance: cov.view((0, 0), (own, own)).into_owned(),
        relative_pose: relative,
        td_sigma_s: td.map(|k| cov[(k, k)].max(0.0).sqrt()),
    })
}

fn tangent(problem: &Problem, id: BlockId) -> impl Iterator<Item = (BlockId, usize)> {
    (0..problem.manifold(id).tangent_size()).map(move |i| (id, i))
}

/// `T_a_b` and its covariance from the joint covariance of `[pose a, pose b]`, first-order:
/// `δp_ab = R_aᵀ(δp_b − δp_a) + [p_ab]× δθ_a`, `δθ_ab = δθ_b − R_abᵀ δθ_a`.
#[allow(non_snake_case)]
fn relative_pose(
    from_t_ns: i64,
    T_w_a: &Pose,
    T_w_b: &Pose,
    joint: &SMatrix<f64, 12, 12>,
) -> RelativePose {
    let T_a_b = T_w_a.inverse().compose(T_w_b);
    let r_a: Matrix3<f64> = T_w_a.q.to_rotation_matrix().into_inner();
    let r_ab: Matrix3<f64> = T_a_b.q.to_rotation_matrix().into_inner();
    let mut j = SMatrix::<f64, 6, 12>::zeros();
    j.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-r_a.transpose()));
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&skew(&T_a_b.p));
    j.fixed_view_mut::<3, 3>(0, 6).copy_from(&r_a.transpose());
    j.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(-r_ab.transpose()));
    j.fixed_view_mut::<3, 3>(3, 9)
        .copy_from(&Matrix3::identity());
    let p = j * joint * j.transpose();
    RelativePose {
        from_t_ns,
        T_a_b,
        covariance: 0.5 * (p + p.transpose()),
    }
}

/// The window as the nonlinear least-squares problem the next solve would start from (prior,
/// IMU and reprojection factors at the current estimates, first-estimate points set), with the
/// roles of its blocks. For analysis and tests; the estimator does not use it.
pub struct WindowSystem {
    /// The problem.
    pub problem: Problem,
    /// Pose block of each window frame, oldest first.
    pub poses: Vec<BlockId>,
    /// Speed-bias block of each window frame (empty without the IMU).
    pub speed_biases: Vec<BlockId>,
    /// Landmark (inverse-depth) blocks.
    pub landmarks: Vec<BlockId>,
    /// Persistent point blocks (states: the prior may hold them).
    pub points: Vec<BlockId>,
    /// What each of `points`' coordinates are.
    pub point_forms: Vec<PointForm>,
}

impl Estimator {
    /// The current window as a [`WindowSystem`]; `None` before the first frame.
    pub fn window_system(&self) -> Option<WindowSystem> {
        if self.window.frames.is_empty() {
            return None;
        }
        let imu_active = self.config.suite.uses_imu() && self.status == super::Status::Tracking;
        let built = self.window.build(&self.problem_settings(), imu_active);
        let seqs: Vec<u64> = self.window.frames.iter().map(|f| f.seq).collect();
        let poses = seqs
            .iter()
            .filter_map(|s| built.block(BlockRef::Pose(*s)))
            .collect();
        let speed_biases = seqs
            .iter()
            .filter_map(|s| built.block(BlockRef::SpeedBias(*s)))
            .collect();
        let landmarks = built.landmarks.iter().map(|(_, b)| *b).collect();
        let points = built.points.iter().map(|(_, b)| *b).collect();
        let point_forms = built
            .points
            .iter()
            .map(|(k, _)| self.window.point_form(*k))
            .collect();
        Some(WindowSystem {
            problem: built.problem,
            poses,
            speed_biases,
            landmarks,
            points,
            point_forms,
        })
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{UnitQuaternion, Vector3, Vector6};

    use super::*;
    use crate::geometry::so3_log;

    /// The first-order map of `relative_pose` against perturbing both poses on their manifold
    /// (`p + δp`, `R · Exp(δθ)`) by central differences.
    #[test]
    #[allow(non_snake_case)]
    fn relative_pose_covariance_is_the_first_order_map() {
        let T_w_a = Pose::new(
            UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1),
            Vector3::new(1.0, -2.0, 0.5),
        );
        let T_w_b = Pose::new(
            UnitQuaternion::from_euler_angles(-0.1, 0.4, 2.0),
            Vector3::new(1.7, -1.1, 0.9),
        );
        let perturb = |t: &Pose, d: &[f64]| {
            Pose::new(
                t.q * UnitQuaternion::from_scaled_axis(Vector3::new(d[3], d[4], d[5])),
                t.p + Vector3::new(d[0], d[1], d[2]),
            )
        };
        let error = |a: &Pose, b: &Pose| -> Vector6<f64> {
            let r0 = T_w_a.inverse().compose(&T_w_b);
            let r = a.inverse().compose(b);
            let mut e = Vector6::zeros();
            e.fixed_rows_mut::<3>(0).copy_from(&(r.p - r0.p));
            e.fixed_rows_mut::<3>(3)
                .copy_from(&so3_log(&(r0.q.inverse() * r.q)));
            e
        };
        // Numerical Jacobian of the relative error over [δ_a, δ_b].
        let h = 1e-6;
        let mut j = SMatrix::<f64, 6, 12>::zeros();
        for k in 0..12 {
            let mut d = [0.0; 12];
            d[k] = h;
            let plus = error(&perturb(&T_w_a, &d[..6]), &perturb(&T_w_b, &d[6..]));
            d[k] = -h;
            let minus = error(&perturb(&T_w_a, &d[..6]), &perturb(&T_w_b, &d[6..]));
            j.set_column(k, &((plus - minus) / (2.0 * h)));
        }
        // A full-rank joint covariance with cross terms.
        let l = SMatrix::<f64, 12, 12>::from_fn(|r, c| {
            if c <= r {
                0.1 + 0.01 * ((r * 7 + c * 3) % 11) as f64
            } else {
                0.0
            }
        });
        let joint = l * l.transpose();
        let rel = relative_pose(5, &T_w_a, &T_w_b, &joint);
        let want = j * joint * j.transpose();
        let err = (rel.covariance - want).amax();
        assert!(err < 1e-7 * want.amax(), "max difference {err:e}");
        assert_eq!(rel.from_t_ns, 5);
        let direct = T_w_a.inverse().compose(&T_w_b);
        assert!((rel.T_a_b.p - direct.p).norm() < 1e-12);
    }
}
