//! New first estimates for persistent points and frame positions and velocities whose first
//! estimate was far off.
//!
//! Frames: a frame held by the prior is seen by every factor at its first estimate too, and
//! the window's solution is where those Jacobians, not the true ones, are orthogonal to the
//! residuals; a first estimate far from the truth biases it. A mono+IMU start 9 % short of the
//! scale (30 Hz figure-eight, seed 1) stayed 2–3 % short for 50 s that way: each frame entered
//! the prior at the biased solution of the last. Positions and velocities that moved by more
//! than `frame_relinearize_fraction` get new first estimates the way points do (the prior is
//! linear in them); attitudes keep theirs.
//!
//! With first-estimate Jacobians every factor of a persistent world point sees the point at
//! the prior's linearization point of it. A point promoted with a poor depth then puts a wrong
//! bearing into every later observation of it for as long as it is tracked, and the window's
//! yaw follows those bearings: on the left-camera death (seed 1) eight points promoted around
//! the switch to mono+IMU drifted more than 10 % of their range from their first estimates
//! within a second, and the yaw drifted about 1° (ATE 0.0289 m). Relinearizing every point at
//! every solve instead gains information about yaw that no sensor gave, which shows on motions
//! that turn all the time (see `EstimatorConfig::first_estimate_points`).
//!
//! Between the two: a point that has moved from its first estimate by more than
//! `point_relinearize_fraction` of its range gets a new one. The prior is linear in a point, so
//! moving its linearization point changes nothing the prior says
//! ([`PriorFactor::relinearized`]); but the prior's information was built with the
//! unobservable yaw direction at the old point while the factors now use the new one, so
//! alone it would give the window yaw information (a leak of 5e-7 after 30 s in
//! `tests/gauge.rs`, as much as relinearizing every point). The prior's Jacobian is therefore
//! also changed, as little as possible and only in the columns of the moved points and the
//! frame poses, so that it says along the four unobservable directions at the new
//! linearization points what it said along them at the old ones
//! ([`PriorFactor::with_directions_moved`]), as an observability-constrained filter does; the
//! window's nullspace stays exactly four-dimensional.
//!
//! Points in inverse distance about an anchor ([`PointForm::InverseDistance`]) keep their first
//! estimates: their bearing is the anchor's observation, so a poor first distance does not turn
//! into a wrong bearing the way a poor world point does, and in these coordinates the
//! unobservable directions depend on the point itself (a shift moves `ρ` by `ρ²` times its
//! component along the ray), so moving them bends the prior's Jacobian far more. Measured at
//! 100 points with `marginalize_lost_points` (outdoor figure-eight without GNSS, 60 s, seeds
//! 1–4): relinearized 0.7181 / 0.1461 / 0.1430 / 0.1142 m (seed 1 drifts 2.6° in yaw), kept
//! 0.0466 / 0.0676 / 0.1391 / 0.0921 m.
//!
//! Kept, a poor first distance stays in every Jacobian of the point for as long as it lives.
//! With `release_drifted_points` such a point instead leaves the prior: its block is
//! marginalized out of the prior alone (exact, as the prior is linear in it, and a Schur
//! complement keeps the prior's nullspace), the prior keeping what its old observations said
//! about the frames, and the point goes on as a state the window's own observations alone
//! determine, linearized where it is, until its next observation leaves into the prior. No
//! observation is counted twice; what is lost is the link between its old and new ones.

use std::sync::Arc;

use nalgebra::Vector3;

use super::frame::BlockRef;
use super::window::Window;
use crate::factors::PointForm;
use crate::geometry::Pose;
use crate::problem::marginalization::MarginalizationOptions;
use crate::problem::{Factor, PriorFactor};

