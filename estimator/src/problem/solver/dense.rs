//! Dense linear algebra of the solver: the Cholesky solve of the reduced system (faer) and,
//! for analysis and tests, the full dense normal equations of a problem.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{MatMut, Par};
use nalgebra::{DMatrix, DVector};

use super::normal_equations::linearize;
use super::plan::{Layout, NONE};
use super::vector::mirror_upper;
use crate::problem::graph::{BlockId, Problem};

/// The scratch of a factorization and solve of size `n` with `cols` right-hand sides, kept
/// (and reallocated when the sizes change) in `scratch`.
fn scratch_for(
    scratch: &mut Option<((usize, usize), MemBuffer)>,
    n: usize,
    cols: usize,
) -> &mut MemBuffer {
    if scratch.as_ref().is_none_or(|(m, _)| *m != (n, cols)) {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default())
            .or(llt::solve::solve_in_place_scratch::<f64>(n, cols, Par::Seq));
        *scratch = Some(((n, cols), MemBuffer::new(req)));
    }
    &mut scratch.as_mut().expect("allocated above").1
}

/// Solves `A x = b` in place for a symmetric positive-definite row-major `n × n` matrix by
/// faer's blocked Cholesky factorization (single-threaded: `Par::Seq`), overwriting `a` with
/// the factor ([`dense_cholesky_factor`]) and `b` with `x` ([`dense_cholesky_resolve`]).
/// `false` if `A` is not positive definite.
pub(crate) fn dense_cholesky_solve(
    a: &mut [f64],
    n: usize,
    b: &mut [f64],
    scratch: &mut Option<((usize, usize), MemBuffer)>,
) -> bool {
    if !dense_cholesky_factor(a, n, scratch) {
        return false;
    }
    dense_cholesky_resolve(a, n, b, scratch);
    true
}

/// Factors the symmetric positive-definite `n × n` matrix `a` in place; `false` if it is not
/// positive definite. The row-major buffer of a symmetric matrix is also its column-major
/// buffer, and the factorization reads only the lower triangle of the column-major view: the
/// upper triangle of the row-major matrix.
pub(crate) fn dense_cholesky_factor(
    a: &mut [f64],
    n: usize,
    scratch: &mut Option<((usize, usize), MemBuffer)>,
) -> bool {
    if n == 0 {
        return true;
    }
    let buf = scratch_for(scratch, n, 1);
    let stack = MemStack::new(buf);
    let l = MatMut::from_column_major_slice_mut(a, n, n);
    llt::factor::cholesky_in_place(l, Default::default(), Par::Seq, stack, Default::default())
        .is_ok()
}

/// Solves `A x = b` in place with the factor `a` that [`dense_cholesky_factor`] left (one
/// right-hand side, the same `scratch`).
pub(crate) fn dense_cholesky_resolve(
    a: &[f64],
    n: usize,
    b: &mut [f64],
    scratch: &mut Option<((usize, usize), MemBuffer)>,
) {
    if n == 0 {
        return;
    }
    let buf = scratch_for(scratch, n, 1);
    let l = faer::MatRef::from_column_major_slice(a, n, n);
    let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
    llt::solve::solve_in_place(l, rhs, Par::Seq, MemStack::new(buf));
}

/// The full normal equations `H = Σ JᵀJ`, `g = Σ Jᵀr` at the current values with every variable
/// block (landmarks included) in one dense system, in block-id order. Returns `(H, g, blocks)`,
/// where `blocks` lists the variable blocks in the order of their tangent coordinates. For
/// analysis and tests (gauge freedoms, consistency); the solver itself never forms this matrix.
pub fn dense_normal_equations(
    problem: &Problem,
) -> Option<(DMatrix<f64>, DVector<f64>, Vec<BlockId>)> {
    let mut layout = Layout::new(problem);
    let mut n = 0;
    let mut blocks = Vec::new();
    for (i, b) in problem.blocks.iter().enumerate() {
        if layout.state_offset[i] != NONE || layout.landmark_slot[i] != NONE {
            layout.state_offset[i] = n;
            layout.landmark_slot[i] = NONE;
            n += b.manifold.tangent_size();
            blocks.push(BlockId(i));
        }
    }
    layout.n = n;
    layout.landmarks.clear();
    layout.landmark_offset.clear();
    layout.n_landmark = 0;
    let mut eqs = linearize(problem, &layout, None)?;
    mirror_upper(&mut eqs.hxx, n);
    Some((
        DMatrix::from_row_slice(n, n, &eqs.hxx),
        DVector::from_vec(eqs.gx),
        blocks,
    ))
}

/// The `m × m` covariance whose entries `(r, r')` are `H⁻¹[c, c']` for each `(r, c)` of
/// `picks` (output row, column of the symmetric `n × n` information `h`, overwritten by its
/// Cholesky factor) and zero for output rows without a pick. `None` if `h` is not positive
/// definite.
pub(crate) fn covariance_of_picks(
    h: &mut [f64],
    n: usize,
    picks: &[(usize, usize)],
    m: usize,
) -> Option<DMatrix<f64>> {
    let mut scratch = None;
    dense_cholesky_factor(h, n, &mut scratch).then(|| covariance_from_factor(h, n, picks, m))
}

/// [`covariance_of_picks`] from the factor that [`dense_cholesky_factor`] left in `l`.
pub(crate) fn covariance_from_factor(
    l: &[f64],
    n: usize,
    picks: &[(usize, usize)],
    m: usize,
) -> DMatrix<f64> {
    // Unit columns of the picked coordinates, solved in place (column-major, n × picks).
    let k = picks.len();
    let mut x = vec![0.0; n * k];
    for (j, &(_, c)) in picks.iter().enumerate() {
        x[j * n + c] = 1.0;
    }
    if n > 0 {
        let mut scratch = None;
        let buf = scratch_for(&mut scratch, n, k);
        let rhs = MatMut::from_column_major_slice_mut(&mut x, n, k);
        let l = faer::MatRef::from_column_major_slice(l, n, n);
        llt::solve::solve_in_place(l, rhs, Par::Seq, MemStack::new(buf));
    }
    // Symmetric by construction up to rounding.
    let mut cov = DMatrix::zeros(m, m);
    for (i, &(ri, ci)) in picks.iter().enumerate() {
        for (j, &(rj, cj)) in picks.iter().enumerate() {
            cov[(ri, rj)] = 0.5 * (x[j * n + ci] + x[i * n + cj]);
        }
    }
    cov
}
