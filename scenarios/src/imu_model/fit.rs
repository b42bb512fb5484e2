//! The noise model fitted to an Allan deviation curve: white noise density `N`, bias
//! instability `B` and random walk `K`.
//!
//! `σ²(τ) = N²/τ + (2 ln2/π)·B² + K²·τ/3`: linear in `(N², B², K²)`, fitted by weighted least
//! squares with non-negative coefficients (every active set of the three tried, the best
//! feasible one kept: exact for three unknowns). Each point weighs by its variance
//! `(2·δ·σ²)²`, δ the Allan deviation's relative uncertainty, with σ² the model's value after a
//! first pass on the measured one (iteratively re-weighted), so points that scatter low do not
//! pull the fit. `N` and `K` are Kalibr's `*_noise_density` and `*_random_walk`.
//!
//! Beside it the classic read-offs of the log-log slopes: `N` where the −1/2 line through the
//! point of slope closest to −1/2 crosses τ = 1 s, `K` where the +1/2 line crosses τ = 3 s,
//! `B` = min σ / 0.664.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use super::allan::AllanCurve;

/// `2 ln 2 / π`: the flat floor of the Allan variance per unit `B²`.
pub const BIAS_INSTABILITY_FACTOR: f64 = 2.0 * std::f64::consts::LN_2 / std::f64::consts::PI;
/// Largest distance of a local slope from ±1/2 for a read-off to be made.
const SLOPE_TOLERANCE: f64 = 0.25;
/// Re-weighting passes after the first.
const REWEIGHT_PASSES: usize = 3;

/// The fitted noise model of one axis.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NoiseFit {
    /// White noise density `N` (unit/√Hz: rad/s/√Hz, m/s²/√Hz).
    pub white_noise_density: f64,
    /// Bias instability `B` (unit: rad/s, m/s²).
    pub bias_instability: f64,
    /// Random walk `K` (unit·√Hz/s: rad/s²/√Hz, m/s³/√Hz).
    pub random_walk: f64,
    /// RMS of the fit's relative residuals `(σ²_meas − σ²_model)/σ²_model`, over the curve.
    pub relative_rms_residual: f64,
}

impl NoiseFit {
    /// The model's Allan deviation at τ (s).
    pub fn adev(&self, tau_s: f64) -> f64 {
        let n = self.white_noise_density;
        let b = self.bias_instability;
        let k = self.random_walk;
        (n * n / tau_s + BIAS_INSTABILITY_FACTOR * b * b + k * k * tau_s / 3.0).sqrt()
    }
}

/// The classic read-offs of one axis' curve (`None` where the curve has no region of that slope).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SlopeReadoff {
    /// `N`: the −1/2 line through the point of slope closest to −1/2, at τ = 1 s.
    pub white_noise_density: Option<f64>,
    /// τ (s) of the point the −1/2 line goes through.
    pub white_noise_tau_s: Option<f64>,
    /// `K`: the +1/2 line through the point of slope closest to +1/2, at τ = 3 s.
    pub random_walk: Option<f64>,
    /// τ (s) of the point the +1/2 line goes through.
    pub random_walk_tau_s: Option<f64>,
    /// `B` = min σ / 0.664.
    pub bias_instability: Option<f64>,
    /// τ (s) of the minimum.
    pub bias_instability_tau_s: Option<f64>,
}

/// Weighted non-negative least-squares fit of the noise model to `curve`; `None` for fewer than
/// three points or a curve without a positive finite value.
pub fn fit_noise_model(curve: &AllanCurve) -> Option<NoiseFit> {
    let pts: Vec<(f64, f64, f64)> = curve
        .tau_s
        .iter()
        .zip(&curve.adev)
        .zip(&curve.relative_sigma)
        .filter(|((t, a), d)| t.is_finite() && a.is_finite() && **a > 0.0 && d.is_finite())
        .map(|((t, a), d)| (*t, a * a, *d))
        .collect();
    if pts.len() < 3 {
        return None;
    }
    // Columns scaled so each spans ~1 over the curve.
    let t_lo = pts[0].0;
    let t_hi = pts[pts.len() - 1].0;
    let basis = |t: f64| [t_lo / t, 1.0, t / t_hi];
    let mut scale: Vec<f64> = pts.iter().map(|p| 2.0 * p.2 * p.1).collect();
    let mut coef = [0.0; 3];
    for _ in 0..=REWEIGHT_PASSES {
        coef = nnls3(&pts, &scale, basis)?;
        let floor = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min) * 1e-3;
        for (s, p) in scale.iter_mut().zip(&pts) {
            let model: f64 = basis(p.0).iter().zip(&coef).map(|(b, c)| b * c).sum();
            *s = 2.0 * p.2 * model.max(floor);
        }
    }
    let (a, b, c) = (coef[0] * t_lo, coef[1], coef[2] / t_hi);
    let mut sq = 0.0;
    for p in &pts {
        let model = a / p.0 + b + c * p.0;
        let r = (p.1 - model) / model.max(f64::MIN_POSITIVE);
        sq += r * r;
    }
    Some(NoiseFit {
        white_noise_density: a.sqrt(),
        bias_instability: (b / BIAS_INSTABILITY_FACTOR).sqrt(),
        random_walk: (3.0 * c).sqrt(),
        relative_rms_residual: (sq / pts.len() as f64).sqrt(),
    })
}

