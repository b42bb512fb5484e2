//! Blocks removed from a prior alone: Householder reflections on its square-root form.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::linalg::{householder, qr};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par};

use super::{PriorError, PriorFactor};
use crate::problem::solver::dot;

impl PriorFactor {
    /// The same prior with the blocks `remove` (indices into its blocks) marginalized out:
    /// Householder reflections on `[J_removed | J_kept | r₀]` zero the removed columns below
    /// their leading rows, and the rows under them are the square-root form of the marginal
    /// (the Schur complement `H_kk − H_km H_mm⁻¹ H_mk`, with its `b`), around the same
    /// linearization points. Exact, as the prior is linear in `x ⊟ x̄`; no relinearization,
    /// no eigen-decomposition: O(m n t) for `t` removed coordinates. A removed direction whose
    /// remaining information (squared column norm) is at most `min_information` carries none
    /// and is skipped, like the eigenvalue threshold of the general marginalization.
    pub fn marginalized(&self, remove: &[usize], min_information: f64) -> Result<Self, PriorError> {
        let (m, n) = (self.r0.len(), self.tangent_dim());
        let nb = self.manifolds.len();
        let removing: Vec<bool> = (0..nb).map(|k| remove.contains(&k)).collect();
        // Columns: removed coordinates first, then kept ones in block order, then r₀.
        let block_cols = |k: usize| self.offsets[k]..self.offsets[k] + self.tangents[k];
        let mut cols: Vec<usize> = (0..nb)
            .filter(|&k| removing[k])
            .flat_map(block_cols)
            .collect();
        let nm = cols.len();
        cols.extend((0..nb).filter(|&k| !removing[k]).flat_map(block_cols));
        // Column-major working copy, m × (n + 1); blocked reflections where every removed
        // direction carries information (the usual case), one by one otherwise.
        let copy = || {
            let mut a = vec![0.0; m * (n + 1)];
            for (c, &src) in cols.iter().enumerate() {
                for r in 0..m {
                    a[c * m + r] = self.jacobian[r * n + src];
                }
            }
            a[n * m..].copy_from_slice(&self.r0);
            a
        };
        let mut a = copy();
        let p = match reflect_blocked(&mut a, m, n, nm, min_information) {
            Some(p) => p,
            None => {
                a = copy();
                reflect_one_by_one(&mut a, m, n, nm, min_information)
            }
        };
        let (mk, nk) = (m - p, n - nm);
        let mut jacobian = vec![0.0; mk * nk];
        for c in 0..nk {
            for r in 0..mk {
                jacobian[r * nk + c] = a[(nm + c) * m + p + r];
            }
        }
        let r0 = a[n * m + p..(n + 1) * m].to_vec();
        // JᵀJ of the rows left, without forming it: the reflections keep [J_m J_k]ᵀ[J_m J_k],
        // so H_kk = TᵀT + J'ᵀJ' with T the leading p rows of the kept columns (O(p n²)).
        let mut hessian = vec![0.0; nk * nk];
        if p > 0 && nk > 0 {
            // TᵀT by one product (column-major = row-major for a symmetric result).
            let t = MatRef::from_column_major_slice_with_stride(&a[nm * m..], p, nk, m);
            matmul(
                MatMut::from_column_major_slice_mut(&mut hessian, nk, nk),
                Accum::Replace,
                t.transpose(),
                t,
                1.0,
                Par::Seq,
            );
        }
        // Exactly symmetric: the upper triangle of TᵀT, mirrored.
        for i in 0..nk {
            let src = cols[nm + i] * n;
            for j in i..nk {
                let h = self.hessian[src + cols[nm + j]] - hessian[j * nk + i];
                hessian[i * nk + j] = h;
                hessian[j * nk + i] = h;
            }
        }
        let kept = (0..nb).filter(|&k| !removing[k]);
        PriorFactor::with_hessian(
            kept.clone().map(|k| self.manifolds[k].clone()).collect(),
            kept.map(|k| self.linearization_points[k].clone()).collect(),
            jacobian,
            r0,
            Some(hessian),
        )
    }
}

/// Householder reflections that zero the first `nm` columns of the column-major `m × (n + 1)`
/// matrix `a` below their leading rows, applied to all its columns one reflection at a time;
/// a column whose remaining squared norm is at most `min_information` is skipped. Returns the
/// number of reflections (the leading rows they fill).
fn reflect_one_by_one(a: &mut [f64], m: usize, n: usize, nm: usize, min_information: f64) -> usize {
    let mut p = 0;
    let mut v = vec![0.0; m];
    for j in 0..nm {
        if p == m {
            break;
        }
        let x = &a[j * m + p..(j + 1) * m];
        let norm_sq: f64 = x.iter().map(|v| v * v).sum();
        if norm_sq <= min_information {
            continue;
        }
        // v = x − α e₁ with α = −sign(x₀) ‖x‖ (no cancellation); H = I − 2 v vᵀ / vᵀv.
        let alpha = if x[0] > 0.0 {
            -norm_sq.sqrt()
        } else {
            norm_sq.sqrt()
        };
        let v = &mut v[..m - p];
        v.copy_from_slice(x);
        v[0] -= alpha;
        let vtv: f64 = v.iter().map(|x| x * x).sum();
        for c in j..=n {
            let col = &mut a[c * m + p..(c + 1) * m];
            let s = 2.0 * dot(col, v) / vtv;
            for (x, y) in col.iter_mut().zip(v.iter()) {
                *x -= s * y;
            }
        }
        p += 1;
    }
    p
}

