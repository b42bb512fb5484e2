//! Marginalization: fold the information that residuals carry about removed blocks into a
//! linear prior on the blocks that stay (Schur complement), as in VINS-Fusion and OKVIS.
//!
//! Steps, for residuals R touching removed blocks M and kept blocks K:
//! 1. linearize R at the current values: `H = Σ JᵀJ`, `g = Σ Jᵀr`;
//! 2. eliminate removed landmark blocks per block (block-diagonal Schur complement);
//! 3. eliminate the removed state blocks with a pseudo-inverse from a symmetric eigen-decomposition
//!    whose eigenvalues below `eigen_threshold` are treated as zero (rank deficiency is normal:
//!    gauge directions carry no information);
//! 4. factor the marginal `H* = J*ᵀJ*` by a rank-revealing (diagonally pivoted) Cholesky and solve
//!    `J*ᵀ r* = g*`. Pivoted Cholesky costs n³/3 instead of an eigen-decomposition's ≈10n³ for the
//!    ~160-dimensional window prior, and drops directions with no information just the same.
//!
//! The prior keeps the linearization point of K (first-estimate Jacobians): its Jacobian never
//! changes, so it cannot inject information along directions it had none in. Blocks that
//! already carry a first-estimate point ([`Problem::set_linearization_point`]) keep it: the
//! residuals are linearized with Jacobians there and the prior is expressed around it.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor as llt;
use faer::linalg::cholesky::llt_pivoting::factor as piv_llt;
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::graph::{BlockId, BlockKind, Problem, ResidualId};
use super::prior::{PriorError, PriorFactor};
use super::solver::schur_complement_system;
use crate::problem::Manifold;

/// Errors from [`marginalize`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MarginalizationError {
    /// A residual could not be evaluated at the current values.
    #[error("a residual could not be evaluated at the linearization point")]
    Evaluation,
    /// A block to remove is constant or touched by none of the residuals.
    #[error("block {0:?} to marginalize is constant or not touched by the given residuals")]
    NotInvolved(BlockId),
    /// The prior could not be built.
    #[error(transparent)]
    Prior(#[from] PriorError),
}

/// Thresholds for [`marginalize`].
#[derive(Clone, Copy, Debug)]
pub struct MarginalizationOptions {
    /// Eigenvalues of the removed-state block below this are treated as zero.
    pub eigen_threshold: f64,
    /// Pivots of the marginal below `relative_rank_threshold · max diag` end the factorization.
    pub relative_rank_threshold: f64,
}

impl Default for MarginalizationOptions {
    fn default() -> Self {
        Self {
            eigen_threshold: 1e-8,
            relative_rank_threshold: 1e-12,
        }
    }
}

/// The result of marginalization: a prior factor over `blocks`.
#[derive(Clone, Debug)]
pub struct MarginalPrior {
    /// The prior (its parameter blocks are `blocks`, in this order).
    pub factor: PriorFactor,
    /// The kept blocks the prior constrains, in id order.
    pub blocks: Vec<BlockId>,
    /// Rank of the prior's information.
    pub rank: usize,
}

