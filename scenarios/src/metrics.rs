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

use std::fmt;
use std::str::FromStr;

use estimator::geometry::{Pose, so3_log};
use nalgebra::{Matrix3, Matrix6, Rotation3, UnitQuaternion, Vector3, Vector6};

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
// Association

/// Associates two timestamp lists one-to-one: returns `(i, j)` index pairs with
/// `|a[i] − b[j]| ≤ max_diff_ns`, sorted by `i`.
///
/// Pairs are accepted greedily in order of increasing time difference (ties broken by `i`, then
/// `j`), each index used at most once: exact nanosecond matches come first, then nearest
/// neighbours. Deterministic. When every timestamp of the sparser list has a unique nearest
/// neighbour in the other (the usual case of regular sampling with a tolerance below half the
/// period), this equals evo's association (`--t_max_diff`), which matches each timestamp of the
/// shorter trajectory to its nearest neighbour in the longer one without enforcing uniqueness.
/// One more difference: evo compares float seconds, so for a timestamp exactly halfway between two
/// others its rounding may pick the later neighbour where we pick the earlier. Inputs need not be
/// sorted.
pub fn associate(a: &[i64], b: &[i64], max_diff_ns: i64) -> Vec<(usize, usize)> {
    let tol = max_diff_ns.max(0) as u64;
    let mut bo: Vec<usize> = (0..b.len()).collect();
    bo.sort_by_key(|&j| (b[j], j));
    let bs: Vec<i64> = bo.iter().map(|&j| b[j]).collect();
    let dist = |t: i64, k: usize| (i128::from(bs[k]) - i128::from(t)).unsigned_abs() as u64;
    let mut used_b = vec![false; b.len()];

    // Lazy greedy matching: the global order of all candidate pairs (|Δt|, i, j) is produced by
    // merging, per i, its candidates in increasing (|Δt|, j) order, so memory stays O(n + m)
    // whatever the tolerance. Per i, two boundaries walk outwards from the insertion point over
    // used entries of b: `left[i]` (one past the nearest unused entry below) and `right[i]`.
    // A candidate is only asked for again once it has been used, so skipping used entries is
    // all the advancing needed.
    let mut left: Vec<usize> = Vec::with_capacity(a.len());
    let mut right: Vec<usize> = Vec::with_capacity(a.len());
    for &t in a {
        let p = bs.partition_point(|&s| s < t);
        left.push(p);
        right.push(p);
    }
    let next = |i: usize, left: &mut [usize], right: &mut [usize], used_b: &[bool]| {
        let t = a[i];
        while left[i] > 0 && used_b[bo[left[i] - 1]] {
            left[i] -= 1;
        }
        while right[i] < bs.len() && used_b[bo[right[i]]] {
            right[i] += 1;
        }
        // Below: among equal timestamps the smallest j comes first, i.e. the lowest unused
        // index of the run of equal stamps that ends at the boundary.
        let l = (left[i] > 0)
            .then(|| {
                let end = left[i] - 1;
                let mut k = end;
                while k > 0 && bs[k - 1] == bs[end] {
                    k -= 1;
                }
                (k..=end).find(|&k| !used_b[bo[k]]).unwrap_or(end)
            })
            .map(|k| (dist(t, k), bo[k]))
            .filter(|c| c.0 <= tol);
        let r = (right[i] < bs.len())
            .then_some(right[i])
            .map(|k| (dist(t, k), bo[k]))
            .filter(|c| c.0 <= tol);
        let (d, j) = match (l, r) {
            (Some(x), Some(y)) => Some(x.min(y)),
            (x, y) => x.or(y),
        }?;
        Some(std::cmp::Reverse((d, i, j)))
    };
    let mut heap = std::collections::BinaryHeap::new();
    for i in 0..a.len() {
        if let Some(c) = next(i, &mut left, &mut right, &used_b) {
            heap.push(c);
        }
    }
    let mut pairs = Vec::new();
    while let Some(std::cmp::Reverse((_, i, j))) = heap.pop() {
        if used_b[j] {
            if let Some(c) = next(i, &mut left, &mut right, &used_b) {
                heap.push(c);
            }
        } else {
            used_b[j] = true;
            pairs.push((i, j));
        }
    }
    pairs.sort_unstable();
    pairs
}

