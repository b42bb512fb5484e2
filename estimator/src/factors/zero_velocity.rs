//! The zero-velocity factor: a speed-bias block at rest.

use nalgebra::Vector3;

use crate::problem::Factor;

/// Zero velocity at rest on a speed-bias block `[v, ba, bg]`: `r = [v / σ_v,
/// (b_g − ω̄) / σ_ω̄]`, with `σ_ω̄ = σ_g √rate / √N` the noise of the mean of `N` gyroscope
/// samples.
#[derive(Clone, Debug)]
pub struct ZeroVelocityFactor {
    /// Standard deviation of the velocity constraint (m/s).
    pub velocity_sigma: f64,
    /// Mean gyroscope reading over the rest interval (rad/s).
    pub gyro_mean: Vector3<f64>,
    /// Standard deviation of that mean (rad/s).
    pub gyro_mean_sigma: f64,
}

impl Factor for ZeroVelocityFactor {
    fn residual_dim(&self) -> usize {
        6
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[9]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[9]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let sb = params[0];
        let (wv, wg) = (1.0 / self.velocity_sigma, 1.0 / self.gyro_mean_sigma);
        for i in 0..3 {
            residuals[i] = wv * sb[i];
            residuals[3 + i] = wg * (sb[6 + i] - self.gyro_mean[i]);
        }
        if let Some(j) = jacobians.and_then(|j| j[0].as_deref_mut()) {
            j.fill(0.0);
            for i in 0..3 {
                j[i * 9 + i] = wv;
                j[(3 + i) * 9 + 6 + i] = wg;
            }
        }
        residuals.iter().all(|r| r.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::{CheckOptions, Euclidean, check_factor_jacobians};

    #[test]
    fn zero_velocity_factor_jacobians() {
        let f = ZeroVelocityFactor {
            velocity_sigma: 0.005,
            gyro_mean: Vector3::new(0.01, -0.02, 0.003),
            gyro_mean_sigma: 3e-4,
        };
        let sb = vec![0.1, -0.2, 0.05, 0.01, 0.02, -0.03, 0.004, -0.002, 0.001];
        let m = Euclidean::new(9);
        check_factor_jacobians(&f, &[sb], &[&m], CheckOptions::default()).unwrap();
    }
}