/// Marginalizes `remove` out of the residuals `residual_ids` (which must be all residuals
/// touching `remove`). Constant blocks are treated as known and excluded from the prior.
pub fn marginalize(
    problem: &Problem,
    residual_ids: &[ResidualId],
    remove: &[BlockId],
    options: &MarginalizationOptions,
) -> Result<MarginalPrior, MarginalizationError> {
    let nblocks = problem.blocks.len();
    let mut touched = vec![false; nblocks];
    for r in residual_ids {
        for b in &problem.residuals[r.0].blocks {
            touched[b.0] = true;
        }
    }
    let mut removing = vec![false; nblocks];
    for b in remove {
        if !touched[b.0] || problem.blocks[b.0].constant {
            return Err(MarginalizationError::NotInvolved(*b));
        }
        removing[b.0] = true;
    }
    // Removed states first, then the kept blocks (kept landmarks join the dense part);
    // removed landmarks are eliminated by the Schur complement.
    let is_lm = |i: usize| problem.blocks[i].kind == BlockKind::Landmark;
    let removed_landmarks: Vec<BlockId> = (0..nblocks)
        .filter(|&i| removing[i] && is_lm(i))
        .map(BlockId)
        .collect();
    let mut states: Vec<BlockId> = (0..nblocks)
        .filter(|&i| removing[i] && !is_lm(i))
        .map(BlockId)
        .collect();
    let kept: Vec<BlockId> = (0..nblocks)
        .filter(|&i| touched[i] && !removing[i] && !problem.blocks[i].constant)
        .map(BlockId)
        .collect();
    let tangent = |b: &BlockId| problem.blocks[b.0].manifold.tangent_size();
    let nm: usize = states.iter().map(tangent).sum();
    states.extend_from_slice(&kept);
    // 1–2. Linearize and fold in the removed landmarks.
    let (hm, g) = schur_complement_system(problem, residual_ids, &states, &removed_landmarks)
        .ok_or(MarginalizationError::Evaluation)?;
    let n = hm.nrows();

    // 3. Remove the state blocks with an eigen-thresholded pseudo-inverse.
    let nk = n - nm;
    let mut h_star = hm.view((nm, nm), (nk, nk)).into_owned();
    let mut g_star = g.rows(nm, nk).into_owned();
    if nm > 0 {
        let hmm = hm.view((0, 0), (nm, nm));
        let hmk = hm.view((0, nm), (nm, nk));
        let eig = SymmetricEigen::new(0.5 * (hmm + hmm.transpose()));
        // H_km H_mm⁺ H_mk = (Λ^-½ Vᵀ H_mk)ᵀ (Λ^-½ Vᵀ H_mk) over the kept eigenvalues: one
        // product of the thin factor with itself, exactly symmetric.
        let kept_eig: Vec<usize> = (0..nm)
            .filter(|&i| eig.eigenvalues[i] > options.eigen_threshold)
            .collect();
        let scaled = DMatrix::from_fn(nm, kept_eig.len(), |r, c| {
            eig.eigenvectors[(r, kept_eig[c])] / eig.eigenvalues[kept_eig[c]].sqrt()
        });
        let f = scaled.transpose() * hmk;
        let fg = scaled.transpose() * g.rows(0, nm);
        matmul(
            MatMut::from_column_major_slice_mut(h_star.as_mut_slice(), nk, nk),
            Accum::Add,
            MatRef::from_column_major_slice(f.as_slice(), f.nrows(), nk).transpose(),
            MatRef::from_column_major_slice(f.as_slice(), f.nrows(), nk),
            -1.0,
            Par::Seq,
        );
        g_star.gemv_tr(-1.0, &f, &fg, 1.0);
    }
    // Exactly symmetric from here on (the blocked product need not be, in the last bit).
    for j in 0..nk {
        for i in j + 1..nk {
            h_star[(j, i)] = h_star[(i, j)];
        }
    }

    // Blocks with a first-estimate linearization point keep it in the new prior: the system
    // above is a model in `δ = x ⊟ x_now` with Jacobians at that point, re-expressed in
    // `d = x ⊟ x̄ = δ + (x_now ⊟ x̄)`, so `g*` moves by `−H* (x_now ⊟ x̄)`.
    let mut shift = DVector::zeros(nk);
    let mut off = 0;
    let mut points: Vec<Vec<f64>> = Vec::with_capacity(kept.len());
    for b in &kept {
        let m = &problem.blocks[b.0].manifold;
        let t = m.tangent_size();
        match problem.linearization_point(*b) {
            Some(x0) => {
                m.minus(
                    problem.values(*b),
                    x0,
                    shift.as_mut_slice()[off..off + t].as_mut(),
                );
                points.push(x0.to_vec());
            }
            None => points.push(problem.values(*b).to_vec()),
        }
        off += t;
    }
    let g_star = if shift.iter().any(|v| *v != 0.0) {
        &g_star - &h_star * &shift
    } else {
        g_star
    };

    // 4. Square-root form by pivoted Cholesky.
    let kept_sizes: Vec<usize> = kept.iter().map(tangent).collect();
    let (perm, l, rank) =
        rank_revealing_cholesky(&h_star, &kept_sizes, options.relative_rank_threshold);
    // J* = (P L)ᵀ: row r, column perm[i] holds L[i][r].
    // (L is column-major: both loops run down its columns.)
    let mut jac = vec![0.0; rank * nk];
    for r in 0..rank {
        let (row, col) = (&mut jac[r * nk..(r + 1) * nk], l.column(r));
        for i in r..nk {
            row[perm[i]] = col[i];
        }
    }
    // r* from L₁ r* = (Pᵀ g*)₁ (first `rank` rows, forward substitution by columns).
    let mut r0: Vec<f64> = (0..rank).map(|r| g_star[perm[r]]).collect();
    for c in 0..rank {
        let col = l.column(c);
        r0[c] /= col[c];
        let v = r0[c];
        for r in c + 1..rank {
            r0[r] -= col[r] * v;
        }
    }
    let manifolds: Vec<Arc<dyn Manifold>> = kept
        .iter()
        .map(|b| problem.blocks[b.0].manifold.clone())
        .collect();
    let hessian = information_of_factor(&h_star, &perm, &l, rank);
    let factor = PriorFactor::with_hessian(manifolds, points, jac, r0, hessian)?;
    Ok(MarginalPrior {
        factor,
        blocks: kept,
        rank,
    })
}