/// Associates two trajectories (see [`associate`]) and returns the matched pose lists
/// `(ground truth, estimate)` in ground-truth order, plus the index pairs.
pub fn associate_trajectories(
    gt: &[StampedPose],
    est: &[StampedPose],
    max_diff_ns: i64,
) -> Result<Matched, MetricsError> {
    let ta: Vec<i64> = gt.iter().map(|s| s.t_ns).collect();
    let tb: Vec<i64> = est.iter().map(|s| s.t_ns).collect();
    let pairs = associate(&ta, &tb, max_diff_ns);
    if pairs.is_empty() {
        return Err(MetricsError::NoMatches {
            gt: gt.len(),
            est: est.len(),
            max_diff_ns,
        });
    }
    Ok(Matched {
        gt: pairs.iter().map(|&(i, _)| gt[i]).collect(),
        est: pairs.iter().map(|&(_, j)| est[j]).collect(),
        pairs,
    })
}

/// Two associated trajectories of equal length.
#[derive(Clone, Debug, PartialEq)]
pub struct Matched {
    /// Matched ground-truth poses.
    pub gt: Vec<StampedPose>,
    /// Matched estimated poses (same length and order as `gt`).
    pub est: Vec<StampedPose>,
    /// `(ground-truth index, estimate index)` into the original lists.
    pub pairs: Vec<(usize, usize)>,
}

// ---------------------------------------------------------------------------------------------
// Alignment

/// Which transform aligns the estimate to the ground truth before the errors are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Alignment {
    /// No alignment.
    None,
    /// Rotation + translation (Umeyama without scale; `evo_ape -a`).
    #[default]
    Se3,
    /// Rotation + translation + scale (Umeyama; `evo_ape -a --correct_scale`).
    Sim3,
    /// Translation + rotation about the gravity (z) axis: the 4 DoF unobservable in VIO.
    PosYaw,
}

impl Alignment {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Alignment::None => "none",
            Alignment::Se3 => "se3",
            Alignment::Sim3 => "sim3",
            Alignment::PosYaw => "posyaw",
        }
    }
}

impl fmt::Display for Alignment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Alignment {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "none" => Ok(Alignment::None),
            "se3" => Ok(Alignment::Se3),
            "sim3" => Ok(Alignment::Sim3),
            "posyaw" => Ok(Alignment::PosYaw),
            _ => Err(format!(
                "unknown alignment `{s}` (expected se3, sim3, posyaw or none)"
            )),
        }
    }
}

/// A similarity transform `x ↦ s R x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sim3 {
    /// Rotation `R`.
    pub rotation: Rotation3<f64>,
    /// Translation `t`.
    pub translation: Vector3<f64>,
    /// Scale `s` (1 for SE3 and 4-DoF alignment).
    pub scale: f64,
}

impl Sim3 {
    /// The identity.
    pub fn identity() -> Self {
        Self {
            rotation: Rotation3::identity(),
            translation: Vector3::zeros(),
            scale: 1.0,
        }
    }

    /// `s R x + t`.
    pub fn transform_point(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * (x * self.scale) + self.translation
    }

    /// Applies the transform to a pose `T_w_b` (as evo does: scale the position, then
    /// left-multiply by `[R | t]`).
    pub fn transform_pose(&self, p: &Pose) -> Pose {
        let q = UnitQuaternion::from_rotation_matrix(&self.rotation) * p.q;
        Pose::new(q, self.transform_point(&p.p))
    }
}

fn mean(points: &[Vector3<f64>]) -> Vector3<f64> {
    points.iter().sum::<Vector3<f64>>() / points.len() as f64
}

