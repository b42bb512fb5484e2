//! Coordinates removed from a quadratic in information form: the Schur complement of `H` and
//! `b` (with the constant), as a pure function, and blocks removed from a prior alone.

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::{PriorError, PriorFactor};
use crate::problem::solver::mirror_upper;

/// The quadratic `c + 2 gᵀd + dᵀH d` over the coordinates after the first `nm`, minimized over
/// those: `H* = H_kk − H_km H_mm⁺ H_mk`, `g* = g_k − H_km H_mm⁺ g_m`, `c* = c − g_mᵀ H_mm⁺ g_m`.
/// `H_mm⁺` is the pseudo-inverse over the eigenvalues of `H_mm` above `eigen_threshold`: a
/// removed direction without information (a gauge direction) folds nothing in. `h` must be
/// symmetric; `H*` comes out exactly symmetric, in `h`'s own buffer (`H_kk` moved to its
/// front: no second `n × n` matrix).
pub(crate) fn eliminate_leading(
    h: DMatrix<f64>,
    g: &DVector<f64>,
    c: f64,
    nm: usize,
    eigen_threshold: f64,
) -> (DMatrix<f64>, DVector<f64>, f64) {
    let n = h.nrows();
    let nk = n - nm;
    let mut g_star = g.rows(nm, nk).into_owned();
    let mut c_star = c;
    // The thin factor `Λ^-½ Vᵀ H_mk` over the kept eigenvalues of `H_mm`:
    // H_km H_mm⁺ H_mk = fᵀ f.
    let f = (nm > 0).then(|| {
        let hmm = h.view((0, 0), (nm, nm));
        let hmk = h.view((0, nm), (nm, nk));
        let eig = SymmetricEigen::new(0.5 * (hmm + hmm.transpose()));
        let kept: Vec<usize> = (0..nm)
            .filter(|&i| eig.eigenvalues[i] > eigen_threshold)
            .collect();
        let scaled = DMatrix::from_fn(nm, kept.len(), |r, c| {
            eig.eigenvectors[(r, kept[c])] / eig.eigenvalues[kept[c]].sqrt()
        });
        let fg = scaled.transpose() * g.rows(0, nm);
        (scaled.transpose() * hmk, fg)
    });
    // `H_kk` to the front of the buffer, column by column (each moves towards the start, so no
    // column is overwritten before it is read).
    let mut data: Vec<f64> = h.data.into();
    for j in 0..nk {
        let src = (nm + j) * n + nm;
        data.copy_within(src..src + nk, j * nk);
    }
    data.truncate(nk * nk);
    let mut h_star = DMatrix::from_vec(nk, nk, data);
    if let Some((f, fg)) = f {
        matmul(
            MatMut::from_column_major_slice_mut(h_star.as_mut_slice(), nk, nk),
            Accum::Add,
            MatRef::from_column_major_slice(f.as_slice(), f.nrows(), nk).transpose(),
            MatRef::from_column_major_slice(f.as_slice(), f.nrows(), nk),
            -1.0,
            Par::Seq,
        );
        g_star.gemv_tr(-1.0, &f, &fg, 1.0);
        c_star -= fg.norm_squared();
    }
    // Exactly symmetric (the blocked product need not be, in the last bit): the lower triangle
    // of the column-major matrix is the upper one of the same buffer read row-major.
    mirror_upper(h_star.as_mut_slice(), nk);
    (h_star, g_star, c_star)
}

