//! Linearization: every planned residual's Jacobian rows accumulated into `H_xx`, the landmark
//! blocks `H_ll` and the couplings `H_xl`, and cost and gradient evaluation in a fixed order.

use super::normal_equations::NormalEquations;
use super::plan::{NONE, ResidualPlan, Slot};
use super::vector::Step;
use crate::problem::graph::Problem;

/// `H[a, b] += Jaᵀ Jb` on a row-major `n × n` buffer (only the block with the smaller offset
/// first is written: `H_xx` is kept as its upper triangle).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn add_jtj(
    h: &mut [f64],
    n: usize,
    (oa, ta, ja): (usize, usize, &[f64]),
    (ob, tb, jb): (usize, usize, &[f64]),
    m: usize,
) {
    let (oa, ta, ja, ob, tb, jb) = if oa <= ob {
        (oa, ta, ja, ob, tb, jb)
    } else {
        (ob, tb, jb, oa, ta, ja)
    };
    if m == 2 {
        // Reprojection residuals: two rows, summed in one pass over the block.
        let (a0, a1) = (&ja[..ta], &ja[ta..2 * ta]);
        let (b0, b1) = (&jb[..tb], &jb[tb..2 * tb]);
        if ta == 6 && tb == 6 {
            // Pose × pose: fixed sizes, unrolled.
            let (a0, a1): (&[f64; 6], &[f64; 6]) = (a0.try_into().unwrap(), a1.try_into().unwrap());
            let (b0, b1): (&[f64; 6], &[f64; 6]) = (b0.try_into().unwrap(), b1.try_into().unwrap());
            for i in 0..6 {
                let (x0, x1) = (a0[i], a1[i]);
                let s = (oa + i) * n + ob;
                let row: &mut [f64; 6] = (&mut h[s..s + 6]).try_into().unwrap();
                for j in 0..6 {
                    row[j] += x0 * b0[j] + x1 * b1[j];
                }
            }
            return;
        }
        for i in 0..ta {
            let (x0, x1) = (a0[i], a1[i]);
            let row = &mut h[(oa + i) * n + ob..(oa + i) * n + ob + tb];
            for ((hv, y0), y1) in row.iter_mut().zip(b0).zip(b1) {
                *hv += x0 * y0 + x1 * y1;
            }
        }
        return;
    }
    for r in 0..m {
        let ra = &ja[r * ta..r * ta + ta];
        let rb = &jb[r * tb..r * tb + tb];
        for (i, a) in ra.iter().enumerate() {
            if *a == 0.0 {
                continue;
            }
            // A diagonal block: its upper triangle.
            let from = if oa == ob { i } else { 0 };
            let row = &mut h[(oa + i) * n + ob + from..(oa + i) * n + ob + tb];
            for (hv, b) in row.iter_mut().zip(&rb[from..]) {
                *hv += a * b;
            }
        }
    }
}

/// Adds a factor's directly computed gradient `g_direct` (its blocks' tangent coordinates in
/// slot order) to the reduced gradient `dst` at its variable state blocks.
fn add_direct_gradient(slots: &[Slot], g_direct: &[f64], dst: &mut [f64]) {
    let mut la = 0;
    for s in slots {
        if s.offset != NONE {
            for (d, v) in dst[s.offset..s.offset + s.t]
                .iter_mut()
                .zip(&g_direct[la..la + s.t])
            {
                *d += v;
            }
        }
        la += s.t;
    }
}

impl NormalEquations {
    /// Evaluates every planned residual with Jacobians at the problem's current values and
    /// accumulates the normal equations; `false` if a residual cannot be evaluated.
    ///
    /// Also sets [`Self::cost`], summed in the same order as [`Self::cost_at`].
    pub fn linearize(&mut self, problem: &Problem) -> bool {
        let n = self.n;
        for i in 0..n {
            self.hxx[i * n + i..(i + 1) * n].fill(0.0);
        }
        self.gx.fill(0.0);
        self.hll.fill(0.0);
        self.gl.fill(0.0);
        self.w.fill(0.0);
        let mut total = 0.0;
        self.model_constant = 0.0;
        problem.fill_rotations(&problem.values, &mut self.rot);
        problem.fill_linearization_rotations(&self.rot, &mut self.rot_lin);
        let mut plans = std::mem::take(&mut self.state_res);
        let mut ok = true;
        for p in &mut plans {
            let direct = if p.direct {
                self.accumulate_direct(problem, p)
            } else {
                None
            };
            // A factor without direct normal equations is evaluated from now on (also by
            // `cost_at` and `gradient_at`, so that every pass sums the same terms).
            p.direct = direct.is_some();
            let rho = direct.or_else(|| self.accumulate(problem, p));
            match rho {
                Some(rho) => total += rho,
                None => {
                    ok = false;
                    break;
                }
            }
        }
        self.state_res = plans;
        if !ok {
            return false;
        }
        let plans = std::mem::take(&mut self.lm_res);
        for p in &plans {
            match self.accumulate(problem, p) {
                Some(rho) => total += rho,
                None => {
                    ok = false;
                    break;
                }
            }
        }
        self.lm_res = plans;
        self.cost = 0.5 * total;
        ok
    }

