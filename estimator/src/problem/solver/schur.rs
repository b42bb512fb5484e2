//! Landmark elimination by the Schur complement (Ceres' `SchurEliminator` in spirit): the
//! damped reduced system over the states, its solution and the landmarks' back-substitution.
//! Inverse-depth landmarks are folded in either block pair by block pair (sparse problems) or
//! as one dense product over the coupled coordinates (small windows); see
//! `NormalEquations::dense_schur`.

use faer::dyn_stack::MemBuffer;
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{DMatrix, DVector};

use super::dense::{dense_cholesky_resolve, dense_cholesky_solve};
use super::normal_equations::{NormalEquations, linearize};
use super::plan::{Layout, NONE};
use super::vector::{Step, copy_upper, dot, mirror_upper, split_dot};
use crate::problem::graph::{BlockId, Problem, ResidualId};

impl NormalEquations {
    /// Eliminates landmark blocks from the reduced system by the Schur complement, in place:
    /// `a ← a − W C⁻¹ Wᵀ` (upper block triangle; the lower one is not touched) and
    /// `rhs ← rhs + W C⁻¹ g_l`, with `C = H_ll + λ·diag(max(H_ll, min_diag))` per landmark.
    /// `rhs` is the negative gradient (the Gauss-Newton right-hand side `−g`). Writes each
    /// landmark's `C⁻¹` into `cinv` (laid out like `hll`) and whether it exists into `valid`.
    /// A landmark whose `C` is not positive definite is an error (`false`), or skipped when
    /// `skip_singular` (marginalization: a landmark without information folds nothing in).
    #[allow(clippy::too_many_arguments)]
    pub fn eliminate(
        &self,
        lambda: f64,
        min_diag: f64,
        a: &mut [f64],
        rhs: &mut [f64],
        cinv: &mut [f64],
        valid: &mut [bool],
        skip_singular: bool,
        z: &mut SchurScratch,
    ) -> bool {
        let n = self.n;
        let mut wc: Vec<f64> = Vec::new();
        // Columns of the dense product: one per landmark coordinate (stacked like `gl`).
        let (zd, nl) = (self.zdim, self.gl.len());
        if self.dense_schur {
            z.z1.clear();
            z.z1.resize(zd * nl, 0.0);
            z.z2.clear();
            z.z2.resize(zd * nl, 0.0);
        }
        let mut dense = false;
        for l in 0..self.lt.len() {
            let t = self.lt[l];
            let (ho, go) = (self.lhoff[l], self.loff[l]);
            let cs = &self.couplings[self.cstart[l]..self.cstart[l + 1]];
            let gl = &self.gl[go..go + t];
            if t == 1 {
                // Inverse depths: C is a scalar.
                let h = self.hll[ho];
                let c = h + lambda * h.max(min_diag);
                let ci = 1.0 / c;
                if !(c > 0.0 && ci.is_finite()) {
                    valid[l] = false;
                    if skip_singular {
                        continue;
                    }
                    return false;
                }
                cinv[ho] = ci;
                valid[l] = true;
                let gs = ci * gl[0];
                if self.dense_schur {
                    // W C⁻¹ Wᵀ goes in as column l of Z₁ (W) and Z₂ (W C⁻¹), multiplied out
                    // below.
                    let zd = self.zdim;
                    let (col1, col2) = (
                        &mut z.z1[go * zd..(go + 1) * zd],
                        &mut z.z2[go * zd..(go + 1) * zd],
                    );
                    for ca in cs {
                        let wa = &self.w[ca.pos..ca.pos + ca.t];
                        for (r, w) in rhs[ca.offset..ca.offset + ca.t].iter_mut().zip(wa) {
                            *r += w * gs;
                        }
                        col1[ca.z..ca.z + ca.t].copy_from_slice(wa);
                        for (o, w) in col2[ca.z..ca.z + ca.t].iter_mut().zip(wa) {
                            *o = w * ci;
                        }
                    }
                    dense = true;
                } else {
                    // W C⁻¹ Wᵀ as an outer product per block pair.
                    for (ia, ca) in cs.iter().enumerate() {
                        let wa = &self.w[ca.pos..ca.pos + ca.t];
                        for (r, w) in rhs[ca.offset..ca.offset + ca.t].iter_mut().zip(wa) {
                            *r += w * gs;
                        }
                        // Diagonal block: upper triangle only.
                        for (i, wi) in wa.iter().enumerate() {
                            let si = wi * ci;
                            let s = (ca.offset + i) * n + ca.offset;
                            for (hv, w) in a[s + i..s + ca.t].iter_mut().zip(&wa[i..]) {
                                *hv -= si * w;
                            }
                        }
                        if ca.t == 6 {
                            // Pose blocks (the usual case): fixed sizes, unrolled.
                            let wa: &[f64; 6] = wa.try_into().unwrap();
                            let mut sa = [0.0; 6];
                            for i in 0..6 {
                                sa[i] = wa[i] * ci;
                            }
                            for cb in &cs[ia + 1..] {
                                if cb.t != 6 {
                                    continue;
                                }
                                let wb: &[f64; 6] = self.w[cb.pos..cb.pos + 6].try_into().unwrap();
                                for i in 0..6 {
                                    let s = (ca.offset + i) * n + cb.offset;
                                    let row: &mut [f64; 6] = (&mut a[s..s + 6]).try_into().unwrap();
                                    for j in 0..6 {
                                        row[j] -= sa[i] * wb[j];
                                    }
                                }
                            }
                        }
                        for cb in &cs[ia + 1..] {
                            if ca.t == 6 && cb.t == 6 {
                                continue;
                            }
                            let wb = &self.w[cb.pos..cb.pos + cb.t];
                            for (i, wi) in wa.iter().enumerate() {
                                let si = wi * ci;
                                let s = (ca.offset + i) * n + cb.offset;
                                for (hv, w) in a[s..s + cb.t].iter_mut().zip(wb) {
                                    *hv -= si * w;
                                }
                            }
                        }
                    }
                }
                continue;
            }
            let mut c = self.hll[ho..ho + t * t].to_vec();
            for i in 0..t {
                let d = c[i * t + i];
                c[i * t + i] += lambda * d.max(min_diag);
            }
            let ci = match small_spd_inverse(&c, t).filter(|c| c.iter().all(|v| v.is_finite())) {
                Some(ci) => ci,
                None => {
                    valid[l] = false;
                    if skip_singular {
                        continue;
                    }
                    return false;
                }
            };
            cinv[ho..ho + t * t].copy_from_slice(&ci);
            valid[l] = true;
            if self.dense_schur && t <= MAX_DENSE_LANDMARK {
                // W C⁻¹ Wᵀ = (W L⁻ᵀ)(W L⁻ᵀ)ᵀ with C = L Lᵀ: the t columns W L⁻ᵀ of this
                // landmark go into Z₁ and Z₂ alike; the right-hand side gains (W L⁻ᵀ)(L⁻¹ g_l).
                let Some(lc) = small_cholesky(&c, t) else {
                    valid[l] = false;
                    if skip_singular {
                        continue;
                    }
                    return false;
                };
                // y = L⁻¹ g_l.
                let mut y = [0.0; MAX_DENSE_LANDMARK];
                for i in 0..t {
                    let s: f64 = (0..i).map(|k| lc[i * t + k] * y[k]).sum();
                    y[i] = (gl[i] - s) / lc[i * t + i];
                }
                for ca in cs {
                    let wa = &self.w[ca.pos..ca.pos + ca.t * t];
                    for i in 0..ca.t {
                        // Row i of W L⁻ᵀ: m Lᵀ = w.
                        let mut m = [0.0; MAX_DENSE_LANDMARK];
                        for j in 0..t {
                            let s: f64 = (0..j).map(|k| m[k] * lc[j * t + k]).sum();
                            m[j] = (wa[i * t + j] - s) / lc[j * t + j];
                        }
                        rhs[ca.offset + i] += (0..t).map(|j| m[j] * y[j]).sum::<f64>();
                        for j in 0..t {
                            let at = (go + j) * zd + ca.z + i;
                            z.z1[at] = m[j];
                            z.z2[at] = m[j];
                        }
                    }
                }
                dense = true;
                continue;
            }
            for (ia, ca) in cs.iter().enumerate() {
                let ta = ca.t;
                // wc = W_a C⁻¹ (ta × t).
                wc.clear();
                wc.resize(ta * t, 0.0);
                let wa = &self.w[ca.pos..ca.pos + ta * t];
                for i in 0..ta {
                    for j in 0..t {
                        wc[i * t + j] = (0..t).map(|k| wa[i * t + k] * ci[k * t + j]).sum();
                    }
                }
                for i in 0..ta {
                    rhs[ca.offset + i] += (0..t).map(|j| wc[i * t + j] * gl[j]).sum::<f64>();
                }
                for cb in &cs[ia..] {
                    let wb = &self.w[cb.pos..cb.pos + cb.t * t];
                    for i in 0..ta {
                        let s = (ca.offset + i) * n + cb.offset;
                        for (jb, hv) in a[s..s + cb.t].iter_mut().enumerate() {
                            let mut acc = 0.0;
                            for k in 0..t {
                                acc += wc[i * t + k] * wb[jb * t + k];
                            }
                            *hv -= acc;
                        }
                    }
                }
            }
        }
        if dense {
            // Σ_l w_l c_l⁻¹ w_lᵀ over the coupled coordinates as one product Z₂ Z₁ᵀ (dense, but
            // only over the coordinates landmarks couple to), subtracted from the upper
            // triangle of `a`.
            z.s.clear();
            z.s.resize(zd * zd, 0.0);
            matmul(
                MatMut::from_column_major_slice_mut(&mut z.s, zd, zd),
                Accum::Replace,
                MatRef::from_column_major_slice(&z.z2, zd, nl),
                MatRef::from_column_major_slice(&z.z1, zd, nl).transpose(),
                1.0,
                Par::Seq,
            );
            for (bi, &(oi, ti, zi)) in self.zblocks.iter().enumerate() {
                for &(oj, tj, zj) in &self.zblocks[bi..] {
                    for i in 0..ti {
                        let row = (oi + i) * n + oj;
                        let j0 = if oj == oi { i } else { 0 };
                        for j in j0..tj {
                            a[row + j] -= z.s[(zi + i) + (zj + j) * zd];
                        }
                    }
                }
            }
        }
        true
    }
}

