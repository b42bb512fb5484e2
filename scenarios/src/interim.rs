//! INTERIM — to be replaced at merge time by `scenarios::metrics` (alignment, ATE, RPE) and
//! `scenarios::dataset` (TUM I/O), which are written on another branch. This module holds the
//! minimum the runner and reports need until then; nothing else should grow here.
//!
//! - [`tum_string`]: TUM trajectory text (`t tx ty tz qx qy qz qw`, seconds with ns precision).
//! - [`align_position_yaw`] (4-DoF, for visual-inertial estimates) and [`align_se3`] (6-DoF, for
//!   vision-only estimates whose world frame is not gravity-aligned), both without scale.
//! - [`ate`]: position and rotation RMSE after alignment; [`rpe_trans_rmse`]: translation RMSE of
//!   relative poses over a fixed time step.

use std::fmt::Write as _;

use estimator::geometry::Pose;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// A timestamped pose.
pub type Stamped = (i64, Pose);

/// Formats `t_ns` as seconds with nanosecond precision.
fn seconds(t_ns: i64) -> String {
    let sign = if t_ns < 0 { "-" } else { "" };
    let a = t_ns.unsigned_abs();
    format!("{sign}{}.{:09}", a / 1_000_000_000, a % 1_000_000_000)
}

/// TUM text of a trajectory, with a `#` header line.
pub fn tum_string(poses: &[Stamped]) -> String {
    let mut s = String::from("# timestamp tx ty tz qx qy qz qw\n");
    for (t, p) in poses {
        let q = p.q.quaternion();
        let _ = writeln!(
            s,
            "{} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}",
            seconds(*t),
            p.p.x,
            p.p.y,
            p.p.z,
            q.i,
            q.j,
            q.k,
            q.w
        );
    }
    s
}

/// A rigid alignment `x ↦ R x + t` applied to estimates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// Rotation.
    pub r: UnitQuaternion<f64>,
    /// Translation.
    pub t: Vector3<f64>,
}

impl Alignment {
    /// The aligned pose.
    pub fn apply(&self, p: &Pose) -> Pose {
        Pose::new(self.r * p.q, self.r * p.p + self.t)
    }
}

fn centroids(est: &[Vector3<f64>], gt: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let n = est.len().max(1) as f64;
    (
        est.iter().sum::<Vector3<f64>>() / n,
        gt.iter().sum::<Vector3<f64>>() / n,
    )
}

/// Least-squares rotation about z plus translation mapping `est` onto `gt` (paired).
pub fn align_position_yaw(est: &[Vector3<f64>], gt: &[Vector3<f64>]) -> Alignment {
    let (ce, cg) = centroids(est, gt);
    let (mut s, mut c) = (0.0, 0.0);
    for (e, g) in est.iter().zip(gt) {
        let (e, g) = (e - ce, g - cg);
        s += e.x * g.y - e.y * g.x;
        c += e.x * g.x + e.y * g.y;
    }
    let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), s.atan2(c));
    Alignment { r, t: cg - r * ce }
}

/// Least-squares rotation plus translation mapping `est` onto `gt` (Horn/Kabsch, no scale).
pub fn align_se3(est: &[Vector3<f64>], gt: &[Vector3<f64>]) -> Alignment {
    let (ce, cg) = centroids(est, gt);
    let mut h = Matrix3::zeros();
    for (e, g) in est.iter().zip(gt) {
        h += (g - cg) * (e - ce).transpose();
    }
    let svd = h.svd(true, true);
    let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(u * d * vt));
    Alignment { r, t: cg - r * ce }
}

/// ATE after alignment: position RMSE (m) and rotation RMSE (deg), plus per-pose position
/// errors (m).
#[derive(Clone, Debug, PartialEq)]
pub struct Ate {
    /// Position RMSE (m).
    pub rmse_m: f64,
    /// Rotation RMSE (deg).
    pub rot_rmse_deg: f64,
    /// Per-pose position error (m).
    pub errors_m: Vec<f64>,
}

/// ATE of `est` against the paired `gt` after `alignment`.
pub fn ate(est: &[Pose], gt: &[Pose], alignment: &Alignment) -> Ate {
    let mut errors_m = Vec::with_capacity(est.len());
    let (mut sp, mut sr) = (0.0, 0.0);
    for (e, g) in est.iter().zip(gt) {
        let a = alignment.apply(e);
        let d = (a.p - g.p).norm();
        let ang = g.q.angle_to(&a.q).to_degrees();
        errors_m.push(d);
        sp += d * d;
        sr += ang * ang;
    }
    let n = est.len().max(1) as f64;
    Ate {
        rmse_m: (sp / n).sqrt(),
        rot_rmse_deg: (sr / n).sqrt(),
        errors_m,
    }
}

/// Translation RMSE (m) of relative poses over pairs `(i, j)` with `j` the first pose at least
/// `delta_ns` after `i`; `None` without any pair.
pub fn rpe_trans_rmse(est: &[Stamped], gt: &[Pose], delta_ns: i64) -> Option<f64> {
    let mut sum = 0.0;
    let mut n = 0usize;
    for i in 0..est.len() {
        let target = est[i].0 + delta_ns;
        let j = est.partition_point(|(t, _)| *t < target);
        if j >= est.len() {
            break;
        }
        let rel_e = est[i].1.inverse().compose(&est[j].1);
        let rel_g = gt[i].inverse().compose(&gt[j]);
        let err = rel_g.inverse().compose(&rel_e);
        sum += err.p.norm_squared();
        n += 1;
    }
    (n > 0).then(|| (sum / n as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tum_time_has_ns_precision() {
        let p = Pose::identity();
        let s = tum_string(&[(1_000_000_001, p), (-5, p)]);
        assert!(s.contains("\n1.000000001 0.000000000"));
        assert!(s.contains("\n-0.000000005 "));
    }

    #[test]
    fn alignments_recover_a_rigid_motion() {
        let gt: Vec<Vector3<f64>> = (0..20)
            .map(|i| {
                let t = f64::from(i) * 0.3;
                Vector3::new(t.sin(), (2.0 * t).cos(), 0.1 * t)
            })
            .collect();
        let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.7);
        let est: Vec<_> = gt
            .iter()
            .map(|g| r * g + Vector3::new(1.0, 2.0, 3.0))
            .collect();
        for a in [align_position_yaw(&est, &gt), align_se3(&est, &gt)] {
            for (e, g) in est.iter().zip(&gt) {
                assert!((a.r * e + a.t - g).norm() < 1e-9);
            }
        }
    }
}