/// `J*ᵀJ*` of the factor that [`rank_revealing_cholesky`] cut at `rank` from `h`, without the dense
/// product: with `P h Pᵀ = [L₁; L₂][L₁; L₂]ᵀ + [0 0; 0 S]`, it is `h − Pᵀ [0 0; 0 S] P`, where
/// the trailing Schur complement `S = (P h Pᵀ)₂₂ − L₂ L₂ᵀ` holds the directions cut (gauge
/// directions: a few). `h` must be exactly symmetric. `None` (form the product) when more than
/// a quarter of them are cut.
fn information_of_factor(
    h: &DMatrix<f64>,
    perm: &[usize],
    l: &DMatrix<f64>,
    rank: usize,
) -> Option<Vec<f64>> {
    let n = h.nrows();
    if 4 * (n - rank) > n {
        return None;
    }
    // `h` is exactly symmetric: its column-major buffer is the row-major one.
    let mut out = h.as_slice().to_vec();
    for i in rank..n {
        for j in rank..n {
            let l2: f64 = (0..rank).map(|r| l[(i, r)] * l[(j, r)]).sum();
            let (pi, pj) = (perm[i], perm[j]);
            out[pi * n + pj] = l2;
        }
    }
    Some(out)
}

/// Coordinates at the end of a [`rank_revealing_cholesky`] kept for the pivoted part besides
/// the singular blocks: room for directions without information that involve every block
/// (the gauge of visual-inertial odometry: 4).
const TAIL_SLACK: usize = 16;