impl Window {
    /// Gives the states held by the prior whose estimates have moved far from the prior's
    /// linearization points of them new first estimates: the current ones (see the module
    /// doc). A persistent point moves when it has moved by more than `point_fraction` of its
    /// distance from the newest frame; a frame's position when it has moved by more than
    /// `frame_fraction` of its distance from the newest frame (at least 0.1 m), its velocity
    /// when by more than `frame_fraction` of the first estimate's speed (at least 0.1 m/s).
    /// A frame's attitude and biases keep theirs: the prior is linear in positions, velocities
    /// and points, so moving those is exact. Returns how many points moved; the prior stays as
    /// it was when nothing did or the new one would not be finite.
    pub fn relinearize_drifted_states(
        &mut self,
        point_fraction: f64,
        frame_fraction: f64,
        release_points: bool,
    ) -> usize {
        let (Some((factor, refs)), Some(newest)) = (&self.prior, self.frames.back()) else {
            return 0;
        };
        let p_w_b = newest.pose.p;
        let frame = |seq: &u64| self.frames.iter().find(|f| f.seq == *seq);
        // The first three coordinates of block `k` moved to `x` when they drifted past `limit`.
        let moved_to = |k: usize, x: &Vector3<f64>, limit: f64| {
            let x0 = &factor.linearization_points()[k];
            ((x - Vector3::new(x0[0], x0[1], x0[2])).norm() > limit).then(|| {
                let mut y = x0.clone();
                y[..3].copy_from_slice(x.as_slice());
                (k, y)
            })
        };
        let moves: Vec<(usize, Vec<f64>)> = refs
            .iter()
            .enumerate()
            .filter_map(|(k, r)| match r {
                BlockRef::Point(key) => {
                    // Inverse-distance points keep their first estimates (module doc).
                    let x = self
                        .points
                        .get(key)
                        .filter(|p| p.form == PointForm::World)?
                        .coords;
                    moved_to(k, &x, point_fraction * (x - p_w_b).norm())
                }
                BlockRef::Pose(seq) => {
                    let p = frame(seq)?.pose.p;
                    moved_to(k, &p, frame_fraction * (p - p_w_b).norm().max(0.1))
                }
                BlockRef::SpeedBias(seq) => {
                    let x0 = &factor.linearization_points()[k];
                    let speed0 = Vector3::new(x0[0], x0[1], x0[2]).norm();
                    moved_to(k, &frame(seq)?.v, frame_fraction * speed0.max(0.1))
                }
                _ => None,
            })
            .collect();
        let points_moved = moves
            .iter()
            .filter(|(k, _)| matches!(refs[*k], BlockRef::Point(_)))
            .count();
        // With `release_points`, inverse-distance points that drifted as far leave the prior
        // instead (module doc): those the window still observes from three frames or more.
        let released: Vec<usize> = refs
            .iter()
            .enumerate()
            .filter_map(|(k, r)| match r {
                BlockRef::Point(key) if release_points => {
                    let point = self
                        .points
                        .get(key)
                        .filter(|p| p.form != PointForm::World)?;
                    let x0 = &factor.linearization_points()[k];
                    let x = point.world();
                    let drift = (x - point.form.world(&Vector3::new(x0[0], x0[1], x0[2]))).norm();
                    if drift <= point_fraction * (x - p_w_b).norm() {
                        return None;
                    }
                    let track = self
                        .features
                        .tracks
                        .values()
                        .find(|t| t.point == Some(*key));
                    track.is_some_and(|t| t.obs.len() >= 3).then_some(k)
                }
                _ => None,
            })
            .collect();
        if moves.is_empty() && released.is_empty() {
            return 0;
        }
        let moved = if moves.is_empty() {
            None
        } else {
            let Some(moved) = self.moved_prior(factor, refs, &moves) else {
                return 0;
            };
            Some(moved)
        };
        let prior = if released.is_empty() {
            // Not empty: something moved.
            let Some(moved) = moved else { return 0 };
            (Arc::new(moved), refs.clone())
        } else {
            // The prior without the released points: their blocks marginalized out of it alone.
            let threshold = MarginalizationOptions::default().eigen_threshold;
            let Ok(marginal) = moved
                .as_ref()
                .unwrap_or(factor)
                .marginalized(&released, threshold)
            else {
                return 0;
            };
            let kept = (0..refs.len())
                .filter(|k| !released.contains(k))
                .map(|k| refs[k])
                .collect();
            (Arc::new(marginal), kept)
        };
        self.prior = Some(prior);
        points_moved + released.len()
    }

    /// `prior` with the blocks `moves` names at their new linearization points and, while the
    /// window's nullspace is unobservable, its Jacobian carrying the four unobservable
    /// directions along (module doc); `None` when either step fails.
    fn moved_prior(
        &self,
        prior: &PriorFactor,
        refs: &[BlockRef],
        moves: &[(usize, Vec<f64>)],
    ) -> Option<PriorFactor> {
        let borrowed: Vec<(usize, &[f64])> =
            moves.iter().map(|(k, x)| (*k, x.as_slice())).collect();
        let moved = prior.relinearized(&borrowed).ok()?;
        let form_of = |key: u64| self.point_form(key);
        // A GNSS alignment in the prior makes the global frame observable: nothing to keep.
        match (
            gauge_directions(prior, refs, &form_of),
            gauge_directions(&moved, refs, &form_of),
        ) {
            (Some(from), Some(to)) => {
                let columns = geometry_columns(&moved, refs, moves);
                moved.with_directions_moved(&from, &to, &columns).ok()
            }
            _ => Some(moved),
        }
    }
}

