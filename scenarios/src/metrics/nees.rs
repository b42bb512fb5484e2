//! NEES of estimated poses against the ground truth with the estimator's covariances.

use estimator::geometry::{Pose, so3_log};
use nalgebra::{Matrix3, Matrix6, Vector6};

use super::MetricsError;

/// The estimator's covariance of one pose.
#[derive(Clone, Copy, Debug, PartialEq)]
// Stored in plain slices, one per pose: boxing the 6×6 case would cost an allocation each.
#[allow(clippy::large_enum_variant)]
pub enum Covariance {
    /// Position only (m², world frame).
    Position(Matrix3<f64>),
    /// Full pose in the estimator's tangent order `[δp (world), δθ (body, right perturbation)]`.
    Pose(Matrix6<f64>),
}

/// Normalized estimation error squared.
#[derive(Clone, Debug, PartialEq)]
pub struct NeesResult {
    /// NEES of each pose.
    pub per_pose: Vec<f64>,
    /// Average NEES; a consistent estimator gives ≈ `dof`.
    pub mean: f64,
    /// Degrees of freedom: 3 (position) or 6 (pose).
    pub dof: usize,
}

/// NEES `eᵀ P⁻¹ e` per pose, averaged. The error is the truth relative to the estimate in the
/// estimator's convention `gt = est ⊕ e`: `e = [p_gt − p_est, Log(q_estᵀ q_gt)]` (the position
/// part alone for [`Covariance::Position`]). Poses are compared as given (no alignment): VIO
/// covariances are relative to the estimator's own gauge. All covariances must be of one kind.
pub fn nees(gt: &[Pose], est: &[Pose], cov: &[Covariance]) -> Result<NeesResult, MetricsError> {
    if gt.len() != est.len() || cov.len() != est.len() {
        return Err(MetricsError::LengthMismatch {
            gt: gt.len(),
            est: est.len().min(cov.len()),
        });
    }
    if gt.is_empty() {
        return Err(MetricsError::TooFewPoses {
            what: "NEES",
            have: 0,
            need: 1,
        });
    }
    let dof = match cov[0] {
        Covariance::Position(_) => 3,
        Covariance::Pose(_) => 6,
    };
    let mut per_pose = Vec::with_capacity(gt.len());
    for (index, ((g, e), c)) in gt.iter().zip(est).zip(cov).enumerate() {
        let dp = g.p - e.p;
        let v = match c {
            Covariance::Position(p) if dof == 3 => p
                .cholesky()
                .map(|ch| dp.dot(&ch.solve(&dp)))
                .ok_or(MetricsError::BadCovariance { index })?,
            Covariance::Pose(p) if dof == 6 => {
                let dth = so3_log(&(e.q.inverse() * g.q));
                let err = Vector6::new(dp.x, dp.y, dp.z, dth.x, dth.y, dth.z);
                p.cholesky()
                    .map(|ch| err.dot(&ch.solve(&err)))
                    .ok_or(MetricsError::BadCovariance { index })?
            }
            _ => {
                return Err(MetricsError::InvalidOption(
                    "NEES covariances mix 3×3 and 6×6 matrices".into(),
                ));
            }
        };
        if !v.is_finite() {
            return Err(MetricsError::BadCovariance { index });
        }
        per_pose.push(v);
    }
    let mean = per_pose.iter().sum::<f64>() / per_pose.len() as f64;
    Ok(NeesResult {
        per_pose,
        mean,
        dof,
    })
}