/// Umeyama's closed form (IEEE PAMI 1991): the `s, R, t` minimizing `Σ ‖dst_i − (s R src_i + t)‖²`
/// (`s = 1` unless `with_scale`). Needs at least three non-collinear points.
pub fn umeyama(
    src: &[Vector3<f64>],
    dst: &[Vector3<f64>],
    with_scale: bool,
) -> Result<Sim3, MetricsError> {
    if src.len() != dst.len() {
        return Err(MetricsError::LengthMismatch {
            gt: dst.len(),
            est: src.len(),
        });
    }
    let n = src.len();
    if n < 3 {
        return Err(MetricsError::TooFewPoses {
            what: "Umeyama alignment",
            have: n,
            need: 3,
        });
    }
    let mx = mean(src);
    let my = mean(dst);
    let mut sigma_x = 0.0;
    let mut cov = Matrix3::zeros();
    for (x, y) in src.iter().zip(dst) {
        let dx = x - mx;
        sigma_x += dx.norm_squared();
        cov += (y - my) * dx.transpose();
    }
    let inv_n = 1.0 / n as f64;
    sigma_x *= inv_n;
    cov *= inv_n;
    let svd = cov.svd(true, true); // singular values sorted in decreasing order
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(MetricsError::Degenerate("SVD did not converge".into()));
    };
    let d = svd.singular_values;
    if !(d[0].is_finite() && d[0] > 0.0) || d[1] <= d[0] * 1e-12 {
        return Err(MetricsError::Degenerate(
            "the positions are (nearly) collinear or identical: Umeyama alignment is not possible"
                .into(),
        ));
    }
    let mut s = Matrix3::identity();
    if u.determinant() * v_t.determinant() < 0.0 {
        s[(2, 2)] = -1.0;
    }
    let r = u * s * v_t;
    let scale = if with_scale {
        (d[0] * s[(0, 0)] + d[1] * s[(1, 1)] + d[2] * s[(2, 2)]) / sigma_x
    } else {
        1.0
    };
    let t = my - r * mx * scale;
    Ok(Sim3 {
        rotation: Rotation3::from_matrix_unchecked(r),
        translation: t,
        scale,
    })
}

/// Position + yaw alignment (4 DoF): the rotation about z and the translation minimizing
/// `Σ ‖dst_i − (R_z(ψ) src_i + t)‖²`. Closed form: with centred points `a_i`, `b_i`,
/// `ψ = atan2(Σ a_x b_y − a_y b_x, Σ a_x b_x + a_y b_y)` and `t = mean(dst) − R_z(ψ) mean(src)`.
pub fn align_position_yaw(
    src: &[Vector3<f64>],
    dst: &[Vector3<f64>],
) -> Result<Sim3, MetricsError> {
    if src.len() != dst.len() {
        return Err(MetricsError::LengthMismatch {
            gt: dst.len(),
            est: src.len(),
        });
    }
    let n = src.len();
    if n < 2 {
        return Err(MetricsError::TooFewPoses {
            what: "position+yaw alignment",
            have: n,
            need: 2,
        });
    }
    let mx = mean(src);
    let my = mean(dst);
    let (mut dot, mut cross, mut spread_a, mut spread_b) = (0.0, 0.0, 0.0, 0.0);
    for (x, y) in src.iter().zip(dst) {
        let a = x - mx;
        let b = y - my;
        dot += a.x * b.x + a.y * b.y;
        cross += a.x * b.y - a.y * b.x;
        spread_a += a.x * a.x + a.y * a.y;
        spread_b += b.x * b.x + b.y * b.y;
    }
    if dot.hypot(cross) <= 1e-12 * (spread_a * spread_b).sqrt() || spread_a == 0.0 {
        return Err(MetricsError::Degenerate(
            "the horizontal positions do not determine a yaw".into(),
        ));
    }
    let yaw = cross.atan2(dot);
    let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), yaw);
    Ok(Sim3 {
        rotation,
        translation: my - rotation * mx,
        scale: 1.0,
    })
}