    /// `ρ(‖r‖²)` of one planned residual at `values`, without Jacobians.
    pub(super) fn evaluate_cost(
        &mut self,
        problem: &Problem,
        values: &[f64],
        p: &ResidualPlan,
    ) -> Option<f64> {
        if p.direct
            && let Some(cost) = self.direct_normal_equations(problem, values, p, false)
        {
            // The cost as the normal equations give it (as `linearize` sums it).
            return Some(cost);
        }
        // `self.rot` holds the rotations at `values` (filled by the caller).
        let rot = (&self.rot[..], &self.rot_lin[..]);
        problem.evaluate_residual_with(values, Some(rot), p.ri, &mut self.r[..p.m], None)
    }

    /// Total cost `½ Σ ρ(‖r‖²)` of the planned residuals at `values`, summed in the order of
    /// [`Self::linearize`] (so that the two agree exactly at the same point); `None` if a
    /// residual cannot be evaluated.
    pub fn cost_at(&mut self, problem: &Problem, values: &[f64]) -> Option<f64> {
        let mut total = 0.0;
        problem.fill_rotations(values, &mut self.rot);
        let (state_res, lm_res) = (
            std::mem::take(&mut self.state_res),
            std::mem::take(&mut self.lm_res),
        );
        let mut ok = true;
        for p in state_res.iter().chain(&lm_res) {
            match self.evaluate_cost(problem, values, p) {
                Some(rho) => total += rho,
                None => {
                    ok = false;
                    break;
                }
            }
        }
        self.state_res = state_res;
        self.lm_res = lm_res;
        ok.then_some(0.5 * total)
    }

    /// Evaluates one residual at `values` with its Jacobians into the scratch `r` and `jac`
    /// (laid out by the plan's slots); returns its `ρ(‖r‖²)`. `self.rot` must hold the
    /// rotations at `values`.
    fn evaluate_jacobians(
        &mut self,
        problem: &Problem,
        values: &[f64],
        p: &ResidualPlan,
    ) -> Option<f64> {
        let m = p.m;
        let slots = &self.slots[p.slots.0..p.slots.1];
        let nb = slots.len();
        let mut rest: &mut [f64] = &mut self.jac[..p.jlen];
        let mut small: [Option<&mut [f64]>; 16] = Default::default();
        let mut heap: Vec<Option<&mut [f64]>>;
        let js: &mut [Option<&mut [f64]>] = if nb <= small.len() {
            &mut small[..nb]
        } else {
            heap = (0..nb).map(|_| None).collect();
            &mut heap
        };
        for (k, s) in slots.iter().enumerate() {
            if s.jpos != NONE {
                let (head, tail) = std::mem::take(&mut rest).split_at_mut(m * s.t);
                js[k] = Some(head);
                rest = tail;
            }
        }
        let rot = (&self.rot[..], &self.rot_lin[..]);
        problem.evaluate_residual_with(values, Some(rot), p.ri, &mut self.r[..m], Some(js))
    }