/// The tangent coordinates of `prior` that the correction of its Jacobian may change: the
/// moved points and velocities and the frame poses, the states that observations of a point
/// connect.
/// Spreading it over every coordinate instead (the plain least change) put most of it on the
/// other points far from the world origin, whose yaw direction is largest, and changed what
/// the prior says about them: a ground vehicle in a hall with distant points lost 10–70 % of
/// its accuracy (`hall_ground_vehicle_stereo_imu`, seeds 1 and 2: 0.0690 / 0.0440 m against
/// 0.0373 / 0.0353 m without relinearization, 0.0399 / 0.0406 m with these columns).
fn geometry_columns(
    prior: &PriorFactor,
    refs: &[BlockRef],
    moves: &[(usize, Vec<f64>)],
) -> Vec<bool> {
    let mut columns = Vec::with_capacity(prior.tangent_dim());
    for (k, (r, t)) in refs.iter().zip(prior.parameter_tangent_sizes()).enumerate() {
        let touched = match r {
            BlockRef::Pose(_) => true,
            BlockRef::Point(_) | BlockRef::SpeedBias(_) => moves.iter().any(|(j, _)| *j == k),
            _ => false,
        };
        columns.extend(std::iter::repeat_n(touched, *t));
    }
    columns
}

/// The four unobservable directions of visual-inertial odometry (global x, y, z, and yaw
/// about gravity) in the tangent space of `prior`'s blocks at its linearization points; `None`
/// when the prior holds the GNSS alignment (the directions are then observable).
///
/// A global translation `t` moves positions and points by `t`; a yaw `δψ` about world z moves
/// a position or point `x` by `δψ e_z × x`, a velocity `v` by `δψ e_z × v`, and a body
/// attitude by `δψ R_w_bᵀ e_z` in its body-frame tangent. Biases, extrinsics and the time offset
/// do not move.
pub(super) fn gauge_directions(
    prior: &PriorFactor,
    refs: &[BlockRef],
    form_of: &dyn Fn(u64) -> PointForm,
) -> Option<Vec<Vec<f64>>> {
    if refs.contains(&BlockRef::GnssAlignment) {
        return None;
    }
    let n = prior.tangent_dim();
    let mut null = vec![vec![0.0; n]; 4];
    let mut off = 0;
    let z = Vector3::z();
    let tangents = prior.parameter_tangent_sizes();
    for ((r, x), t) in refs.iter().zip(prior.linearization_points()).zip(tangents) {
        match r {
            BlockRef::Pose(_) => {
                let pose = Pose::from_slice(x);
                let dp = z.cross(&pose.p);
                let dth = pose.q.inverse() * z;
                for i in 0..3 {
                    null[i][off + i] = 1.0;
                    null[3][off + i] = dp[i];
                    null[3][off + 3 + i] = dth[i];
                }
            }
            // Velocity first, then the biases.
            BlockRef::SpeedBias(_) => {
                let dv = z.cross(&Vector3::new(x[0], x[1], x[2]));
                for i in 0..3 {
                    null[3][off + i] = dv[i];
                }
            }
            BlockRef::Point(key) => {
                // In the point's own coordinates: what the world displacement asks of them.
                let form = form_of(*key);
                let c = Vector3::new(x[0], x[1], x[2]);
                let yaw = form.coordinates_step(&c, &z.cross(&form.world(&c)));
                for i in 0..3 {
                    let shift = form.coordinates_step(&c, &Vector3::ith(i, 1.0));
                    for j in 0..3 {
                        null[i][off + j] = shift[j];
                    }
                    null[3][off + i] = yaw[i];
                }
            }
            BlockRef::Extrinsic(_)
            | BlockRef::Td
            | BlockRef::GnssAlignment
            | BlockRef::BiasMean => {}
        }
        off += t;
    }
    debug_assert_eq!(off, n, "tangent sizes of the window's blocks");
    Some(null)
}

#[cfg(test)]
mod tests {
    use nalgebra::{UnitQuaternion, Vector3};

    use super::*;
    use crate::problem::{Euclidean, Manifold, PoseManifold};