/// Scratch of [`NormalEquations::eliminate`], reused across calls.
#[derive(Default)]
pub(crate) struct SchurScratch {
    z1: Vec<f64>,
    z2: Vec<f64>,
    s: Vec<f64>,
}

/// Largest landmark tangent size the dense Schur product takes (larger ones are eliminated
/// block pair by block pair).
const MAX_DENSE_LANDMARK: usize = 4;

/// The lower Cholesky factor `L` (row-major, `L Lᵀ = a`) of a small symmetric matrix of size
/// `t ≤ MAX_DENSE_LANDMARK`; `None` if `a` is not positive definite.
fn small_cholesky(a: &[f64], t: usize) -> Option<[f64; MAX_DENSE_LANDMARK * MAX_DENSE_LANDMARK]> {
    let mut l = [0.0; MAX_DENSE_LANDMARK * MAX_DENSE_LANDMARK];
    for i in 0..t {
        for j in 0..=i {
            let s: f64 = (0..j).map(|k| l[i * t + k] * l[j * t + k]).sum();
            if i == j {
                let d = a[i * t + i] - s;
                if !(d > 0.0 && d.is_finite()) {
                    return None;
                }
                l[i * t + i] = d.sqrt();
            } else {
                l[i * t + j] = (0.5 * (a[i * t + j] + a[j * t + i]) - s) / l[j * t + j];
            }
        }
    }
    Some(l)
}

