//! The one Jacobian checker every factor test uses (Ceres' `GradientChecker`, GTSAM's
//! `EXPECT_CORRECT_FACTOR_JACOBIANS`): analytic Jacobians against central differences taken in
//! each block's tangent space.

use super::{Factor, Manifold};

/// Tolerances for [`check_factor_jacobians`].
#[derive(Clone, Copy, Debug)]
pub struct CheckOptions {
    /// Central-difference step in the tangent space.
    pub step: f64,
    /// Relative tolerance: `|analytic − numeric| ≤ rel_tol · max(1, max|numeric| of the block)`.
    pub rel_tol: f64,
}

impl Default for CheckOptions {
    fn default() -> Self {
        Self {
            step: 1e-6,
            rel_tol: 1e-5,
        }
    }
}

/// Where a Jacobian check failed.
#[derive(Clone, Debug)]
pub struct JacobianMismatch {
    /// Parameter block index.
    pub block: usize,
    /// Residual row and tangent column of the worst entry.
    pub row: usize,
    /// Tangent column of the worst entry.
    pub col: usize,
    /// Analytic value at the worst entry.
    pub analytic: f64,
    /// Numeric (central-difference) value at the worst entry.
    pub numeric: f64,
    /// The tolerance the entry violated.
    pub tolerance: f64,
}

impl std::fmt::Display for JacobianMismatch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "block {} entry ({}, {}): analytic {:.9e} vs numeric {:.9e} (|diff| {:.3e} > tol {:.3e})",
            self.block,
            self.row,
            self.col,
            self.analytic,
            self.numeric,
            (self.analytic - self.numeric).abs(),
            self.tolerance
        )
    }
}

/// Why a check could not pass.
#[derive(Clone, Debug)]
pub enum CheckError {
    /// The factor declined to evaluate at the given point or a perturbed one.
    EvaluationFailed {
        /// Which evaluation: `None` = the nominal point, `Some((block, col, sign))` a perturbation.
        at: Option<(usize, usize, i8)>,
    },
    /// Block sizes disagree between the factor, the parameters and the manifolds.
    SizeMismatch(String),
    /// Residuals or Jacobians contain NaN/∞.
    NonFinite,
    /// An analytic Jacobian disagrees with central differences.
    Mismatch(JacobianMismatch),
}

impl std::fmt::Display for CheckError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CheckError::EvaluationFailed { at } => write!(f, "evaluation failed at {at:?}"),
            CheckError::SizeMismatch(s) => write!(f, "size mismatch: {s}"),
            CheckError::NonFinite => write!(f, "non-finite residual or Jacobian"),
            CheckError::Mismatch(m) => write!(f, "{m}"),
        }
    }
}

impl std::error::Error for CheckError {}

/// Compares `factor`'s analytic Jacobians with central differences at `params`.
///
/// `manifolds[k]` describes block k. The numeric Jacobian column for tangent direction `e_d` is
/// `(r(x ⊞ h e_d) − r(x ⊞ −h e_d)) / 2h`. Also checks that evaluating with and without Jacobians
/// gives the same residuals. Returns the worst relative error over all blocks on success.
pub fn check_factor_jacobians(
    factor: &dyn Factor,
    params: &[Vec<f64>],
    manifolds: &[&dyn Manifold],
    options: CheckOptions,
) -> Result<f64, CheckError> {
    let sizes = factor.parameter_block_sizes();
    let tangents = factor.parameter_tangent_sizes();
    if sizes.len() != params.len()
        || manifolds.len() != params.len()
        || tangents.len() != params.len()
    {
        return Err(CheckError::SizeMismatch(format!(
            "factor has {} blocks, given {} parameter blocks and {} manifolds",
            sizes.len(),
            params.len(),
            manifolds.len()
        )));
    }
    for k in 0..params.len() {
        if params[k].len() != sizes[k]
            || manifolds[k].ambient_size() != sizes[k]
            || manifolds[k].tangent_size() != tangents[k]
        {
            return Err(CheckError::SizeMismatch(format!("block {k}")));
        }
    }
    let m = factor.residual_dim();
    let views: Vec<&[f64]> = params.iter().map(|p| p.as_slice()).collect();

    let mut r0 = vec![0.0; m];
    let mut jac_store: Vec<Vec<f64>> = tangents.iter().map(|t| vec![0.0; m * t]).collect();
    {
        let mut jacs: Vec<Option<&mut [f64]>> = jac_store
            .iter_mut()
            .map(|j| Some(j.as_mut_slice()))
            .collect();
        if !factor.evaluate(&views, &mut r0, Some(&mut jacs)) {
            return Err(CheckError::EvaluationFailed { at: None });
        }
    }
    let mut r_plain = vec![0.0; m];
    if !factor.evaluate(&views, &mut r_plain, None) {
        return Err(CheckError::EvaluationFailed { at: None });
    }
    if r0
        .iter()
        .chain(jac_store.iter().flatten())
        .any(|v| !v.is_finite())
    {
        return Err(CheckError::NonFinite);
    }
    for i in 0..m {
        if (r0[i] - r_plain[i]).abs() > 1e-12 * (1.0 + r0[i].abs()) {
            return Err(CheckError::SizeMismatch(format!(
                "residual {i} differs with/without Jacobians: {} vs {}",
                r0[i], r_plain[i]
            )));
        }
    }

    let h = options.step;
    let mut worst = 0.0f64;
    let mut rp = vec![0.0; m];
    let mut rm = vec![0.0; m];
    for k in 0..params.len() {
        let t = tangents[k];
        let mut numeric = vec![0.0; m * t];
        let mut delta = vec![0.0; t];
        let mut xp = vec![0.0; sizes[k]];
        let mut xm = vec![0.0; sizes[k]];
        for d in 0..t {
            delta.fill(0.0);
            delta[d] = h;
            manifolds[k].plus(&params[k], &delta, &mut xp);
            delta[d] = -h;
            manifolds[k].plus(&params[k], &delta, &mut xm);
            let mut pv = views.clone();
            pv[k] = &xp;
            if !factor.evaluate(&pv, &mut rp, None) {
                return Err(CheckError::EvaluationFailed {
                    at: Some((k, d, 1)),
                });
            }
            pv[k] = &xm;
            if !factor.evaluate(&pv, &mut rm, None) {
                return Err(CheckError::EvaluationFailed {
                    at: Some((k, d, -1)),
                });
            }
            for i in 0..m {
                numeric[i * t + d] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let scale = numeric.iter().fold(1.0f64, |a, v| a.max(v.abs()));
        let tol = options.rel_tol * scale;
        let mut worst_entry: Option<JacobianMismatch> = None;
        for i in 0..m {
            for d in 0..t {
                let a = jac_store[k][i * t + d];
                let n = numeric[i * t + d];
                let err = (a - n).abs();
                worst = worst.max(err / scale);
                if err > tol
                    && worst_entry
                        .as_ref()
                        .is_none_or(|w| err > (w.analytic - w.numeric).abs())
                {
                    worst_entry = Some(JacobianMismatch {
                        block: k,
                        row: i,
                        col: d,
                        analytic: a,
                        numeric: n,
                        tolerance: tol,
                    });
                }
            }
        }
        if let Some(w) = worst_entry {
            return Err(CheckError::Mismatch(w));
        }
    }
    Ok(worst)
}