    /// The directions are what a global shift and a global yaw do to the states, in the
    /// tangent conventions of their manifolds: `(T(ε) x) ⊟ x ≈ ε N` for a small ε, to
    /// first order, with biases, the extrinsic and the time offset left alone.
    #[test]
    fn gauge_directions_are_global_shifts_and_yaw() {
        let manifolds: Vec<Arc<dyn Manifold>> = vec![
            Arc::new(PoseManifold),
            Arc::new(Euclidean::new(9)),
            Arc::new(Euclidean::new(3)),
            Arc::new(PoseManifold),
            Arc::new(Euclidean::new(1)),
            Arc::new(Euclidean::new(3)),
        ];
        let pose = Pose {
            q: UnitQuaternion::from_euler_angles(0.2, -0.3, 1.1),
            p: Vector3::new(1.5, -2.0, 0.7),
        };
        let extrinsic = Pose {
            q: UnitQuaternion::from_euler_angles(-1.5, 0.0, -1.5),
            p: Vector3::new(0.0, 0.05, 0.0),
        };
        // The second point as inverse distance about a camera at `pose`.
        let anchor_frame = pose.q.to_rotation_matrix().into_inner();
        let far = pose.p + anchor_frame * Vector3::new(2.0, -1.0, 25.0);
        let (form, c) = PointForm::anchored(pose.p, anchor_frame, &far).expect("in front");
        let x = vec![
            pose.to_array().to_vec(),
            vec![0.4, -0.8, 0.1, 0.05, -0.04, 0.08, 0.003, -0.002, 0.0015],
            vec![3.0, 1.0, -0.5],
            extrinsic.to_array().to_vec(),
            vec![0.002],
            c.as_slice().to_vec(),
        ];
        let refs = [
            BlockRef::Pose(0),
            BlockRef::SpeedBias(0),
            BlockRef::Point(0),
            BlockRef::Extrinsic(0),
            BlockRef::Td,
            BlockRef::Point(1),
        ];
        let n = 6 + 9 + 3 + 6 + 1 + 3;
        let prior =
            PriorFactor::new(manifolds.clone(), x.clone(), vec![0.0; n], vec![0.0]).unwrap();
        let form_of = |key: u64| if key == 1 { form } else { PointForm::World };
        let null = gauge_directions(&prior, &refs, &form_of).unwrap();
        let eps = 1e-6;
        // A global motion of every state: rotation `q_g` then shift `t_g`.
        let moved = |q_g: UnitQuaternion<f64>, t_g: Vector3<f64>| -> Vec<Vec<f64>> {
            let v = |s: &[f64]| Vector3::new(s[0], s[1], s[2]);
            let p = Pose {
                q: q_g * pose.q,
                p: q_g * pose.p + t_g,
            };
            let mut sb = x[1].clone();
            sb[..3].copy_from_slice((q_g * v(&x[1])).as_slice());
            let point = q_g * v(&x[2]) + t_g;
            let (anchor, frame) = match form {
                PointForm::InverseDistance { anchor, frame } => (anchor, frame),
                PointForm::World => unreachable!(),
            };
            let (_, far_c) = PointForm::anchored(anchor, frame, &(q_g * far + t_g)).unwrap();
            vec![
                p.to_array().to_vec(),
                sb,
                point.as_slice().to_vec(),
                x[3].clone(),
                x[4].clone(),
                far_c.as_slice().to_vec(),
            ]
        };
        let motions = [
            (UnitQuaternion::identity(), Vector3::x() * eps),
            (UnitQuaternion::identity(), Vector3::y() * eps),
            (UnitQuaternion::identity(), Vector3::z() * eps),
            (
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), eps),
                Vector3::zeros(),
            ),
        ];
        for (dir, (q_g, t_g)) in motions.into_iter().enumerate() {
            let y = moved(q_g, t_g);
            let mut off = 0;
            for (k, m) in manifolds.iter().enumerate() {
                let t = m.tangent_size();
                let mut d = vec![0.0; t];
                m.minus(&y[k], &x[k], &mut d);
                for i in 0..t {
                    let want = d[i] / eps;
                    let got = null[dir][off + i];
                    assert!(
                        (want - got).abs() < 1e-5,
                        "direction {dir}, block {k}, coordinate {i}: {got} vs {want}"
                    );
                }
                off += t;
            }
        }
        let with_gnss = [BlockRef::GnssAlignment];
        let gnss_prior = PriorFactor::new(
            vec![Arc::new(PoseManifold)],
            vec![Pose::identity().to_array().to_vec()],
            vec![0.0; 6],
            vec![0.0],
        )
        .unwrap();
        assert!(gauge_directions(&gnss_prior, &with_gnss, &|_| PointForm::World).is_none());
    }
}