/// Inverts a small symmetric positive-definite matrix (row-major); `None` if not PD.
pub(crate) fn small_spd_inverse(a: &[f64], t: usize) -> Option<Vec<f64>> {
    if t == 1 {
        return (a[0] > 0.0).then(|| vec![1.0 / a[0]]);
    }
    let m = DMatrix::from_row_slice(t, t, a);
    let inv = m.cholesky()?.inverse();
    Some(inv.transpose().as_slice().to_vec())
}

/// Buffers of the damped reduced system, reused across the steps of a solve.
#[derive(Default)]
pub(crate) struct ReducedSystem {
    a: Vec<f64>,
    rhs: Vec<f64>,
    cinv: Vec<f64>,
    valid: Vec<bool>,
    scratch: Option<((usize, usize), MemBuffer)>,
    schur: SchurScratch,
    /// Whether `a` and `cinv` hold the factorized system of the last successful
    /// [`NormalEquations::solve_damped`], and its damping `(λ, min_diag)`.
    factored: bool,
    damping: (f64, f64),
}

impl ReducedSystem {
    /// Marks the buffers as holding no factorization (a new solve or a new linearization).
    pub(crate) fn forget_factorization(&mut self) {
        self.factored = false;
    }

    /// The Cholesky factor of the last successful [`NormalEquations::solve_damped`] (the
    /// damped reduced system, column-major lower triangle), taken out of the buffers, when its
    /// damping `λ` was at most `max_lambda`; `None` otherwise.
    pub(crate) fn take_factor(&mut self, max_lambda: f64) -> Option<Vec<f64>> {
        if !self.factored || self.damping.0 > max_lambda {
            return None;
        }
        self.factored = false;
        Some(std::mem::take(&mut self.a))
    }