/// The alignment of `est` onto `gt` (equal-length, associated pose lists) by positions.
pub fn estimate_alignment(
    gt: &[Pose],
    est: &[Pose],
    alignment: Alignment,
) -> Result<Sim3, MetricsError> {
    let src: Vec<Vector3<f64>> = est.iter().map(|p| p.p).collect();
    let dst: Vec<Vector3<f64>> = gt.iter().map(|p| p.p).collect();
    match alignment {
        Alignment::None => {
            if src.len() != dst.len() {
                return Err(MetricsError::LengthMismatch {
                    gt: dst.len(),
                    est: src.len(),
                });
            }
            Ok(Sim3::identity())
        }
        Alignment::Se3 => umeyama(&src, &dst, false),
        Alignment::Sim3 => umeyama(&src, &dst, true),
        Alignment::PosYaw => align_position_yaw(&src, &dst),
    }
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
// RPE

/// The spacing of RPE pose pairs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RpeDelta {
    /// Index distance (evo `--delta N --delta_unit f`).
    Frames(usize),
    /// Travelled path length in metres (evo `--delta D --delta_unit m`).
    Meters(f64),
}

impl fmt::Display for RpeDelta {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RpeDelta::Frames(n) => write!(f, "{n} f"),
            RpeDelta::Meters(d) => write!(f, "{d} m"),
        }
    }
}

/// Whose path lengths select the pose pairs of a distance-based RPE.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PairsFrom {
    /// The ground truth (evo `--pairs_from_reference`). Our default: pairs do not depend on the
    /// estimate's noise.
    #[default]
    Reference,
    /// The (aligned) estimate: evo's default.
    Estimate,
}

/// Which pose pairs the RPE compares.
///
/// - [`RpeDelta::Frames`]`(Δ)`: consecutive pairs `(0, Δ), (Δ, 2Δ), ...`, or with `all_pairs`
///   every `(i, i + Δ)`.
/// - [`RpeDelta::Meters`]`(Δ)`: consecutive mode walks along the trajectory chosen by
///   `pairs_from`, summing the distances between successive positions; the first pose is an
///   anchor, and each pose at which the sum since the last anchor reaches `Δ` becomes the next
///   anchor (the sum restarts at zero). Pairs are successive anchors, so each pair spans a
///   travelled path of at least `Δ` (exceeding it by less than one step). With `all_pairs`, for
///   every pose `i` the later pose `j` whose path length from `i` is closest to `Δ` is taken if
///   it is within `tol_m` of `Δ`.
///
/// Both are evo's definitions (`evo.core.filters.filter_pairs_by_index` / `_by_path`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RpeOptions {
    /// Pair spacing.
    pub delta: RpeDelta,
    /// Use all pairs instead of consecutive ones.
    pub all_pairs: bool,
    /// Path tolerance (m) for `all_pairs` with a distance delta (evo's `rel_delta_tol`, 0.1).
    pub tol_m: f64,
    /// Which trajectory's path selects the pairs of a distance-based delta.
    pub pairs_from: PairsFrom,
}

impl Default for RpeOptions {
    fn default() -> Self {
        Self {
            delta: RpeDelta::Meters(1.0),
            all_pairs: false,
            tol_m: 0.1,
            pairs_from: PairsFrom::Reference,
        }
    }
}

impl RpeOptions {
    /// Consecutive pairs `Δ` frames apart (`evo_rpe --delta Δ --delta_unit f`).
    pub fn frames(delta: usize) -> Self {
        Self {
            delta: RpeDelta::Frames(delta),
            ..Self::default()
        }
    }

    /// Consecutive pairs `Δ` metres of ground-truth path apart.
    pub fn meters(delta: f64) -> Self {
        Self {
            delta: RpeDelta::Meters(delta),
            ..Self::default()
        }
    }
}