/// [`pivoted_cholesky`]'s factorization (same form, same tolerance) at the speed of a blocked
/// one where the directions it cuts are few or confined to a few blocks, as in a window's
/// prior (the gauge, and new persistent points seen from one frame): the blocks of
/// `block_sizes` whose own diagonal block is singular at the tolerance, and the last
/// [`TAIL_SLACK`] coordinates, go to a tail; the rest is factored by faer's blocked Cholesky,
/// and only the tail's Schur complement by the pivoted one. Falls back to the pivoted
/// factorization of the whole matrix when the leading part has a pivot at or below the
/// tolerance or the tail is more than half of it. `a` must be exactly symmetric.
fn rank_revealing_cholesky(
    a: &DMatrix<f64>,
    block_sizes: &[usize],
    rel_tol: f64,
) -> (Vec<usize>, DMatrix<f64>, usize) {
    let n = a.nrows();
    let max_diag = (0..n).map(|i| a[(i, i)]).fold(0.0f64, f64::max);
    let tol = rel_tol * max_diag.max(f64::MIN_POSITIVE);
    // Blocks by their own diagonal block: singular ones to the tail (`a` is exactly
    // symmetric, so it is read as stored).
    let mut in_tail = Vec::with_capacity(block_sizes.len());
    let mut off = 0;
    for &t in block_sizes {
        let block = DMatrix::from_fn(t, t, |i, j| a[(off + i, off + j)]);
        in_tail.push(pivoted_cholesky_at(&block, tol).2 < t);
        off += t;
    }
    if off != n {
        return pivoted_cholesky(a, rel_tol);
    }
    let mut slack = 0;
    for k in (0..block_sizes.len()).rev() {
        if slack >= TAIL_SLACK {
            break;
        }
        if !in_tail[k] {
            in_tail[k] = true;
            slack += block_sizes[k];
        }
    }
    let (mut lead, mut tail) = (Vec::new(), Vec::new());
    let mut off = 0;
    for (k, &t) in block_sizes.iter().enumerate() {
        let to = if in_tail[k] { &mut tail } else { &mut lead };
        to.extend(off..off + t);
        off += t;
    }
    let (k, s) = (lead.len(), tail.len());
    if k == 0 || 2 * s > n {
        return pivoted_cholesky(a, rel_tol);
    }
    // L₁₁ by the blocked Cholesky; every pivot must clear the tolerance.
    let mut l11 = faer::Mat::<f64>::from_fn(k, k, |i, j| a[(lead[i], lead[j])]);
    let mut buf = MemBuffer::new(llt::cholesky_in_place_scratch::<f64>(
        k,
        Par::Seq,
        Default::default(),
    ));
    let factored = llt::cholesky_in_place(
        l11.as_mut(),
        Default::default(),
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    );
    if factored.is_err() || (0..k).any(|i| l11[(i, i)] * l11[(i, i)] <= tol) {
        return pivoted_cholesky(a, rel_tol);
    }
    // L₂₁ᵀ = L₁₁⁻¹ A₁₂, and the tail's Schur complement A₂₂ − L₂₁ L₂₁ᵀ, factored with pivots.
    let mut l21t = faer::Mat::<f64>::from_fn(k, s, |i, j| a[(lead[i], tail[j])]);
    solve_lower_triangular_in_place(l11.as_ref(), l21t.as_mut(), Par::Seq);
    let cols: Vec<Vec<f64>> = (0..s)
        .map(|j| (0..k).map(|r| l21t[(r, j)]).collect())
        .collect();
    let schur = DMatrix::from_fn(s, s, |i, j| {
        a[(tail[i], tail[j])] - crate::problem::solver::dot(&cols[i], &cols[j])
    });
    let (perm_s, ls, rank_s) = pivoted_cholesky_at(&schur, tol);
    let mut perm = lead;
    perm.extend(perm_s.iter().map(|&q| tail[q]));
    let mut l = DMatrix::zeros(n, n);
    for r in 0..k {
        for i in r..k {
            l[(i, r)] = l11[(i, r)];
        }
    }
    for (q, &ts) in perm_s.iter().enumerate() {
        for r in 0..k {
            l[(k + q, r)] = l21t[(r, ts)];
        }
        for r in 0..rank_s {
            l[(k + q, k + r)] = ls[(q, r)];
        }
    }
    (perm, l, k + rank_s)
}

