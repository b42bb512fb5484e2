//! Trajectories too short or too static to align: whether the ground truth determines an
//! alignment, and the drift and tilt measured from the first pose instead.
//!
//! An alignment by positions (Umeyama, position+yaw) finds its rotation from how the positions
//! spread: a yaw error `δψ` moves a point at distance `r` from the centroid by `r·δψ`. A
//! trajectory that does not move (a vehicle at rest, a few centimetres of hover) leaves the
//! rotation to noise: one millimetre of estimate error over one centimetre of spread is 6° of
//! yaw, reported as a rotation error the estimator never made. Such a run is scored instead
//! against its first evaluated pose: the estimate is placed on the ground truth there (position
//! and yaw for a gravity-aligned estimate, the whole pose otherwise) and the position drift, the
//! rotation drift and, for a gravity-aligned estimate, the tilt error (the angle between the
//! estimated and the true gravity direction in the body frame, which needs no alignment) are
//! measured from there on.

use estimator::geometry::{Pose, so3_log};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use super::{Alignment, MetricsError, Sim3, Stats};

/// The ground truth must spread at least this far (m, RMS about its centroid in the directions
/// the alignment needs) for its rotation to be determined: at 0.1 m a 1 mm estimate error is
/// at most ~0.6° of alignment rotation.
pub const MIN_ALIGNMENT_SPREAD_M: f64 = 0.1;

/// How far `positions` spread in the directions `alignment` needs (m): the RMS horizontal
/// distance from the centroid for [`Alignment::PosYaw`] (one horizontal direction fixes the
/// yaw), the RMS extent along the second principal direction for SE(3)/Sim(3) (two directions
/// fix a rotation); infinite for [`Alignment::None`] and for an empty list.
pub fn alignment_spread(positions: &[Vector3<f64>], alignment: Alignment) -> f64 {
    let n = positions.len();
    if n == 0 || alignment == Alignment::None {
        return f64::INFINITY;
    }
    let mean = positions.iter().sum::<Vector3<f64>>() / n as f64;
    match alignment {
        Alignment::PosYaw => {
            let ss: f64 = positions
                .iter()
                .map(|p| (p - mean).xy().norm_squared())
                .sum();
            (ss / n as f64).sqrt()
        }
        _ => {
            let scatter: Matrix3<f64> = positions
                .iter()
                .map(|p| (p - mean) * (p - mean).transpose())
                .sum::<Matrix3<f64>>()
                / n as f64;
            let mut eig: Vec<f64> = scatter.symmetric_eigenvalues().iter().copied().collect();
            eig.sort_by(|a, b| b.total_cmp(a));
            eig[1].max(0.0).sqrt()
        }
    }
}

/// `est` scored from its first pose when `alignment` of it onto `gt` (associated,
/// equal-length lists) would be ill-posed: the ground truth spreads less than
/// [`MIN_ALIGNMENT_SPREAD_M`] in the directions the alignment needs. `None` when the ground truth
/// determines the alignment (and always for [`Alignment::None`] or no poses).
pub fn static_trajectory(
    gt: &[Pose],
    est: &[Pose],
    alignment: Alignment,
) -> Result<Option<StaticTrajectory>, MetricsError> {
    let positions: Vec<Vector3<f64>> = gt.iter().map(|p| p.p).collect();
    let spread = alignment_spread(&positions, alignment);
    if spread >= MIN_ALIGNMENT_SPREAD_M {
        return Ok(None);
    }
    let what = match alignment {
        Alignment::PosYaw => "horizontally",
        _ => "in its second direction",
    };
    Ok(Some(StaticTrajectory {
        reason: format!(
            "too short or static to align: the ground truth spreads {spread:.4} m {what} \
             (RMS about its centroid, < {MIN_ALIGNMENT_SPREAD_M} m), which leaves the \
             alignment's rotation to noise; scored from the first pose instead"
        ),
        spread_m: spread,
        drift: anchored_drift(gt, est, alignment == Alignment::PosYaw)?,
    }))
}