/// The pose pairs selected by `opts` on `poses` (see [`RpeOptions`]).
pub fn rpe_pairs(poses: &[Pose], opts: &RpeOptions) -> Result<Vec<(usize, usize)>, MetricsError> {
    let n = poses.len();
    match opts.delta {
        RpeDelta::Frames(d) => {
            if d == 0 {
                return Err(MetricsError::InvalidOption(
                    "RPE frame delta must be ≥ 1".into(),
                ));
            }
            Ok(if opts.all_pairs {
                (0..n.saturating_sub(d)).map(|i| (i, i + d)).collect()
            } else {
                let anchors: Vec<usize> = (0..n).step_by(d).collect();
                anchors.windows(2).map(|w| (w[0], w[1])).collect()
            })
        }
        RpeDelta::Meters(d) => {
            if !(d.is_finite() && d > 0.0) {
                return Err(MetricsError::InvalidOption(format!(
                    "RPE distance delta must be finite and > 0, got {d}"
                )));
            }
            if n == 0 {
                return Ok(Vec::new());
            }
            if opts.all_pairs {
                if !(opts.tol_m.is_finite() && opts.tol_m >= 0.0) {
                    return Err(MetricsError::InvalidOption(format!(
                        "RPE path tolerance must be finite and ≥ 0, got {}",
                        opts.tol_m
                    )));
                }
                let mut acc = vec![0.0; n];
                for k in 1..n {
                    acc[k] = acc[k - 1] + (poses[k].p - poses[k - 1].p).norm();
                }
                let mut pairs = Vec::new();
                for i in 0..n.saturating_sub(1) {
                    // First j minimizing |acc[j] − acc[i] − d| (numpy's argmin keeps the first).
                    let mut best = i + 1;
                    let mut best_err = f64::INFINITY;
                    for j in i + 1..n {
                        let e = ((acc[j] - acc[i]) - d).abs();
                        if e < best_err {
                            best_err = e;
                            best = j;
                        }
                    }
                    if best_err <= opts.tol_m {
                        pairs.push((i, best));
                    }
                }
                Ok(pairs)
            } else {
                let mut anchors = vec![0usize];
                let mut path = 0.0;
                for k in 1..n {
                    path += (poses[k].p - poses[k - 1].p).norm();
                    if path >= d {
                        anchors.push(k);
                        path = 0.0;
                    }
                }
                Ok(anchors.windows(2).map(|w| (w[0], w[1])).collect())
            }
        }
    }
}

/// Relative pose error.
#[derive(Clone, Debug, PartialEq)]
pub struct RpeResult {
    /// The options used.
    pub options: RpeOptions,
    /// The compared index pairs.
    pub pairs: Vec<(usize, usize)>,
    /// Translation errors (m).
    pub translation: Stats,
    /// Rotation errors (deg).
    pub rotation_deg: Stats,
}

/// RPE of associated pose lists (`gt[i]` ↔ `est[i]`); `est` should already be aligned when the
/// alignment has a scale or when pairs come from the estimate. Errors if no pair qualifies.
pub fn rpe(gt: &[Pose], est: &[Pose], opts: &RpeOptions) -> Result<RpeResult, MetricsError> {
    if gt.len() != est.len() {
        return Err(MetricsError::LengthMismatch {
            gt: gt.len(),
            est: est.len(),
        });
    }
    let pairs = match opts.pairs_from {
        PairsFrom::Reference => rpe_pairs(gt, opts)?,
        PairsFrom::Estimate => rpe_pairs(est, opts)?,
    };
    let mut te = Vec::with_capacity(pairs.len());
    let mut re = Vec::with_capacity(pairs.len());
    for &(i, j) in &pairs {
        let q_rel = gt[i].inverse().compose(&gt[j]);
        let p_rel = est[i].inverse().compose(&est[j]);
        let e = q_rel.inverse().compose(&p_rel);
        te.push(e.p.norm());
        re.push(so3_log(&e.q).norm().to_degrees());
    }
    match (Stats::from_errors(&te), Stats::from_errors(&re)) {
        (Some(translation), Some(rotation_deg)) => Ok(RpeResult {
            options: *opts,
            pairs,
            translation,
            rotation_deg,
        }),
        _ => Err(MetricsError::InvalidOption(format!(
            "no pose pairs for RPE with delta {} ({} poses)",
            opts.delta,
            gt.len()
        ))),
    }
}

// ---------------------------------------------------------------------------------------------
// NEES

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
    let ate = ate(&g, &e, opts.alignment)?;
    let aligned: Vec<Pose> = e.iter().map(|p| ate.alignment.transform_pose(p)).collect();
    let rpe = opts.rpe.iter().map(|o| rpe(&g, &aligned, o)).collect();
    Ok(Evaluation { matched, ate, rpe })
}