    /// Evaluates one residual with Jacobians and adds its rows; returns its `ρ(‖r‖²)`.
    fn accumulate(&mut self, problem: &Problem, p: &ResidualPlan) -> Option<f64> {
        let rho = self.evaluate_jacobians(problem, &problem.values, p)?;
        let m = p.m;
        let slots = &self.slots[p.slots.0..p.slots.1];
        let r = &self.r[..m];
        self.model_constant += r.iter().map(|v| v * v).sum::<f64>();
        let jac = &self.jac[..p.jlen];
        let n = self.n;
        // The landmark's own rows and its Jacobian, if any.
        let lm = (p.landmark != NONE).then(|| {
            let s = slots[p.landmark];
            (s.t, &jac[s.jpos..s.jpos + m * s.t])
        });
        if let Some((tl, jl)) = lm {
            let (ho, go) = (self.lhoff[p.lm], self.loff[p.lm]);
            let hll = &mut self.hll[ho..ho + tl * tl];
            let gl = &mut self.gl[go..go + tl];
            for rr in 0..m {
                let row = &jl[rr * tl..rr * tl + tl];
                for i in 0..tl {
                    gl[i] += row[i] * r[rr];
                    for j in 0..tl {
                        hll[i * tl + j] += row[i] * row[j];
                    }
                }
            }
        }
        if m == 2 {
            // Reprojection residuals: both rows in one pass over each block.
            let (r0, r1) = (r[0], r[1]);
            for (a, sa) in slots.iter().enumerate() {
                let oa = sa.offset;
                if oa == NONE {
                    continue;
                }
                let ta = sa.t;
                let (a0, a1) = jac[sa.jpos..sa.jpos + 2 * ta].split_at(ta);
                for ((g, x0), x1) in self.gx[oa..oa + ta].iter_mut().zip(a0).zip(a1) {
                    *g += x0 * r0 + x1 * r1;
                }
                // Diagonal block: upper triangle only.
                if ta == 6 {
                    // Pose blocks: fixed sizes, unrolled.
                    let (b0, b1): (&[f64; 6], &[f64; 6]) =
                        (a0.try_into().unwrap(), a1.try_into().unwrap());
                    for i in 0..6 {
                        let (x0, x1) = (b0[i], b1[i]);
                        let s0 = (oa + i) * n + oa;
                        let row: &mut [f64; 6] = (&mut self.hxx[s0..s0 + 6]).try_into().unwrap();
                        for j in i..6 {
                            row[j] += x0 * b0[j] + x1 * b1[j];
                        }
                    }
                } else {
                    for i in 0..ta {
                        let (x0, x1) = (a0[i], a1[i]);
                        let s0 = (oa + i) * n + oa;
                        let row = &mut self.hxx[s0 + i..s0 + ta];
                        for ((hv, y0), y1) in row.iter_mut().zip(&a0[i..]).zip(&a1[i..]) {
                            *hv += x0 * y0 + x1 * y1;
                        }
                    }
                }
                for sb in &slots[a + 1..] {
                    if sb.offset == NONE {
                        continue;
                    }
                    let jb = &jac[sb.jpos..sb.jpos + 2 * sb.t];
                    let ja = &jac[sa.jpos..sa.jpos + 2 * ta];
                    add_jtj(&mut self.hxx, n, (oa, ta, ja), (sb.offset, sb.t, jb), 2);
                }
                if let Some((tl, jl)) = lm {
                    let c = self.couplings[sa.coupling];
                    let wb = &mut self.w[c.pos..c.pos + ta * tl];
                    if tl == 1 {
                        let (j0, j1) = (jl[0], jl[1]);
                        for ((w, x0), x1) in wb.iter_mut().zip(a0).zip(a1) {
                            *w += x0 * j0 + x1 * j1;
                        }
                    } else if tl == 3 {
                        // Landmarks `[λ, cx, cy]`: fixed sizes, unrolled.
                        let l0: &[f64; 3] = jl[..3].try_into().unwrap();
                        let l1: &[f64; 3] = jl[3..6].try_into().unwrap();
                        for ((w, x0), x1) in wb.chunks_exact_mut(3).zip(a0).zip(a1) {
                            for j in 0..3 {
                                w[j] += x0 * l0[j] + x1 * l1[j];
                            }
                        }
                    } else {
                        for i in 0..ta {
                            for j in 0..tl {
                                wb[i * tl + j] += a0[i] * jl[j] + a1[i] * jl[tl + j];
                            }
                        }
                    }
                }
            }
            return Some(rho);
        }
        for (a, sa) in slots.iter().enumerate() {
            let oa = sa.offset;
            if oa == NONE {
                continue;
            }
            let ta = sa.t;
            let ja = &jac[sa.jpos..sa.jpos + m * ta];
            let gx = &mut self.gx[oa..oa + ta];
            for rr in 0..m {
                let rv = r[rr];
                for (g, j) in gx.iter_mut().zip(&ja[rr * ta..rr * ta + ta]) {
                    *g += j * rv;
                }
            }
            for sb in &slots[a..] {
                if sb.offset == NONE {
                    continue;
                }
                let jb = &jac[sb.jpos..sb.jpos + m * sb.t];
                add_jtj(&mut self.hxx, n, (oa, ta, ja), (sb.offset, sb.t, jb), m);
            }
            if let Some((tl, jl)) = lm {
                let c = self.couplings[sa.coupling];
                let wb = &mut self.w[c.pos..c.pos + ta * tl];
                for rr in 0..m {
                    for i in 0..ta {
                        let av = ja[rr * ta + i];
                        for j in 0..tl {
                            wb[i * tl + j] += av * jl[rr * tl + j];
                        }
                    }
                }
            }
        }
        Some(rho)
    }

