//! Trajectory metrics with evo's definitions: timestamp association, Umeyama alignment (SE3,
//! Sim3) and position+yaw (4-DoF) alignment, ATE, RPE and NEES.
//!
//! Conventions (those of `evo_ape` / `evo_rpe`, so that the numbers agree with evo to round-off):
//! - The estimate is aligned to the ground truth: `x_gt ≈ s R x_est + t` over the associated
//!   positions (least squares, Umeyama 1991). The aligned estimate pose is `(R q_est, s R p_est + t)`.
//! - ATE translation error of pose i: `‖p_gt,i − p_est,i‖` after alignment (evo's
//!   `translation_part` of `T_gt⁻¹ T_est`, which has the same norm). ATE rotation error: the angle
//!   of `R_gt,iᵀ R_est,i` in degrees (evo's `-r angle_deg`).
//! - RPE of a pose pair (i, j): `E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j)` with Q ground truth and P the
//!   aligned estimate; the translation error is `‖t(E)‖`, the rotation error the angle of `R(E)`.
//!   Which pairs are used is set by [`RpeOptions`] (see there).
//! - Statistics ([`Stats`]) as evo prints them: rmse, mean, median, std (population), min, max, sse.

mod align;
mod anchored;
mod associate;
mod nees;
mod rpe;

pub use align::{Alignment, Sim3, align_position_yaw, estimate_alignment, umeyama};
pub use anchored::{
    AnchoredDrift, MIN_ALIGNMENT_SPREAD_M, StaticTrajectory, alignment_spread, anchored_drift,
    static_trajectory,
};
pub use associate::{Matched, associate, associate_trajectories};
pub use nees::{Covariance, NeesResult, nees};
pub use rpe::{PairsFrom, RpeDelta, RpeOptions, RpeResult, rpe, rpe_pairs};

use estimator::geometry::{Pose, so3_log};
use nalgebra::UnitQuaternion;

use crate::dataset::StampedPose;

/// evo's default `--t_max_diff`: 10 ms.
pub const DEFAULT_MAX_DIFF_NS: i64 = 10_000_000;

/// Errors from the metrics.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MetricsError {
    /// Association found no pair of timestamps within the tolerance.
    #[error(
        "no matching timestamps between ground truth ({gt} poses) and estimate ({est} poses) with max. time difference {max_diff_ns} ns"
    )]
    NoMatches {
        /// Number of ground-truth poses.
        gt: usize,
        /// Number of estimated poses.
        est: usize,
        /// The tolerance used (ns).
        max_diff_ns: i64,
    },
    /// The two pose lists handed to a metric differ in length.
    #[error("pose lists differ in length: {gt} ground-truth vs {est} estimated poses")]
    LengthMismatch {
        /// Number of ground-truth poses.
        gt: usize,
        /// Number of estimated poses (or covariances).
        est: usize,
    },
    /// Too few poses for the requested computation.
    #[error("{have} poses are too few for {what} (need at least {need})")]
    TooFewPoses {
        /// What was attempted.
        what: &'static str,
        /// Poses available.
        have: usize,
        /// Poses needed.
        need: usize,
    },
    /// The positions do not determine the alignment (all equal, or collinear for SE3/Sim3).
    #[error("degenerate geometry: {0}")]
    Degenerate(String),
    /// A covariance matrix is not symmetric positive definite.
    #[error("covariance of pose {index} is not positive definite")]
    BadCovariance {
        /// Index of the pose.
        index: usize,
    },
    /// A delta or tolerance was out of range, or no pose pair satisfied it.
    #[error("{0}")]
    InvalidOption(String),
}

// ---------------------------------------------------------------------------------------------
// Statistics

/// Summary statistics of an error list, as evo prints them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    /// Number of values.
    pub count: usize,
    /// `sqrt(mean(e²))`.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median (mean of the two middle values for an even count, like numpy).
    pub median: f64,
    /// Population standard deviation (numpy's `np.std`).
    pub std: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
    /// Sum of squares.
    pub sse: f64,
}

impl Stats {
    /// Statistics of `errors`; `None` when empty.
    pub fn from_errors(errors: &[f64]) -> Option<Stats> {
        let n = errors.len();
        if n == 0 {
            return None;
        }
        let nf = n as f64;
        let sse: f64 = errors.iter().map(|e| e * e).sum();
        let mean = errors.iter().sum::<f64>() / nf;
        let var = errors.iter().map(|e| (e - mean) * (e - mean)).sum::<f64>() / nf;
        let mut sorted = errors.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            sorted[n / 2]
        } else {
            0.5 * (sorted[n / 2 - 1] + sorted[n / 2])
        };
        Some(Stats {
            count: n,
            rmse: (sse / nf).sqrt(),
            mean,
            median,
            std: var.sqrt(),
            min: sorted[0],
            max: sorted[n - 1],
            sse,
        })
    }
}

/// Rotation angle (rad, in `[0, π]`) of `a⁻¹ b`.
fn angle_between(a: &UnitQuaternion<f64>, b: &UnitQuaternion<f64>) -> f64 {
    so3_log(&(a.inverse() * b)).norm()
}

// ---------------------------------------------------------------------------------------------
// ATE

