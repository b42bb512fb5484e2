//! The square-root form of a prior held in information form: residual rows `r₀ + J d` with
//! `‖r₀ + J d‖² = c + 2 bᵀd + dᵀH d`, for `Factor::evaluate` and for readers of `J` (the solver
//! itself works on `H`, `b`, `c` and never asks for it).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt_pivoting::factor as piv_llt;
use faer::{Mat, Par};

/// Pivots of the factor at or below this fraction of `H`'s largest diagonal end it: the
/// directions left carry no information worth a row (the gauge, to round-off).
pub(super) const RELATIVE_RANK_THRESHOLD: f64 = 1e-12;

/// `J` (row-major, `rows × n`) and `r₀` of a prior.
#[derive(Clone, Debug)]
pub(super) struct SquareRoot {
    pub jacobian: Vec<f64>,
    pub r0: Vec<f64>,
}

impl SquareRoot {
    /// The square root of `c + 2 bᵀd + dᵀH d` (`h` row-major, exactly symmetric) in `n + 1`
    /// rows: `J`'s first rows from the diagonally pivoted Cholesky factor of `H` (cut at
    /// [`RELATIVE_RANK_THRESHOLD`]), `r₀` from `L r₀ = Pᵀ b` on them, zero rows up to `n`, and a
    /// last row with no Jacobian that carries what `c` holds beyond `‖r₀‖²` (what the
    /// marginalized residuals cost at the linearization point that no value of the kept states
    /// can remove).
    pub fn of(h: &[f64], b: &[f64], c: f64, n: usize) -> Self {
        let (perm, l, rank) = pivoted_cholesky(h, n, RELATIVE_RANK_THRESHOLD);
        let rows = n + 1;
        let mut jacobian = vec![0.0; rows * n];
        // Row r of J: column r of L, its entry i at coordinate perm[i].
        for r in 0..rank {
            for i in r..n {
                jacobian[r * n + perm[i]] = l[(i, r)];
            }
        }
        let mut r0 = vec![0.0; rows];
        for r in 0..rank {
            r0[r] = b[perm[r]];
        }
        for c in 0..rank {
            r0[c] /= l[(c, c)];
            let v = r0[c];
            for r in c + 1..rank {
                r0[r] -= l[(r, c)] * v;
            }
        }
        let explained: f64 = r0.iter().map(|v| v * v).sum();
        r0[n] = (c - explained).max(0.0).sqrt();
        Self { jacobian, r0 }
    }
}