    /// Gives back a buffer [`Self::take_factor`] took (the next factorization fills it), or
    /// returns it when the system already holds one.
    pub(crate) fn give_back(&mut self, buffer: Vec<f64>) -> Option<Vec<f64>> {
        if self.a.capacity() == 0 {
            self.a = buffer;
            None
        } else {
            Some(buffer)
        }
    }
}

impl NormalEquations {
    /// Solves `(H + λD) δ = −g` by eliminating landmarks, with `D = diag(max(H, min_diag))`;
    /// `None` if the reduced matrix is not positive definite.
    pub fn solve_damped(
        &self,
        lambda: f64,
        min_diag: f64,
        sys: &mut ReducedSystem,
    ) -> Option<Step> {
        let n = self.n;
        // The upper triangle (the lower one is neither kept nor read).
        copy_upper(&mut sys.a, &self.hxx, n);
        sys.rhs.clear();
        sys.rhs.extend(self.gx.iter().map(|g| -g));
        for i in 0..n {
            let d = sys.a[i * n + i];
            sys.a[i * n + i] += lambda * d.max(min_diag);
        }
        sys.cinv.resize(self.hll.len(), 0.0);
        sys.valid.resize(self.lt.len(), false);
        if !self.eliminate(
            lambda,
            min_diag,
            &mut sys.a,
            &mut sys.rhs,
            &mut sys.cinv,
            &mut sys.valid,
            false,
            &mut sys.schur,
        ) {
            return None;
        }
        // The Cholesky reads the lower triangle of the column-major matrix: the upper one of
        // this row-major buffer, which is what the copy and the elimination wrote.
        let mut dx = std::mem::take(&mut sys.rhs);
        sys.factored = false;
        if !dense_cholesky_solve(&mut sys.a, n, &mut dx, &mut sys.scratch) {
            return None;
        }
        sys.factored = true;
        sys.damping = (lambda, min_diag);
        self.back_substitute(sys, dx, &self.gl)
    }

    /// The decrease `−(gᵀδ + ½ δᵀHδ)` of the undamped quadratic model along a step `δ` that
    /// solves `(H + λD) δ = −g` with the system factorized in `sys`, in O(n) by the identity
    /// `δᵀHδ = −gᵀδ − λ δᵀDδ`: `½ (λ δᵀDδ − gᵀδ)` (Madsen, Nielsen & Tingleff).
    pub fn damped_model_decrease(
        &self,
        (gx, gl): (&[f64], &[f64]),
        step: &Step,
        sys: &ReducedSystem,
    ) -> f64 {
        let (lambda, min_diag) = sys.damping;
        let n = self.n;
        let mut ddd = 0.0;
        for i in 0..n {
            ddd += self.hxx[i * n + i].max(min_diag) * step.dx[i] * step.dx[i];
        }
        for l in 0..self.lt.len() {
            let t = self.lt[l];
            let (ho, go) = (self.lhoff[l], self.loff[l]);
            for i in 0..t {
                ddd += self.hll[ho + i * t + i].max(min_diag) * step.dl[go + i] * step.dl[go + i];
            }
        }
        0.5 * (lambda * ddd - split_dot((gx, gl), step))
    }

