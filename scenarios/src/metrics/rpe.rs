//! Relative pose error (evo's `evo_rpe`): pose pairs and their errors.

use std::fmt;

use estimator::geometry::{Pose, so3_log};

use super::{MetricsError, Stats};

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