impl PriorFactor {
    /// The same prior with the blocks `remove` (indices into its blocks) marginalized out, around
    /// the same linearization points: [`eliminate_leading`] on its information form with the
    /// removed coordinates first. Exact, as the prior is linear in `x ⊟ x̄`: no relinearization,
    /// O(t n²) for `t` removed coordinates. A removed direction whose information is at most
    /// `min_information` (an eigenvalue of its block) carries none and is skipped, like the
    /// eigenvalue threshold of the general marginalization.
    pub fn marginalized(&self, remove: &[usize], min_information: f64) -> Result<Self, PriorError> {
        let n = self.tangent_dim();
        let nb = self.manifolds.len();
        let removing: Vec<bool> = (0..nb).map(|k| remove.contains(&k)).collect();
        // Coordinates: removed ones first, then kept ones in block order.
        let block_cols = |k: usize| self.offsets[k]..self.offsets[k] + self.tangents[k];
        let mut cols: Vec<usize> = (0..nb)
            .filter(|&k| removing[k])
            .flat_map(block_cols)
            .collect();
        let nm = cols.len();
        cols.extend((0..nb).filter(|&k| !removing[k]).flat_map(block_cols));
        // Filled a column at a time: column j of the permuted matrix is row `cols[j]` of the
        // (exactly symmetric) Hessian, read along the row.
        let h = DMatrix::from_fn(n, n, |i, j| self.hessian[cols[j] * n + cols[i]]);
        let g = DVector::from_fn(n, |i, _| self.gradient[cols[i]]);
        let (h_star, g_star, c_star) = eliminate_leading(h, &g, self.constant, nm, min_information);
        let kept = (0..nb).filter(|&k| !removing[k]);
        PriorFactor::from_symmetric_information(
            kept.clone().map(|k| self.manifolds[k].clone()).collect(),
            kept.map(|k| self.linearization_points[k].clone()).collect(),
            h_star.data.into(),
            g_star.data.into(),
            c_star,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::test_blocks;
    use super::*;
    use crate::problem::Factor;

    /// Marginalizing blocks out of a prior gives the Schur complement of its information form
    /// (`H`, `b` and the constant), around the same points, and what is left is still a sum of
    /// squares (its square root reproduces it); a removed coordinate without information (a
    /// zero column) is skipped and changes nothing.
    #[test]
    fn marginalizing_blocks_is_the_schur_complement() {
        check_marginalized_is_the_schur_complement(Some(7));
        check_marginalized_is_the_schur_complement(None);
    }

    /// Removes the point (6..9) and the first pose (0..6) from an 18-row prior whose column
    /// `zero` (if any) is zero, and compares with the dense Schur complement.
    fn check_marginalized_is_the_schur_complement(zero: Option<usize>) {
        let (manifolds, x0) = test_blocks();
        let (m, n) = (18, 15);
        let mut jac: Vec<f64> = (0..m * n)
            .map(|i| (((i * 37 + i / 7) % 23) as f64 - 11.0) / 7.0)
            .collect();
        if let Some(c) = zero {
            for r in 0..m {
                jac[r * n + c] = 0.0;
            }
        }
        let r0: Vec<f64> = (0..m).map(|i| 0.1 * i as f64 - 0.3).collect();
        let prior = PriorFactor::new(manifolds, x0.clone(), jac, r0).unwrap();
        let h = DMatrix::from_row_slice(n, n, &prior.hessian);
        let b = DVector::from_column_slice(&prior.gradient);
        let removed: Vec<usize> = (0..9).filter(|&c| Some(c) != zero).collect();
        let kept: Vec<usize> = (9..15).collect();
        let pick = |rows: &[usize], cols: &[usize]| {
            DMatrix::from_fn(rows.len(), cols.len(), |i, j| h[(rows[i], cols[j])])
        };
        let hmm_inv = pick(&removed, &removed).try_inverse().unwrap();
        let hkm = pick(&kept, &removed);
        let bm = DVector::from_fn(removed.len(), |i, _| b[removed[i]]);
        let bk = DVector::from_fn(kept.len(), |i, _| b[kept[i]]);
        let h_star = pick(&kept, &kept) - &hkm * &hmm_inv * hkm.transpose();
        let b_star = bk - &hkm * &hmm_inv * &bm;
        let c_star = prior.constant - (bm.transpose() * &hmm_inv * &bm)[(0, 0)];

        let marginal = prior.marginalized(&[0, 1], 1e-8).unwrap();
        assert_eq!(marginal.linearization_points(), &x0[2..]);
        assert_eq!(marginal.tangent_dim(), 6);
        let h_new = DMatrix::from_row_slice(6, 6, &marginal.hessian);
        assert!((&h_new - &h_star).abs().max() < 1e-9 * h_star.abs().max());
        assert_eq!(h_new, h_new.transpose());
        for i in 0..6 {
            assert!((marginal.gradient[i] - b_star[i]).abs() < 1e-9 * b_star.abs().max());
        }
        assert!((marginal.constant - c_star).abs() < 1e-9 * prior.constant);
        // The marginal is a sum of squares: its rows give back H, b and the constant.
        let rows = marginal.residual_dim();
        let j_new = DMatrix::from_row_slice(rows, 6, marginal.jacobian());
        let r_new = DVector::from_column_slice(marginal.r0());
        assert!((j_new.transpose() * &j_new - &h_new).abs().max() < 1e-9 * h_star.abs().max());
        assert!((j_new.transpose() * &r_new - &b_star).abs().max() < 1e-9 * b_star.abs().max());
        assert!((r_new.norm_squared() - c_star).abs() < 1e-9 * prior.constant);
    }
}
