//! The χ² quantile the window's consistency tests compare against (the IMU factors' χ² in the
//! health checks, the rest tests of zero-velocity detection) and the harness's NEES bands.

/// The quantile of a χ² variable at the standard normal quantile `z` (`z > 0`: upper; `z < 0`:
/// lower), for a variable with `dof` degrees of freedom
/// (Wilson–Hilferty: `(χ²/k)^(1/3)` is nearly normal with mean `1 − 2/(9k)` and variance
/// `2/(9k)`; within 1 % of the exact quantile from 10 degrees of freedom on).
pub fn chi2_quantile(dof: usize, z: f64) -> f64 {
    let k = dof.max(1) as f64;
    let v = 2.0 / (9.0 * k);
    k * (1.0 - v + z * v.sqrt()).powi(3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantiles_match_the_exact_ones() {
        assert!((chi2_quantile(15, 3.0902) - 37.697).abs() / 37.697 < 0.01);
        assert!((chi2_quantile(150, 3.0902) - 208.98).abs() / 208.98 < 0.002);
        // Both tails of the 95 % band (χ² tables: k = 75: 52.942, 100.839; k = 10: 3.247, 20.483).
        let z = 1.959_963_984_540_054;
        for (k, lo, hi, tol) in [(75, 52.942, 100.839, 3e-4), (10, 3.247, 20.483, 1e-2)] {
            assert!((chi2_quantile(k, -z) / lo - 1.0).abs() < tol, "k {k}");
            assert!((chi2_quantile(k, z) / hi - 1.0).abs() < tol, "k {k}");
        }
    }
}