/// Minimizes `Σ ((Σ_j c_j·basis_j(τ) − σ²)/scale)²` over `c ≥ 0`: the best feasible solution
/// among the unconstrained solutions on every subset of the columns.
fn nnls3(
    pts: &[(f64, f64, f64)],
    scale: &[f64],
    basis: impl Fn(f64) -> [f64; 3],
) -> Option<[f64; 3]> {
    let rows = pts.len();
    let mut best: Option<([f64; 3], f64)> = None;
    for mask in 1u32..8 {
        let cols: Vec<usize> = (0..3).filter(|j| mask & (1 << j) != 0).collect();
        let mut a = DMatrix::zeros(rows, cols.len());
        let mut y = DVector::zeros(rows);
        for (i, p) in pts.iter().enumerate() {
            let bvec = basis(p.0);
            for (jj, &j) in cols.iter().enumerate() {
                a[(i, jj)] = bvec[j] / scale[i];
            }
            y[i] = p.1 / scale[i];
        }
        let Ok(sol) = a.clone().svd(true, true).solve(&y, 1e-12) else {
            continue;
        };
        if sol.iter().any(|v| !v.is_finite() || *v < 0.0) {
            continue;
        }
        let cost = (&a * &sol - &y).norm_squared();
        let mut c = [0.0; 3];
        for (jj, &j) in cols.iter().enumerate() {
            c[j] = sol[jj];
        }
        if best.is_none_or(|(_, b)| cost < b) {
            best = Some((c, cost));
        }
    }
    best.map(|(c, _)| c)
}

/// The classic slope read-offs of `curve`.
pub fn slope_readoff(curve: &AllanCurve) -> SlopeReadoff {
    let (t, a) = (&curve.tau_s, &curve.adev);
    // Local slope between consecutive points, attributed to their geometric-mean τ and σ.
    let mut slopes = Vec::new();
    for i in 0..t.len().saturating_sub(1) {
        if a[i] > 0.0 && a[i + 1] > 0.0 {
            let s = (a[i + 1] / a[i]).ln() / (t[i + 1] / t[i]).ln();
            slopes.push((s, (t[i] * t[i + 1]).sqrt(), (a[i] * a[i + 1]).sqrt()));
        }
    }
    let closest = |target: f64| {
        slopes
            .iter()
            .filter(|s| (s.0 - target).abs() <= SLOPE_TOLERANCE)
            .min_by(|x, y| (x.0 - target).abs().total_cmp(&(y.0 - target).abs()))
            .copied()
    };
    let white = closest(-0.5);
    let walk = closest(0.5);
    let min = t
        .iter()
        .zip(a)
        .filter(|(_, v)| v.is_finite() && **v > 0.0)
        .min_by(|x, y| x.1.total_cmp(y.1));
    SlopeReadoff {
        white_noise_density: white.map(|(_, tau, s)| s * tau.sqrt()),
        white_noise_tau_s: white.map(|w| w.1),
        random_walk: walk.map(|(_, tau, s)| s * (3.0 / tau).sqrt()),
        random_walk_tau_s: walk.map(|w| w.1),
        bias_instability: min.map(|(_, s)| s / BIAS_INSTABILITY_FACTOR.sqrt()),
        bias_instability_tau_s: min.map(|(tau, _)| *tau),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve_of(model: &NoiseFit) -> AllanCurve {
        let tau_s: Vec<f64> = (0..40)
            .map(|i| 0.005 * 10f64.powf(i as f64 / 10.0))
            .collect();
        AllanCurve {
            adev: tau_s.iter().map(|t| model.adev(*t)).collect(),
            relative_sigma: tau_s.iter().map(|t| 0.01 + 0.01 * t).collect(),
            cluster_samples: (1..=40).collect(),
            tau_s,
        }
    }

    #[test]
    fn an_exact_model_curve_is_recovered() {
        let truth = NoiseFit {
            white_noise_density: 1.7e-4,
            bias_instability: 2e-5,
            random_walk: 2e-5,
            relative_rms_residual: 0.0,
        };
        let f = fit_noise_model(&curve_of(&truth)).unwrap();
        assert!((f.white_noise_density / truth.white_noise_density - 1.0).abs() < 1e-6);
        assert!((f.bias_instability / truth.bias_instability - 1.0).abs() < 1e-4);
        assert!((f.random_walk / truth.random_walk - 1.0).abs() < 1e-4);
        assert!(f.relative_rms_residual < 1e-8);
    }

    #[test]
    fn coefficients_stay_non_negative_and_readoffs_match_pure_slopes() {
        let truth = NoiseFit {
            white_noise_density: 1e-3,
            bias_instability: 0.0,
            random_walk: 0.0,
            relative_rms_residual: 0.0,
        };
        let f = fit_noise_model(&curve_of(&truth)).unwrap();
        assert!(f.random_walk < 1e-9 && f.bias_instability < 1e-9, "{f:?}");
        assert!((f.white_noise_density / 1e-3 - 1.0).abs() < 1e-9);
        let r = slope_readoff(&curve_of(&truth));
        assert!((r.white_noise_density.unwrap() / 1e-3 - 1.0).abs() < 1e-9);
        assert!(r.random_walk.is_none());
    }
}
