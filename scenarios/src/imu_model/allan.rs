//! Overlapping Allan deviation of a rate signal (angular rate or specific force) over
//! log-spaced cluster times.
//!
//! For `n` samples `y_k` at period `τ₀` and a cluster of `m` samples (`τ = m·τ₀`):
//! `σ²(τ) = 1/(2(n − 2m + 1)) · Σ_k (ȳ_{k+m} − ȳ_k)²` with `ȳ_k` the mean of `y_k … y_{k+m−1}`,
//! every start `k` used (overlapping estimator, IEEE Std 952 / 1554). The cluster means come from
//! one cumulative sum of the mean-removed signal, so each `τ` costs `O(n)`.

use serde::Serialize;

/// Cluster times per decade.
pub const POINTS_PER_DECADE: usize = 10;
/// The longest cluster time is the record length divided by this (`T/9`: at least 9 clusters).
pub const MIN_CLUSTERS: usize = 9;

/// An Allan deviation curve.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AllanCurve {
    /// Cluster times τ (s), increasing.
    pub tau_s: Vec<f64>,
    /// Samples per cluster `m` at each τ.
    pub cluster_samples: Vec<usize>,
    /// Allan deviation σ(τ) in the signal's unit.
    pub adev: Vec<f64>,
    /// Relative 1-σ uncertainty of each σ(τ), `1/sqrt(2(n/m − 1))`.
    pub relative_sigma: Vec<f64>,
}

/// Cluster sizes `m`: log-spaced, [`POINTS_PER_DECADE`] per decade, from 1 to `n / 9`
/// (duplicates after rounding removed). Empty when `n < 9`.
pub fn cluster_sizes(n: usize) -> Vec<usize> {
    let max_m = n / MIN_CLUSTERS;
    let mut out: Vec<usize> = Vec::new();
    if max_m < 1 {
        return out;
    }
    for i in 0usize.. {
        let m = 10f64.powf(i as f64 / POINTS_PER_DECADE as f64).round() as usize;
        if m > max_m {
            break;
        }
        if out.last() != Some(&m) {
            out.push(m);
        }
    }
    out
}

/// Relative 1-σ uncertainty of an Allan deviation from `n` samples with `m` per cluster.
pub fn relative_sigma(n: usize, m: usize) -> f64 {
    let clusters = n as f64 / m as f64;
    1.0 / (2.0 * (clusters - 1.0)).max(1.0).sqrt()
}

/// The overlapping Allan deviation of `y` (period `dt_s`) at the cluster sizes of
/// [`cluster_sizes`]. Returns an empty curve when `y` is too short (fewer than 9 samples).
pub fn allan_deviation(y: &[f64], dt_s: f64) -> AllanCurve {
    let n = y.len();
    let ms = cluster_sizes(n);
    let mean = if n == 0 {
        0.0
    } else {
        y.iter().sum::<f64>() / n as f64
    };
    // S[k] = Σ_{j<k} (y_j − mean): mean removed so the sum stays small.
    let mut s = Vec::with_capacity(n + 1);
    s.push(0.0);
    let mut acc = 0.0;
    for v in y {
        acc += v - mean;
        s.push(acc);
    }
    let mut curve = AllanCurve {
        tau_s: Vec::with_capacity(ms.len()),
        cluster_samples: Vec::with_capacity(ms.len()),
        adev: Vec::with_capacity(ms.len()),
        relative_sigma: Vec::with_capacity(ms.len()),
    };
    for m in ms {
        let terms = n - 2 * m + 1;
        let mut sum = 0.0;
        for k in 0..terms {
            let d = s[k + 2 * m] - 2.0 * s[k + m] + s[k];
            sum += d * d;
        }
        let avar = sum / (2.0 * (m * m) as f64 * terms as f64);
        curve.tau_s.push(m as f64 * dt_s);
        curve.cluster_samples.push(m);
        curve.adev.push(avar.sqrt());
        curve.relative_sigma.push(relative_sigma(n, m));
    }
    curve
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cluster_sizes_are_log_spaced_up_to_a_ninth() {
        let m = cluster_sizes(1000);
        assert_eq!(m.first(), Some(&1));
        assert!(*m.last().unwrap() <= 111);
        assert!(m.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(cluster_sizes(17), vec![1]);
        assert!(cluster_sizes(8).is_empty());
    }

    #[test]
    fn white_sequence_has_the_expected_allan_deviation() {
        // A deterministic ±1 sequence, checked against the definition.
        let y: Vec<f64> = (0..100)
            .map(|k| if k % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let c = allan_deviation(&y, 0.5);
        // m = 1: consecutive differences are ±2, σ² = 4/2 = 2.
        assert!((c.adev[0] - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(c.tau_s[0], 0.5);
        // m = 2: every cluster mean is 0.
        assert!(c.adev[1].abs() < 1e-12);
    }
}