/// A trajectory scored from its first pose: why, and the errors.
#[derive(Clone, Debug, PartialEq)]
pub struct StaticTrajectory {
    /// Why the alignment is ill-posed.
    pub reason: String,
    /// The ground truth's spread in the directions the alignment needs (m,
    /// [`alignment_spread`]).
    pub spread_m: f64,
    /// The errors from the first pose.
    pub drift: AnchoredDrift,
}

/// Errors of an estimate placed on the ground truth at its first pose.
#[derive(Clone, Debug, PartialEq)]
pub struct AnchoredDrift {
    /// The anchoring: maps the estimate's first pose onto the ground truth's (in position and
    /// yaw, or whole).
    pub alignment: Sim3,
    /// Whether only position and yaw were anchored (a gravity-aligned estimate: tilt errors
    /// are measured) or the whole first pose.
    pub gravity_aligned: bool,
    /// Per-pose position error (m), 0 at the first pose.
    pub position_errors: Vec<f64>,
    /// Per-pose rotation error (deg) after the anchoring.
    pub rotation_errors_deg: Vec<f64>,
    /// Per-pose tilt error (deg): the angle between the estimated and the true gravity
    /// direction in the body frame (gravity-aligned estimates only; empty otherwise).
    pub tilt_errors_deg: Vec<f64>,
}

impl AnchoredDrift {
    /// The position error of the last pose (m): the drift over the trajectory.
    pub fn final_position_m(&self) -> f64 {
        self.position_errors.last().copied().unwrap_or(0.0)
    }

    /// The largest position error (m).
    pub fn max_position_m(&self) -> f64 {
        self.position_errors.iter().copied().fold(0.0, f64::max)
    }

    /// The rotation error of the last pose (deg).
    pub fn final_rotation_deg(&self) -> f64 {
        self.rotation_errors_deg.last().copied().unwrap_or(0.0)
    }

    /// Statistics of the tilt errors (deg); `None` when not gravity-aligned.
    pub fn tilt_deg(&self) -> Option<Stats> {
        Stats::from_errors(&self.tilt_errors_deg)
    }
}

/// The rotation about z closest to `r` (Frobenius norm): its yaw is
/// `atan2(r₁₀ − r₀₁, r₀₀ + r₁₁)`.
fn closest_yaw(r: &Matrix3<f64>) -> f64 {
    (r[(1, 0)] - r[(0, 1)]).atan2(r[(0, 0)] + r[(1, 1)])
}

/// Angle (deg) between the world's z axis seen from the two bodies.
fn tilt_between(gt: &UnitQuaternion<f64>, est: &UnitQuaternion<f64>) -> f64 {
    let z = Vector3::z();
    let a = gt.inverse() * z;
    let b = est.inverse() * z;
    a.cross(&b).norm().atan2(a.dot(&b)).to_degrees()
}