    /// Solves `(H + λD) δ = −g` for another gradient `g` with the system `sys` factorized by
    /// the last successful [`Self::solve_damped`] of these normal equations (same `λ`): the
    /// landmark terms fold into the right-hand side, one pair of triangular solves, the
    /// back-substitution. `None` if `sys` holds no factorization.
    pub fn solve_factored(&self, g: &Step, sys: &mut ReducedSystem) -> Option<Step> {
        if !sys.factored {
            return None;
        }
        // rhs = −g_x + W C⁻¹ g_l.
        let mut dx: Vec<f64> = g.dx.iter().map(|v| -v).collect();
        for l in 0..self.lt.len() {
            let t = self.lt[l];
            let (ho, go) = (self.lhoff[l], self.loff[l]);
            let ci = &sys.cinv[ho..ho + t * t];
            let mut v = [0.0; MAX_DENSE_LANDMARK];
            let mut heap;
            let v = if t <= MAX_DENSE_LANDMARK {
                &mut v[..t]
            } else {
                heap = vec![0.0; t];
                &mut heap[..]
            };
            for i in 0..t {
                v[i] = dot(&ci[i * t..i * t + t], &g.dl[go..go + t]);
            }
            for c in &self.couplings[self.cstart[l]..self.cstart[l + 1]] {
                for i in 0..c.t {
                    dx[c.offset + i] += dot(&self.w[c.pos + i * t..c.pos + i * t + t], v);
                }
            }
        }
        dense_cholesky_resolve(&sys.a, self.n, &mut dx, &mut sys.scratch);
        self.back_substitute(sys, dx, &g.dl)
    }

    /// Back-substitution of the landmarks, `δl = C⁻¹ (−g_l − Wᵀ δx)`, with `C⁻¹` from `sys`;
    /// `None` if the step is not finite.
    fn back_substitute(&self, sys: &ReducedSystem, dx: Vec<f64>, gl: &[f64]) -> Option<Step> {
        let mut dl = vec![0.0; gl.len()];
        for l in 0..self.lt.len() {
            let t = self.lt[l];
            let (ho, go) = (self.lhoff[l], self.loff[l]);
            let cs = &self.couplings[self.cstart[l]..self.cstart[l + 1]];
            if t == 1 {
                let mut rhs = -gl[go];
                for c in cs {
                    rhs -= dot(&self.w[c.pos..c.pos + c.t], &dx[c.offset..c.offset + c.t]);
                }
                dl[go] = sys.cinv[ho] * rhs;
                continue;
            }
            let mut rhs: Vec<f64> = gl[go..go + t].iter().map(|g| -g).collect();
            for c in cs {
                for i in 0..c.t {
                    for j in 0..t {
                        rhs[j] -= self.w[c.pos + i * t + j] * dx[c.offset + i];
                    }
                }
            }
            let ci = &sys.cinv[ho..ho + t * t];
            for i in 0..t {
                dl[go + i] = (0..t).map(|j| ci[i * t + j] * rhs[j]).sum();
            }
        }
        if dx.iter().chain(&dl).any(|v| !v.is_finite()) {
            return None;
        }
        Some(Step { dx, dl })
    }
}

impl NormalEquations {
    /// The undamped Schur complement onto the states: `H = H_xx − H_xl H_ll⁻¹ H_lx` (its upper
    /// triangle, row-major `n × n`; the lower one is left as it was),
    /// `−g = −g_x + H_xl H_ll⁻¹ g_l`, and what eliminating the landmarks takes off the model's
    /// constant, `Σ g_lᵀ H_ll⁻¹ g_l`. A landmark without information folds nothing in. Consumes
    /// the normal equations: their `H_xx` buffer becomes the result's.
    pub(crate) fn into_undamped_reduced(mut self) -> (Vec<f64>, Vec<f64>, f64) {
        let hxx = std::mem::take(&mut self.hxx);
        self.undamped_reduced_onto(hxx)
    }