/// Rank-revealing Cholesky with diagonal pivoting: `P A Pᵀ ≈ L Lᵀ` with `L` n × rank.
/// Returns (perm, L, rank) where row i of L corresponds to original index `perm[i]`.
fn pivoted_cholesky(a: &DMatrix<f64>, rel_tol: f64) -> (Vec<usize>, DMatrix<f64>, usize) {
    let n = a.nrows();
    let max_diag = (0..n).map(|i| a[(i, i)]).fold(0.0f64, f64::max);
    pivoted_cholesky_at(a, rel_tol * max_diag.max(f64::MIN_POSITIVE))
}

/// [`pivoted_cholesky`] with an absolute tolerance on the pivots.
fn pivoted_cholesky_at(a: &DMatrix<f64>, tol: f64) -> (Vec<usize>, DMatrix<f64>, usize) {
    // faer's blocked, diagonally pivoted Cholesky (LAPACK's `dpstrf` scheme: the largest
    // remaining diagonal is the next pivot; sequential, so deterministic).
    // It stops at `n ε` of the largest diagonal; the pivots it takes never grow, so cutting
    // the factor at the first pivot below `rel_tol` of the largest diagonal is the same rule
    // applied to a stricter tolerance.
    let n = a.nrows();
    if n == 0 {
        return (Vec::new(), DMatrix::zeros(0, 0), 0);
    }
    // Symmetrized lower triangle, column-major (the factor reads only the lower triangle).
    let mut m = faer::Mat::<f64>::zeros(n, n);
    for j in 0..n {
        for i in j..n {
            m[(i, j)] = 0.5 * (a[(i, j)] + a[(j, i)]);
        }
    }
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
        // A negative or NaN diagonal: no information can be trusted.
        Err(_) => 0,
    };
    let lm = DMatrix::from_fn(
        n,
        n,
        |i, r| if r < rank && i >= r { m[(i, r)] } else { 0.0 },
    );
    (perm, lm, rank)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `P L` of a factorization (row `perm[i]` holds row `i` of `L`), its first `rank` columns:
    /// `(P L)(P L)ᵀ` is what the factor says the matrix is.
    fn permuted_factor(perm: &[usize], l: &DMatrix<f64>, rank: usize) -> DMatrix<f64> {
        let mut pl = DMatrix::zeros(perm.len(), rank);
        for (i, &p) in perm.iter().enumerate() {
            for r in 0..rank {
                pl[(p, r)] = l[(i, r)];
            }
        }
        pl
    }

    #[test]
    fn pivoted_cholesky_reconstructs_a_rank_deficient_matrix() {
        // A = B Bᵀ with B 6×4: rank 4.
        let b = DMatrix::from_fn(6, 4, |i, j| {
            ((i * 7 + j * 3) % 5) as f64 - 2.0 + 0.1 * j as f64
        });
        let a = &b * b.transpose();
        let (perm, l, rank) = pivoted_cholesky(&a, 1e-12);
        assert_eq!(rank, 4);
        let pl = permuted_factor(&perm, &l, rank);
        assert!((&pl * pl.transpose() - a).norm() < 1e-9);
    }

    /// The information handed to the prior is the cut factor's own `L Lᵀ` (what `JᵀJ` would
    /// give), not the matrix it came from: the cut directions' remainder is taken out. More
    /// than a quarter cut: left to the product.
    #[test]
    fn information_of_a_cut_factor_is_its_product() {
        // A = B Bᵀ + 1e-13 (on a cut direction) with B 10×8: rank 8 at 1e-12.
        let b = DMatrix::from_fn(10, 8, |i, j| {
            ((i * 7 + j * 3) % 11) as f64 - 5.0 + 0.1 * (i * j) as f64
        });
        let mut a = &b * b.transpose();
        let null = DMatrix::from_fn(10, 1, |i, _| if i % 2 == 0 { 1.0 } else { -1.0 });
        let null = &null - &b * b.clone().pseudo_inverse(1e-12).unwrap() * &null;
        a += 1e-13 * a.abs().max() * &null * null.transpose() / null.norm_squared();
        let a = 0.5 * (&a + a.transpose());
        let (perm, l, rank) = pivoted_cholesky(&a, 1e-12);
        assert_eq!(rank, 8);
        let h = information_of_factor(&a, &perm, &l, rank).unwrap();
        let pl = permuted_factor(&perm, &l, rank);
        let llt = &pl * pl.transpose();
        let h = DMatrix::from_row_slice(10, 10, &h);
        assert!((&h - &llt).abs().max() < 1e-12 * llt.abs().max());
        assert!((&h - &a).abs().max() > 0.0);
        let (perm, l, _) = pivoted_cholesky(&a, 1e-12);
        assert!(information_of_factor(&a, &perm, &l, 7).is_none());
    }

    /// The blocked factorization cuts what the pivoted one cuts: a direction without
    /// information spread over every block (a gauge) and one inside a block (a point seen from
    /// one frame) leave the same rank and `L Lᵀ = A`; a singular leading part falls back.
    #[test]
    fn blocked_rank_revealing_cholesky_matches_the_pivoted_one() {
        let sizes = [6, 3, 3, 6, 3, 3, 6, 3, 9, 6];
        let n: usize = sizes.iter().sum();
        // B: (n − 5) × n with column 8 (the third of the block at 6..9) = columns 6 + 2·7:
        // A = BᵀB has one null direction inside that block and four in general position.
        let mut b = DMatrix::from_fn(n - 5, n, |i, j| {
            ((i * 13 + j * 7 + i * j) % 19) as f64 - 9.0 + if i == j { 20.0 } else { 0.0 }
        });
        for i in 0..n - 5 {
            b[(i, 8)] = b[(i, 6)] + 2.0 * b[(i, 7)];
        }
        let a = b.transpose() * &b;
        let a = 0.5 * (&a + a.transpose());
        let reconstruct = |(perm, l, rank): &(Vec<usize>, DMatrix<f64>, usize)| {
            let pl = permuted_factor(perm, l, *rank);
            &pl * pl.transpose()
        };
        let pivoted = pivoted_cholesky(&a, 1e-12);
        let blocked = rank_revealing_cholesky(&a, &sizes, 1e-12);
        assert_eq!(pivoted.2, n - 5);
        assert_eq!(blocked.2, n - 5);
        // The blocked one kept the first blocks in order (it did not fall back).
        assert_eq!(&blocked.0[..6], &[0, 1, 2, 3, 4, 5]);
        for f in [&pivoted, &blocked] {
            assert!((reconstruct(f) - &a).abs().max() < 1e-10 * a.abs().max());
        }
        // Its leading rows are lower triangular, as the solve for r* needs.
        for i in 0..blocked.2 {
            for r in i + 1..blocked.2 {
                assert_eq!(blocked.1[(i, r)], 0.0);
            }
        }
        // Block sizes that do not cover the matrix: the pivoted factorization.
        let fallback = rank_revealing_cholesky(&a, &[6, 3], 1e-12);
        assert_eq!(fallback.0, pivoted.0);
        assert_eq!(fallback.2, pivoted.2);
    }

    /// The rank stops at the first pivot below the relative tolerance, also where faer's own
    /// (`n ε`) would go on: a direction with 1e-13 of the largest information is dropped at
    /// 1e-12 and kept at 1e-14.
    #[test]
    fn pivoted_cholesky_cuts_at_the_relative_tolerance() {
        // Orthonormal basis from a rotation, eigenvalues 1, 0.5, 1e-13.
        let q = nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 0.9).into_inner();
        let q = DMatrix::from_fn(3, 3, |i, j| q[(i, j)]);
        let d = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 0.5, 1e-13]));
        let a = &q * d * q.transpose();
        assert_eq!(pivoted_cholesky(&a, 1e-12).2, 2);
        assert_eq!(pivoted_cholesky(&a, 1e-14).2, 3);
        assert_eq!(pivoted_cholesky(&DMatrix::zeros(2, 2), 1e-12).2, 0);
    }
}