/// Places `est` on `gt` at their first pose (position and yaw when `gravity_aligned`, the whole
/// pose otherwise) and measures every pose's errors from there (associated, equal-length lists).
pub fn anchored_drift(
    gt: &[Pose],
    est: &[Pose],
    gravity_aligned: bool,
) -> Result<AnchoredDrift, MetricsError> {
    if gt.len() != est.len() {
        return Err(MetricsError::LengthMismatch {
            gt: gt.len(),
            est: est.len(),
        });
    }
    let (Some(g0), Some(e0)) = (gt.first(), est.first()) else {
        return Err(MetricsError::TooFewPoses {
            what: "drift from the first pose",
            have: 0,
            need: 1,
        });
    };
    let relative = (g0.q * e0.q.inverse()).to_rotation_matrix();
    let rotation = if gravity_aligned {
        Rotation3::from_axis_angle(&Vector3::z_axis(), closest_yaw(relative.matrix()))
    } else {
        relative
    };
    let alignment = Sim3 {
        rotation,
        translation: g0.p - rotation * e0.p,
        scale: 1.0,
    };
    let mut out = AnchoredDrift {
        alignment,
        gravity_aligned,
        position_errors: Vec::with_capacity(gt.len()),
        rotation_errors_deg: Vec::with_capacity(gt.len()),
        tilt_errors_deg: Vec::new(),
    };
    for (g, e) in gt.iter().zip(est) {
        let a = alignment.transform_pose(e);
        out.position_errors.push((g.p - a.p).norm());
        out.rotation_errors_deg
            .push(so3_log(&(g.q.inverse() * a.q)).norm().to_degrees());
        if gravity_aligned {
            out.tilt_errors_deg.push(tilt_between(&g.q, &e.q));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(yaw: f64, roll: f64, p: [f64; 3]) -> Pose {
        Pose::new(
            UnitQuaternion::from_euler_angles(roll, 0.0, yaw),
            Vector3::new(p[0], p[1], p[2]),
        )
    }

    #[test]
    fn spread_needs_the_directions_the_alignment_needs() {
        let line: Vec<Vector3<f64>> = (0..11)
            .map(|i| Vector3::new(0.1 * i as f64, 0.0, 1.0))
            .collect();
        // A 1 m line of 11 points: RMS radius sqrt(0.1) horizontally; nothing across it.
        assert!((alignment_spread(&line, Alignment::PosYaw) - 0.1f64.sqrt()).abs() < 1e-12);
        assert!(alignment_spread(&line, Alignment::Se3) < 1e-9);
        let vertical: Vec<Vector3<f64>> =
            (0..11).map(|i| Vector3::new(0.0, 0.0, i as f64)).collect();
        assert_eq!(alignment_spread(&vertical, Alignment::PosYaw), 0.0);
        assert_eq!(alignment_spread(&line, Alignment::None), f64::INFINITY);
    }

    #[test]
    fn a_still_trajectory_is_ill_posed_and_a_moving_one_is_not() {
        let still: Vec<Pose> = (0..20)
            .map(|i| pose(0.0, 0.0, [1e-3 * (i % 3) as f64, 0.0, 1.0]))
            .collect();
        let st = static_trajectory(&still, &still, Alignment::PosYaw)
            .unwrap()
            .expect("ill-posed");
        assert!(st.reason.contains("too short or static"), "{}", st.reason);
        assert!(st.spread_m < 1e-3 && st.drift.max_position_m() == 0.0);
        let moving: Vec<Pose> = (0..20)
            .map(|i| pose(0.0, 0.0, [0.1 * i as f64, 0.0, 1.0]))
            .collect();
        assert_eq!(
            static_trajectory(&moving, &moving, Alignment::PosYaw),
            Ok(None)
        );
    }

    #[test]
    fn anchoring_removes_yaw_and_offset_but_keeps_drift_and_tilt() {
        // The estimate's world is the truth's turned by 0.6 rad about z and shifted; it drifts 2 mm
        // along its x and its last pose is tilted by 0.5° about x more than the truth.
        let turn = UnitQuaternion::from_euler_angles(0.0, 0.0, 0.6);
        let gt: Vec<Pose> = (0..5).map(|_| pose(1.0, 0.02, [1.0, 2.0, 1.0])).collect();
        let est: Vec<Pose> = gt
            .iter()
            .enumerate()
            .map(|(i, g)| {
                let tilt = if i == 4 { 0.5f64.to_radians() } else { 0.0 };
                let q = turn * g.q * UnitQuaternion::from_euler_angles(tilt, 0.0, 0.0);
                let p = turn * g.p
                    + Vector3::new(3.0, -1.0, 0.5)
                    + turn * Vector3::new(5e-4 * i as f64, 0.0, 0.0);
                Pose::new(q, p)
            })
            .collect();
        let d = anchored_drift(&gt, &est, true).unwrap();
        assert!(d.position_errors[0] < 1e-12);
        assert!(
            (d.final_position_m() - 2e-3).abs() < 1e-9,
            "{:?}",
            d.position_errors
        );
        assert!(d.tilt_errors_deg[..4].iter().all(|t| *t < 1e-9));
        assert!(
            (d.tilt_errors_deg[4] - 0.5).abs() < 1e-6,
            "{:?}",
            d.tilt_errors_deg
        );
        assert!((d.final_rotation_deg() - 0.5).abs() < 1e-6);
        // Anchoring the whole pose: the same drift, no tilt measured.
        let full = anchored_drift(&gt, &est, false).unwrap();
        assert!((full.final_position_m() - 2e-3).abs() < 1e-9);
        assert!(full.tilt_errors_deg.is_empty());
    }
}