    /// A factor's directly computed normal equations at `values` (see
    /// `Factor::normal_equations`) into the scratch `direct_h` (left empty without
    /// `with_hessian`), `direct_g`, returning its `‖r‖²`; `None` if the factor does not
    /// provide them.
    fn direct_normal_equations(
        &mut self,
        problem: &Problem,
        values: &[f64],
        p: &ResidualPlan,
        with_hessian: bool,
    ) -> Option<f64> {
        let res = &problem.residuals[p.ri];
        let slots = &self.slots[p.slots.0..p.slots.1];
        let total: usize = slots.iter().map(|s| s.t).sum();
        self.direct_h.clear();
        if with_hessian {
            self.direct_h.resize(total * total, 0.0);
        }
        self.direct_g.clear();
        self.direct_g.resize(total, 0.0);
        let (h, g) = (&mut self.direct_h, &mut self.direct_g);
        problem.with_residual_params(values, p.ri, |params| {
            problem.with_linearization_params(values, p.ri, |lin_params| {
                res.factor.normal_equations(params, lin_params, h, g)
            })
        })
    }

    /// Adds a factor's directly computed normal equations (see `Factor::normal_equations`)
    /// and returns its `‖r‖²`; `None` if the factor does not provide them.
    fn accumulate_direct(&mut self, problem: &Problem, p: &ResidualPlan) -> Option<f64> {
        let res = &problem.residuals[p.ri];
        let constant = problem.with_linearization_params(&problem.values, p.ri, |lin_params| {
            res.factor.constant_hessian(lin_params)
        });
        let cost = self.direct_normal_equations(problem, &problem.values, p, constant.is_none())?;
        self.model_constant += cost;
        let slots = &self.slots[p.slots.0..p.slots.1];
        let total: usize = slots.iter().map(|s| s.t).sum();
        add_direct_gradient(slots, &self.direct_g, &mut self.gx);
        let (h, n) = (constant.unwrap_or(&self.direct_h), self.n);
        let mut la = 0;
        for sa in slots {
            let (oa, ta) = (sa.offset, sa.t);
            if oa != NONE {
                let mut lb = 0;
                for sb in slots {
                    let (ob, tb) = (sb.offset, sb.t);
                    if ob != NONE && ob >= oa {
                        for i in 0..ta {
                            // The diagonal block's upper triangle only.
                            let from = if ob == oa { i } else { 0 };
                            let src = &h[(la + i) * total + lb + from..(la + i) * total + lb + tb];
                            let dst =
                                &mut self.hxx[(oa + i) * n + ob + from..(oa + i) * n + ob + tb];
                            for (d, s) in dst.iter_mut().zip(src) {
                                *d += s;
                            }
                        }
                    }
                    lb += tb;
                }
            }
            la += ta;
        }
        Some(cost)
    }

    /// The cost `½ Σ ρ` and the gradient (`g.dx` over the reduced states, `g.dl` over the
    /// stacked landmarks) at `values`, without forming any second-order term: what a modified
    /// Gauss–Newton step needs besides the factorized system of an earlier linearization.
    /// The cost is summed as in [`Self::cost_at`] (bit-equal to it); `None` if a residual
    /// cannot be evaluated.
    pub(super) fn gradient_at(
        &mut self,
        problem: &Problem,
        values: &[f64],
        g: &mut Step,
    ) -> Option<f64> {
        g.dx.clear();
        g.dx.resize(self.n, 0.0);
        g.dl.clear();
        g.dl.resize(self.gl.len(), 0.0);
        problem.fill_rotations(values, &mut self.rot);
        problem.fill_linearization_rotations(&self.rot, &mut self.rot_lin);
        let (state_res, lm_res) = (
            std::mem::take(&mut self.state_res),
            std::mem::take(&mut self.lm_res),
        );
        let mut total = Some(0.0);
        for p in state_res.iter().chain(&lm_res) {
            let direct = if p.direct {
                self.direct_normal_equations(problem, values, p, false)
            } else {
                None
            };
            let rho = if let Some(cost) = direct {
                let slots = &self.slots[p.slots.0..p.slots.1];
                add_direct_gradient(slots, &self.direct_g, &mut g.dx);
                Some(cost)
            } else {
                self.evaluate_jacobians(problem, values, p).inspect(|_| {
                    let (m, r) = (p.m, &self.r[..p.m]);
                    let slots = &self.slots[p.slots.0..p.slots.1];
                    for (k, s) in slots.iter().enumerate() {
                        let dst = if s.offset != NONE {
                            &mut g.dx[s.offset..s.offset + s.t]
                        } else if k == p.landmark {
                            let go = self.loff[p.lm];
                            &mut g.dl[go..go + s.t]
                        } else {
                            continue;
                        };
                        let j = &self.jac[s.jpos..s.jpos + m * s.t];
                        for (rr, rv) in r.iter().enumerate() {
                            for (d, jv) in dst.iter_mut().zip(&j[rr * s.t..rr * s.t + s.t]) {
                                *d += jv * rv;
                            }
                        }
                    }
                })
            };
            match (rho, total) {
                (Some(rho), Some(t)) => total = Some(t + rho),
                _ => {
                    total = None;
                    break;
                }
            }
        }
        self.state_res = state_res;
        self.lm_res = lm_res;
        total.map(|t| 0.5 * t)
    }
}