/// Absolute trajectory error.
#[derive(Clone, Debug, PartialEq)]
pub struct AteResult {
    /// The alignment applied to the estimate.
    pub alignment: Sim3,
    /// Translation errors (m).
    pub translation: Stats,
    /// Rotation errors (deg).
    pub rotation_deg: Stats,
    /// Per-pose translation error (m), in input order.
    pub translation_errors: Vec<f64>,
    /// Per-pose rotation error (deg), in input order.
    pub rotation_errors_deg: Vec<f64>,
}

/// ATE of associated pose lists (`gt[i]` ↔ `est[i]`) after the given alignment.
pub fn ate(gt: &[Pose], est: &[Pose], alignment: Alignment) -> Result<AteResult, MetricsError> {
    if gt.len() != est.len() {
        return Err(MetricsError::LengthMismatch {
            gt: gt.len(),
            est: est.len(),
        });
    }
    if gt.is_empty() {
        return Err(MetricsError::TooFewPoses {
            what: "ATE",
            have: 0,
            need: 1,
        });
    }
    let s = estimate_alignment(gt, est, alignment)?;
    ate_aligned(gt, est, s)
}

/// ATE of associated pose lists after `alignment` where the ground truth determines it, else
/// after the anchoring at the first pose of a trajectory too short or static to align (with
/// why, and the drift and tilt errors: [`static_trajectory`]).
pub fn ate_or_anchored(
    gt: &[Pose],
    est: &[Pose],
    alignment: Alignment,
) -> Result<(AteResult, Option<StaticTrajectory>), MetricsError> {
    let st = static_trajectory(gt, est, alignment)?;
    let ate = match &st {
        Some(s) => ate_aligned(gt, est, s.drift.alignment)?,
        None => ate(gt, est, alignment)?,
    };
    Ok((ate, st))
}

/// ATE of associated pose lists after a given alignment `s` of the estimate.
pub fn ate_aligned(gt: &[Pose], est: &[Pose], s: Sim3) -> Result<AteResult, MetricsError> {
    if gt.len() != est.len() {
        return Err(MetricsError::LengthMismatch {
            gt: gt.len(),
            est: est.len(),
        });
    }
    let aligned: Vec<Pose> = est.iter().map(|p| s.transform_pose(p)).collect();
    let te: Vec<f64> = gt
        .iter()
        .zip(&aligned)
        .map(|(g, e)| (g.p - e.p).norm())
        .collect();
    let re: Vec<f64> = gt
        .iter()
        .zip(&aligned)
        .map(|(g, e)| angle_between(&g.q, &e.q).to_degrees())
        .collect();
    let too_few = MetricsError::TooFewPoses {
        what: "ATE",
        have: 0,
        need: 1,
    };
    let translation = Stats::from_errors(&te).ok_or(too_few.clone())?;
    let rotation_deg = Stats::from_errors(&re).ok_or(too_few)?;
    Ok(AteResult {
        alignment: s,
        translation,
        rotation_deg,
        translation_errors: te,
        rotation_errors_deg: re,
    })
}

// ---------------------------------------------------------------------------------------------
// Everything at once

/// Options of [`evaluate`].
#[derive(Clone, Debug, PartialEq)]
pub struct EvalOptions {
    /// Alignment of the estimate.
    pub alignment: Alignment,
    /// Association tolerance (ns).
    pub max_diff_ns: i64,
    /// The RPE variants to compute (on the aligned estimate).
    pub rpe: Vec<RpeOptions>,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            alignment: Alignment::Se3,
            max_diff_ns: DEFAULT_MAX_DIFF_NS,
            rpe: vec![RpeOptions::meters(1.0), RpeOptions::frames(1)],
        }
    }
}

/// Results of [`evaluate`].
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// The associated trajectories (estimate not aligned).
    pub matched: Matched,
    /// ATE after alignment.
    pub ate: AteResult,
    /// One entry per requested RPE variant: its result, or why there is none (e.g. a path
    /// shorter than the delta).
    pub rpe: Vec<Result<RpeResult, MetricsError>>,
    /// A ground truth too short or static to determine the alignment's rotation: why, and the
    /// errors from the first pose, which replace the ATE's rotation (`None` otherwise, and with
    /// [`Alignment::None`]).
    pub static_trajectory: Option<StaticTrajectory>,
}

/// Associates, aligns and computes ATE and RPE, as `evo_ape` / `evo_rpe` do.
pub fn evaluate(
    gt: &[StampedPose],
    est: &[StampedPose],
    opts: &EvalOptions,
) -> Result<Evaluation, MetricsError> {
    let matched = associate_trajectories(gt, est, opts.max_diff_ns)?;
    let g: Vec<Pose> = matched.gt.iter().map(|s| s.pose).collect();
    let e: Vec<Pose> = matched.est.iter().map(|s| s.pose).collect();
    let (ate, static_trajectory) = ate_or_anchored(&g, &e, opts.alignment)?;
    let aligned: Vec<Pose> = e.iter().map(|p| ate.alignment.transform_pose(p)).collect();
    let rpe = opts.rpe.iter().map(|o| rpe(&g, &aligned, o)).collect();
    Ok(Evaluation {
        matched,
        ate,
        rpe,
        static_trajectory,
    })
}
