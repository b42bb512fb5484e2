//! A linear factor over Euclidean blocks.

use crate::problem::Factor;

/// `r = Σₖ Aₖ xₖ − b` over Euclidean blocks (already whitened). Useful for linear
/// measurements (absolute positions, relative displacements) and as the exact reference in
/// linear-Gaussian tests of the solver and marginalization.
#[derive(Clone, Debug)]
pub struct LinearFactor {
    a: Vec<Vec<f64>>,
    b: Vec<f64>,
    sizes: Vec<usize>,
}

impl LinearFactor {
    /// Builds the factor from per-block row-major matrices `a[k]` (`b.len() × sizes[k]`).
    /// Returns `None` when dimensions disagree or values are not finite.
    pub fn new(a: Vec<Vec<f64>>, b: Vec<f64>, sizes: Vec<usize>) -> Option<Self> {
        let ok = a.len() == sizes.len()
            && a.iter().zip(&sizes).all(|(ak, s)| ak.len() == b.len() * s)
            && a.iter().flatten().chain(&b).all(|v| v.is_finite());
        ok.then_some(Self { a, b, sizes })
    }
}

impl Factor for LinearFactor {
    fn residual_dim(&self) -> usize {
        self.b.len()
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &self.sizes
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &self.sizes
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let m = self.b.len();
        for i in 0..m {
            let mut s = -self.b[i];
            for (k, x) in params.iter().enumerate() {
                let t = self.sizes[k];
                let row = &self.a[k][i * t..i * t + t];
                s += row.iter().zip(x.iter()).map(|(a, b)| a * b).sum::<f64>();
            }
            residuals[i] = s;
        }
        if let Some(js) = jacobians {
            for (k, out) in js.iter_mut().enumerate() {
                if let Some(o) = out.as_deref_mut() {
                    o.copy_from_slice(&self.a[k]);
                }
            }
        }
        true
    }
}