/// Rank-revealing Cholesky with diagonal pivoting of a symmetric row-major `n × n` matrix:
/// `P A Pᵀ ≈ L Lᵀ` with `L` cut after `rank` columns, the first pivot at or below
/// `rel_tol · max diag` ending it. Returns `(perm, L, rank)`: row `i` of `L` belongs to
/// coordinate `perm[i]`. A negative or NaN diagonal gives rank 0.
pub(super) fn pivoted_cholesky(a: &[f64], n: usize, rel_tol: f64) -> (Vec<usize>, Mat<f64>, usize) {
    if n == 0 {
        return (Vec::new(), Mat::zeros(0, 0), 0);
    }
    let max_diag = (0..n).map(|i| a[i * n + i]).fold(0.0f64, f64::max);
    let tol = rel_tol * max_diag.max(f64::MIN_POSITIVE);
    // faer's blocked, diagonally pivoted Cholesky (LAPACK's `dpstrf` scheme: the largest
    // remaining diagonal is the next pivot; sequential, so deterministic). Its pivots never
    // grow, so cutting at the first one below the tolerance is the same rule as stopping there.
    // It reads the lower triangle; `a` is symmetric, so the row-major buffer serves.
    let mut m = Mat::<f64>::from_fn(n, n, |i, j| if i >= j { a[i * n + j] } else { 0.0 });
    let (mut perm, mut perm_inv) = (vec![0usize; n], vec![0usize; n]);
    let mut buf = MemBuffer::new(piv_llt::cholesky_in_place_scratch::<usize, f64>(
        n,
        Par::Seq,
        Default::default(),
    ));
    let rank = match piv_llt::cholesky_in_place(
        m.as_mut(),
        &mut perm,
        &mut perm_inv,
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    ) {
        Ok((info, _)) => (0..info.rank)
            .find(|&k| {
                (m[(k, k)] * m[(k, k)]).partial_cmp(&tol) != Some(std::cmp::Ordering::Greater)
            })
            .unwrap_or(info.rank),
        Err(_) => 0,
    };
    (perm, m, rank)
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::*;

    /// `P L` of a factorization, its first `rank` columns: `(P L)(P L)ᵀ` is what the factor
    /// says the matrix is.
    fn permuted_factor(perm: &[usize], l: &Mat<f64>, rank: usize) -> DMatrix<f64> {
        let mut pl = DMatrix::zeros(perm.len(), rank);
        for (i, &p) in perm.iter().enumerate() {
            for r in 0..rank.min(i + 1) {
                pl[(p, r)] = l[(i, r)];
            }
        }
        pl
    }

    fn row_major(a: &DMatrix<f64>) -> Vec<f64> {
        a.transpose().as_slice().to_vec()
    }

    #[test]
    fn pivoted_cholesky_reconstructs_a_rank_deficient_matrix() {
        // A = B Bᵀ with B 6×4: rank 4.
        let b = DMatrix::from_fn(6, 4, |i, j| {
            ((i * 7 + j * 3) % 5) as f64 - 2.0 + 0.1 * j as f64
        });
        let a = &b * b.transpose();
        let (perm, l, rank) = pivoted_cholesky(&row_major(&a), 6, 1e-12);
        assert_eq!(rank, 4);
        let pl = permuted_factor(&perm, &l, rank);
        assert!((&pl * pl.transpose() - a).norm() < 1e-9);
    }

    /// A pivot just under the tolerance ends the factor; a stricter tolerance keeps it; the
    /// zero matrix has rank 0.
    #[test]
    fn pivoted_cholesky_cuts_at_the_relative_tolerance() {
        let a = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(vec![1.0, 0.5, 1e-13]));
        assert_eq!(pivoted_cholesky(&row_major(&a), 3, 1e-12).2, 2);
        assert_eq!(pivoted_cholesky(&row_major(&a), 3, 1e-14).2, 3);
        assert_eq!(pivoted_cholesky(&[0.0; 4], 2, 1e-12).2, 0);
    }

    /// The rows reproduce the quadratic: `JᵀJ = H`, `Jᵀr₀ = b`, `‖r₀‖² = c`, for a rank-deficient
    /// `H` with `b` in its range and a constant above `bᵀH⁺b`.
    #[test]
    fn the_rows_reproduce_the_information_form() {
        let n = 7;
        let f = DMatrix::from_fn(5, n, |i, j| {
            ((i * 11 + j * 5) % 9) as f64 - 4.0 + 0.2 * j as f64
        });
        let h = f.transpose() * &f;
        let r = nalgebra::DVector::from_fn(5, |i, _| 0.3 * i as f64 - 0.5);
        let b = f.transpose() * &r;
        let c = r.norm_squared() + 2.5;
        let root = SquareRoot::of(&row_major(&h), b.as_slice(), c, n);
        let j = DMatrix::from_row_slice(n + 1, n, &root.jacobian);
        let r0 = nalgebra::DVector::from_column_slice(&root.r0);
        assert!((j.transpose() * &j - &h).abs().max() < 1e-10 * h.abs().max());
        assert!((j.transpose() * &r0 - &b).abs().max() < 1e-10 * b.abs().max());
        assert!((r0.norm_squared() - c).abs() < 1e-10 * c);
        // The constant's remainder sits on the last row, with no Jacobian.
        assert!(j.row(n).iter().all(|v| *v == 0.0));
        assert!((root.r0[n] - 2.5f64.sqrt()).abs() < 1e-9);
    }
}