    /// The Schur complement onto `h`, which holds `H_xx`'s upper triangle.
    pub(super) fn undamped_reduced_onto(&self, mut h: Vec<f64>) -> (Vec<f64>, Vec<f64>, f64) {
        let mut neg_g: Vec<f64> = self.gx.iter().map(|v| -v).collect();
        let mut cinv = vec![0.0; self.hll.len()];
        let mut valid = vec![false; self.num_landmarks()];
        self.eliminate(
            0.0,
            0.0,
            &mut h,
            &mut neg_g,
            &mut cinv,
            &mut valid,
            true,
            &mut SchurScratch::default(),
        );
        let mut eliminated = 0.0;
        for (l, &t) in self.lt.iter().enumerate() {
            if !valid[l] {
                continue;
            }
            let (ho, go) = (self.lhoff[l], self.loff[l]);
            let gl = &self.gl[go..go + t];
            let ci = &cinv[ho..ho + t * t];
            for i in 0..t {
                eliminated += gl[i] * dot(&ci[i * t..(i + 1) * t], gl);
            }
        }
        (h, neg_g, eliminated)
    }
}

/// The normal equations of some residuals over some states with landmark blocks folded in:
/// what [`schur_complement_system`] returns. The Gauss-Newton model of the residuals, minimized
/// over the eliminated blocks, is `constant + 2 gᵀδ + δᵀH δ` (twice the solver's cost).
pub struct SchurComplementSystem {
    /// `H` (symmetric, exactly).
    pub hessian: DMatrix<f64>,
    /// `g = Σ J̃ᵀ r̃` with the eliminated blocks folded in.
    pub gradient: DVector<f64>,
    /// The model's value at `δ = 0`: `Σ ‖r̃‖²` less what the eliminated blocks take off.
    pub constant: f64,
}