/// [`reflect_one_by_one`] as a blocked QR of the first `nm` columns (faer) applied to the rest
/// by block reflectors; `None` (with `a` modified) when a removed direction carries no more
/// than `min_information`, which the one-by-one path must then skip.
fn reflect_blocked(
    a: &mut [f64],
    m: usize,
    n: usize,
    nm: usize,
    min_information: f64,
) -> Option<usize> {
    let k = m.min(nm);
    if k == 0 {
        return Some(0);
    }
    let mat = MatMut::from_column_major_slice_mut(a, m, n + 1);
    let (mut left, right) = mat.split_at_col_mut(nm);
    let block = qr::no_pivoting::factor::recommended_block_size::<f64>(m, nm);
    let mut factor = Mat::<f64>::zeros(block, k);
    let req =
        qr::no_pivoting::factor::qr_in_place_scratch::<f64>(
            m,
            nm,
            block,
            Par::Seq,
            Default::default(),
        )
        .or(
            householder::apply_block_householder_sequence_transpose_on_the_left_in_place_scratch::<
                f64,
            >(m, block, n + 1 - nm),
        );
    let mut buf = MemBuffer::new(req);
    let stack = MemStack::new(&mut buf);
    qr::no_pivoting::factor::qr_in_place(
        left.as_mut(),
        factor.as_mut(),
        Par::Seq,
        stack,
        Default::default(),
    );
    let informative = (0..k).all(|j| {
        let d = left[(j, j)];
        d * d > min_information
    });
    if !informative {
        return None;
    }
    householder::apply_block_householder_sequence_transpose_on_the_left_in_place_with_conj(
        left.as_ref(),
        factor.as_ref(),
        Conj::No,
        right,
        Par::Seq,
        stack,
    );
    Some(k)
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::super::tests::test_blocks;
    use super::*;

    /// Marginalizing blocks out of a prior by reflections gives the Schur complement of its
    /// information form (`H`, `b` and the constant `r₀ᵀr₀`), around the same points; a removed
    /// coordinate without information (a zero column) is skipped and changes nothing.
    #[test]
    fn marginalizing_blocks_is_the_schur_complement() {
        // Coordinate 7 (the point's y) carries no information: reflections one by one.
        check_marginalized_is_the_schur_complement(Some(7));
        // Every removed direction informative: blocked reflections.
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
        let b = nalgebra::DVector::from_column_slice(&prior.gradient);
        let removed: Vec<usize> = (0..9).filter(|&c| Some(c) != zero).collect();
        let kept: Vec<usize> = (9..15).collect();
        let pick = |rows: &[usize], cols: &[usize]| {
            DMatrix::from_fn(rows.len(), cols.len(), |i, j| h[(rows[i], cols[j])])
        };
        let hmm_inv = pick(&removed, &removed).try_inverse().unwrap();
        let hkm = pick(&kept, &removed);
        let bm = nalgebra::DVector::from_fn(removed.len(), |i, _| b[removed[i]]);
        let bk = nalgebra::DVector::from_fn(kept.len(), |i, _| b[kept[i]]);
        let h_star = pick(&kept, &kept) - &hkm * &hmm_inv * hkm.transpose();
        let b_star = bk - &hkm * &hmm_inv * &bm;
        let c_star = prior.r0_sq - (bm.transpose() * &hmm_inv * &bm)[(0, 0)];

        let marginal = prior.marginalized(&[0, 1], 1e-8).unwrap();
        assert_eq!(marginal.linearization_points(), &x0[2..]);
        assert_eq!(marginal.tangent_dim(), 6);
        // 18 rows less the informative removed directions.
        let rows = m - removed.len();
        assert_eq!(marginal.r0().len(), rows);
        let h_new = DMatrix::from_row_slice(6, 6, &marginal.hessian);
        assert!((&h_new - &h_star).abs().max() < 1e-9 * h_star.abs().max());
        // The Hessian it carries (from the reflections, not a product) is its own J'ᵀJ'.
        let j_new = DMatrix::from_row_slice(rows, 6, marginal.jacobian());
        let jtj = j_new.transpose() * &j_new;
        assert!((&h_new - &jtj).abs().max() < 1e-12 * jtj.abs().max());
        assert_eq!(h_new, h_new.transpose());
        for i in 0..6 {
            assert!((marginal.gradient[i] - b_star[i]).abs() < 1e-9 * b_star.abs().max());
        }
        assert!((marginal.r0_sq - c_star).abs() < 1e-9 * prior.r0_sq);
    }
}