/// The normal equations `H δ = −g` of the residuals `residual_ids` at the problem's current
/// values over the blocks `states` (tangent coordinates stacked in this order), with the blocks
/// `eliminated` folded in by the (undamped) Schur complement: `H = H_xx − H_xl H_ll⁻¹ H_lx`,
/// `g = g_x − H_xl H_ll⁻¹ g_l`. An eliminated block must be a landmark block (a residual touches
/// at most one); one without information folds nothing in. Every block the residuals touch must
/// be in `states`, in `eliminated` or constant. `None` if a residual cannot be evaluated.
///
/// This is the linear API marginalization builds on (`states` = removed states, then kept).
pub fn schur_complement_system(
    problem: &Problem,
    residual_ids: &[ResidualId],
    states: &[BlockId],
    eliminated: &[BlockId],
) -> Option<SchurComplementSystem> {
    let nblocks = problem.blocks.len();
    let mut state_offset = vec![NONE; nblocks];
    let mut landmark_slot = vec![NONE; nblocks];
    let (mut landmarks, mut landmark_offset) = (Vec::new(), Vec::new());
    let mut n_landmark = 0;
    for b in eliminated {
        landmark_slot[b.0] = landmarks.len();
        landmarks.push(b.0);
        landmark_offset.push(n_landmark);
        n_landmark += problem.blocks[b.0].manifold.tangent_size();
    }
    let mut n = 0;
    for b in states {
        state_offset[b.0] = n;
        n += problem.blocks[b.0].manifold.tangent_size();
    }
    let layout = Layout {
        state_offset,
        landmark_slot,
        landmarks,
        landmark_offset,
        n,
        n_landmark,
    };
    let ids: Vec<usize> = residual_ids.iter().map(|r| r.0).collect();
    let eqs = linearize(problem, &layout, Some(&ids))?;
    let constant = eqs.model_constant;
    let (mut h, neg_g, eliminated) = eqs.into_undamped_reduced();
    // Mirrored, so exactly symmetric: the row-major buffer is the column-major one.
    mirror_upper(&mut h, n);
    Some(SchurComplementSystem {
        hessian: DMatrix::from_vec(n, n, h),
        gradient: DVector::from_iterator(n, neg_g.iter().map(|v| -v)),
        constant: constant - eliminated,
    })
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::problem::solver::dense_normal_equations;
    use crate::problem::test_lcg as lcg;
    use crate::problem::{BlockKind, Euclidean, LinearFactor};

    #[test]
    fn schur_step_equals_dense_solve() {
        let mut seed = 7u64;
        let mut p = Problem::new();
        let states: Vec<_> = (0..4)
            .map(|_| {
                p.add_block(&[0.0; 6], Arc::new(Euclidean::new(6)), BlockKind::State)
                    .unwrap()
            })
            .collect();
        let lms: Vec<_> = (0..12)
            .map(|_| {
                p.add_block(&[0.5], Arc::new(Euclidean::new(1)), BlockKind::Landmark)
                    .unwrap()
            })
            .collect();
        for (li, l) in lms.iter().enumerate() {
            for s in states.iter().skip(li % 2) {
                let a = vec![
                    (0..12).map(|_| lcg(&mut seed)).collect(),
                    (0..2).map(|_| lcg(&mut seed)).collect(),
                ];
                let b = (0..2).map(|_| lcg(&mut seed)).collect();
                let f = LinearFactor::new(a, b, vec![6, 1]).unwrap();
                p.add_factor(Arc::new(f), None, &[*s, *l]).unwrap();
            }
        }
        let prior_a = vec![
            (0..36)
                .map(|i| if i % 7 == 0 { 1.0 } else { 0.0 })
                .collect(),
        ];
        let f = LinearFactor::new(prior_a, vec![0.1; 6], vec![6]).unwrap();
        p.add_factor(Arc::new(f), None, &[states[0]]).unwrap();
        let layout = Layout::new(&p);
        let mut eqs = linearize(&p, &layout, None).unwrap();
        let (h, g, _) = dense_normal_equations(&p).unwrap();
        // Both elimination paths: block pair by block pair, and one dense product.
        for (dense_schur, lambda) in [false, true]
            .into_iter()
            .flat_map(|d| [0.0, 1e-3, 10.0].map(|l| (d, l)))
        {
            eqs.dense_schur = dense_schur;
            let mut sys = ReducedSystem::default();
            let step = eqs.solve_damped(lambda, 1e-6, &mut sys).unwrap();
            let d = DMatrix::from_diagonal(&h.diagonal().map(|v| v.max(1e-6)));
            let damped = (&h + d * lambda).cholesky().unwrap();
            let max_err = |s: &Step, dense: &DVector<f64>| {
                let ours: Vec<f64> = s.dx.iter().chain(&s.dl).copied().collect();
                let err = ours
                    .iter()
                    .zip(dense.iter())
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                err / dense.amax().max(1.0)
            };
            let dense = damped.solve(&(-&g));
            let err = max_err(&step, &dense);
            assert!(err < 1e-9, "dense_schur={dense_schur} λ={lambda}: {err:e}");
            // The model decrease by the damping identity equals −(gᵀδ + ½ δᵀHδ).
            let quadratic = -(g.dot(&dense) + 0.5 * dense.dot(&(&h * &dense)));
            let identity = eqs.damped_model_decrease((&eqs.gx, &eqs.gl), &step, &sys);
            assert!(
                (identity - quadratic).abs() < 1e-9 * quadratic.abs().max(1.0),
                "dense_schur={dense_schur} λ={lambda}: {identity} against {quadratic}"
            );
            // Another gradient through the same factorization.
            let g2: Vec<f64> = (0..g.len()).map(|_| lcg(&mut seed)).collect();
            let nx = eqs.gx.len();
            let other = Step {
                dx: g2[..nx].to_vec(),
                dl: g2[nx..].to_vec(),
            };
            let step2 = eqs.solve_factored(&other, &mut sys).unwrap();
            let dense2 = damped.solve(&(-DVector::from_vec(g2)));
            let err = max_err(&step2, &dense2);
            assert!(
                err < 1e-9,
                "factored, dense_schur={dense_schur} λ={lambda}: {err:e}"
            );
        }
        // Nothing factorized: no step.
        let other = Step {
            dx: eqs.gx.clone(),
            dl: eqs.gl.clone(),
        };
        assert!(
            eqs.solve_factored(&other, &mut ReducedSystem::default())
                .is_none()
        );
    }
}
