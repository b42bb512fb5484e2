//! Levenberg–Marquardt and Powell's dogleg on the manifold, with landmark blocks eliminated by
//! the Schur complement and the reduced system solved by dense Cholesky.
//!
//! Everything is deterministic: blocks are visited in id order, no threads, and stopping is
//! decided by iteration count, cost change, gradient and step size — never by wall-clock time.
//! Timing is measured for reports only.

use std::time::{Duration, Instant};

use nalgebra::{DMatrix, DVector};

use super::graph::{BlockKind, Problem};

/// Which trust-region strategy to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Levenberg–Marquardt with Ceres-style Jacobi damping `λ·diag(JᵀJ)`.
    LevenbergMarquardt,
    /// Powell's dogleg between the Cauchy point and the Gauss–Newton step.
    Dogleg,
}

/// Solver settings. Stop criteria are all relative or absolute tolerances and an iteration
/// cap, never time.
#[derive(Clone, Copy, Debug)]
pub struct SolverOptions {
    /// Trust-region strategy.
    pub method: Method,
    /// Maximum number of iterations (linearizations).
    pub max_iterations: usize,
    /// Stop when `|Δcost| / cost` of an accepted step falls below this.
    pub function_tolerance: f64,
    /// Stop when `max |g|` falls below this.
    pub gradient_tolerance: f64,
    /// Stop when `‖δ‖ ≤ tol · (‖x‖ + tol)`.
    pub parameter_tolerance: f64,
    /// Initial trust radius (LM: `λ = 1/radius`).
    pub initial_trust_radius: f64,
    /// Clamp of the Jacobi scaling `diag(JᵀJ)` from below.
    pub min_diagonal: f64,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            method: Method::LevenbergMarquardt,
            max_iterations: 10,
            function_tolerance: 1e-6,
            gradient_tolerance: 1e-10,
            parameter_tolerance: 1e-8,
            initial_trust_radius: 1e4,
            min_diagonal: 1e-6,
        }
    }
}

/// Why the solver stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Termination {
    /// A tolerance was met.
    Converged,
    /// The iteration cap was reached.
    MaxIterations,
    /// No step could reduce the cost (trust region collapsed or factorization kept failing).
    NoProgress,
    /// The initial point could not be evaluated.
    InvalidInitialPoint,
    /// There was nothing to optimize.
    NothingToDo,
}

/// Statistics of one solve, for logs and timing reports.
#[derive(Clone, Copy, Debug)]
pub struct SolverSummary {
    /// Linearizations performed.
    pub iterations: usize,
    /// Accepted steps.
    pub successful_steps: usize,
    /// `½ Σ ρ` before.
    pub initial_cost: f64,
    /// `½ Σ ρ` after.
    pub final_cost: f64,
    /// Why it stopped.
    pub termination: Termination,
    /// Size of the reduced (dense) system.
    pub reduced_size: usize,
    /// Number of eliminated landmark blocks.
    pub landmarks: usize,
    /// Wall time spent (measured for reports; never used for decisions).
    pub time: Duration,
}

const NONE: usize = usize::MAX;

/// Where each variable block lives in the linear system.
pub(crate) struct Layout {
    /// Offset in the reduced system for variable state blocks, `NONE` otherwise.
    pub state_offset: Vec<usize>,
    /// Index into the landmark list for variable landmark blocks, `NONE` otherwise.
    pub landmark_slot: Vec<usize>,
    /// Landmark block indices in id order.
    pub landmarks: Vec<usize>,
    /// Offset of each landmark in the stacked landmark vector.
    pub landmark_offset: Vec<usize>,
    /// Size of the reduced system.
    pub n: usize,
    /// Total landmark tangent dimension.
    pub n_landmark: usize,
}

impl Layout {
    pub fn new(problem: &Problem) -> Self {
        let mut state_offset = vec![NONE; problem.blocks.len()];
        let mut landmark_slot = vec![NONE; problem.blocks.len()];
        let mut landmarks = Vec::new();
        let mut landmark_offset = Vec::new();
        let (mut n, mut nl) = (0, 0);
        // Only blocks some residual touches enter the system.
        let mut used = vec![false; problem.blocks.len()];
        for r in &problem.residuals {
            for b in &r.blocks {
                used[b.0] = true;
            }
        }
        for (i, b) in problem.blocks.iter().enumerate() {
            if b.constant || !used[i] {
                continue;
            }
            match b.kind {
                BlockKind::State => {
                    state_offset[i] = n;
                    n += b.manifold.tangent_size();
                }
                BlockKind::Landmark => {
                    landmark_slot[i] = landmarks.len();
                    landmarks.push(i);
                    landmark_offset.push(nl);
                    nl += b.manifold.tangent_size();
                }
            }
        }
        Self {
            state_offset,
            landmark_slot,
            landmarks,
            landmark_offset,
            n,
            n_landmark: nl,
        }
    }
}

/// One landmark's rows of the normal equations: `H_ll`, `g_l` and the coupling `H_xl`.
#[derive(Clone, Default)]
pub(crate) struct LandmarkBlock {
    pub t: usize,
    pub hll: Vec<f64>,
    pub gl: Vec<f64>,
    /// (state offset, state tangent size, `t_a × t` row-major block of `H_xl`).
    pub w: Vec<(usize, usize, Vec<f64>)>,
}

/// Normal equations `H δ = −g` at a linearization point, landmarks kept apart.
pub(crate) struct NormalEquations {
    pub n: usize,
    /// Reduced-state block `H_xx` (row-major, full).
    pub hxx: Vec<f64>,
    pub gx: Vec<f64>,
    pub landmarks: Vec<LandmarkBlock>,
}

/// `H[a, b] += Jaᵀ Jb` on a row-major `n × n` buffer (only the block with the smaller offset
/// first is written; [`mirror_upper`] completes the matrix).
#[inline]
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
        for i in 0..ta {
            let (x0, x1) = (a0[i], a1[i]);
            let row = &mut h[(oa + i) * n + ob..(oa + i) * n + ob + tb];
            for j in 0..tb {
                row[j] += x0 * b0[j] + x1 * b1[j];
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
            let row = &mut h[(oa + i) * n + ob..(oa + i) * n + ob + tb];
            for (hv, b) in row.iter_mut().zip(rb) {
                *hv += a * b;
            }
        }
    }
}

/// Copies the upper triangle of a row-major square matrix onto its lower triangle.
pub(crate) fn mirror_upper(h: &mut [f64], n: usize) {
    for i in 0..n {
        for j in i + 1..n {
            h[j * n + i] = h[i * n + j];
        }
    }
}

/// Evaluates every residual with Jacobians and accumulates the normal equations.
pub(crate) fn linearize(
    problem: &Problem,
    layout: &Layout,
    residual_ids: Option<&[usize]>,
) -> Option<NormalEquations> {
    let n = layout.n;
    let mut hxx = vec![0.0; n * n];
    let mut gx = vec![0.0; n];
    let mut landmarks: Vec<LandmarkBlock> = layout
        .landmarks
        .iter()
        .map(|&b| {
            let t = problem.blocks[b].manifold.tangent_size();
            LandmarkBlock {
                t,
                hll: vec![0.0; t * t],
                gl: vec![0.0; t],
                w: Vec::new(),
            }
        })
        .collect();
    let mut r = vec![0.0; 16];
    let mut jac: Vec<Vec<f64>> = Vec::new();
    let all: Vec<usize>;
    let ids = match residual_ids {
        Some(ids) => ids,
        None => {
            all = (0..problem.residuals.len()).collect();
            &all
        }
    };
    let mut gn_h: Vec<f64> = Vec::new();
    let mut gn_g: Vec<f64> = Vec::new();
    for &ri in ids {
        let res = &problem.residuals[ri];
        let m = res.factor.residual_dim();
        let tangents = res.factor.parameter_tangent_sizes();
        if res.loss.is_none()
            && res.blocks.iter().all(|b| layout.landmark_slot[b.0] == NONE)
            && accumulate_direct(problem, layout, ri, &mut gn_h, &mut gn_g, &mut hxx, &mut gx)
        {
            continue;
        }
        if r.len() < m {
            r.resize(m, 0.0);
        }
        while jac.len() < res.blocks.len() {
            jac.push(Vec::new());
        }
        let mut active = [false; 64];
        let nb = res.blocks.len();
        let mut active_vec = vec![false; if nb > 64 { nb } else { 0 }];
        let active: &mut [bool] = if nb <= 64 {
            &mut active[..nb]
        } else {
            &mut active_vec
        };
        for (k, b) in res.blocks.iter().enumerate() {
            active[k] = layout.state_offset[b.0] != NONE || layout.landmark_slot[b.0] != NONE;
            if jac[k].len() < m * tangents[k] {
                jac[k].resize(m * tangents[k], 0.0);
            }
        }
        {
            let mut js: [Option<&mut [f64]>; 16] = Default::default();
            let mut heap: Vec<Option<&mut [f64]>>;
            let js: &mut [Option<&mut [f64]>] = if nb <= js.len() {
                for (k, j) in jac.iter_mut().take(nb).enumerate() {
                    js[k] = active[k].then(|| &mut j[..m * tangents[k]]);
                }
                &mut js[..nb]
            } else {
                heap = jac
                    .iter_mut()
                    .take(nb)
                    .enumerate()
                    .map(|(k, j)| active[k].then(|| &mut j[..m * tangents[k]]))
                    .collect();
                &mut heap
            };
            problem.evaluate_residual(&problem.values, ri, &mut r[..m], Some(js))?;
        }
        let r = &r[..m];
        // Landmark of this residual, if variable.
        let lm = res
            .blocks
            .iter()
            .enumerate()
            .find(|(_, b)| layout.landmark_slot[b.0] != NONE)
            .map(|(k, b)| (k, layout.landmark_slot[b.0]));
        for a in 0..nb {
            if !active[a] {
                continue;
            }
            let ba = res.blocks[a].0;
            let ta = tangents[a];
            let ja = &jac[a][..m * ta];
            let oa = layout.state_offset[ba];
            if oa == NONE {
                // The landmark itself: H_ll and g_l.
                let l = &mut landmarks[layout.landmark_slot[ba]];
                for rr in 0..m {
                    for i in 0..ta {
                        l.gl[i] += ja[rr * ta + i] * r[rr];
                        for j in 0..ta {
                            l.hll[i * ta + j] += ja[rr * ta + i] * ja[rr * ta + j];
                        }
                    }
                }
                continue;
            }
            for rr in 0..m {
                for i in 0..ta {
                    gx[oa + i] += ja[rr * ta + i] * r[rr];
                }
            }
            for b in a..nb {
                if !active[b] || layout.state_offset[res.blocks[b].0] == NONE {
                    continue;
                }
                let tb = tangents[b];
                let ob = layout.state_offset[res.blocks[b].0];
                add_jtj(&mut hxx, n, (oa, ta, ja), (ob, tb, &jac[b][..m * tb]), m);
            }
            if let Some((kl, slot)) = lm {
                // H_xl block for (state a, landmark).
                let tl = tangents[kl];
                let jl = &jac[kl][..m * tl];
                let l = &mut landmarks[slot];
                let idx = match l.w.iter().position(|(o, _, _)| *o == oa) {
                    Some(i) => i,
                    None => {
                        l.w.push((oa, ta, vec![0.0; ta * tl]));
                        l.w.len() - 1
                    }
                };
                let wb = &mut l.w[idx].2;
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
    }
    mirror_upper(&mut hxx, n);
    Some(NormalEquations {
        n,
        hxx,
        gx,
        landmarks,
    })
}

/// Eliminates landmark blocks from the reduced system by the Schur complement, in place:
/// `a ← a − W C⁻¹ Wᵀ` (upper block triangle; call [`mirror_upper`] after) and
/// `rhs ← rhs + W C⁻¹ g_l`, with `C = H_ll + λ·diag(dl)` per landmark. `rhs` is the negative
/// gradient (the Gauss-Newton right-hand side `−g`). Returns each landmark's `C⁻¹`; a landmark
/// whose `C` is not positive definite is an error, or skipped (`None`) when `skip_singular`
/// (marginalization: a landmark without information folds nothing in).
#[allow(clippy::too_many_arguments)]
pub(crate) fn eliminate_landmarks(
    landmarks: &[LandmarkBlock],
    lambda: f64,
    dld: &[Vec<f64>],
    a: &mut [f64],
    rhs: &mut [f64],
    n: usize,
    skip_singular: bool,
) -> Option<Vec<Option<Vec<f64>>>> {
    let mut cinv_all = Vec::with_capacity(landmarks.len());
    for (idx, l) in landmarks.iter().enumerate() {
        let t = l.t;
        let mut c = l.hll.clone();
        for i in 0..t {
            c[i * t + i] += lambda * dld.get(idx).map_or(0.0, |d| d[i]);
        }
        let cinv = match small_spd_inverse(&c, t).filter(|c| c.iter().all(|v| v.is_finite())) {
            Some(ci) => ci,
            None if skip_singular => {
                cinv_all.push(None);
                continue;
            }
            None => return None,
        };
        if t == 1 {
            // Inverse depths: C is a scalar, W C⁻¹ Wᵀ an outer product per block pair.
            let ci = cinv[0];
            let gl = l.gl[0];
            for (ia, (oa, ta, wa)) in l.w.iter().enumerate() {
                for i in 0..*ta {
                    rhs[oa + i] += wa[i] * ci * gl;
                }
                for (ob, tb, wb) in &l.w[ia..] {
                    let (lo, hi, wl, wh, tl, th) = if ob >= oa {
                        (*oa, *ob, wa, wb, *ta, *tb)
                    } else {
                        (*ob, *oa, wb, wa, *tb, *ta)
                    };
                    for i in 0..tl {
                        let si = wl[i] * ci;
                        let row = &mut a[(lo + i) * n + hi..(lo + i) * n + hi + th];
                        for (hv, w) in row.iter_mut().zip(wh.iter()) {
                            *hv -= si * w;
                        }
                    }
                }
            }
            cinv_all.push(Some(cinv));
            continue;
        }
        let wc: Vec<Vec<f64>> =
            l.w.iter()
                .map(|(_, ta, w)| mat_mul(w, &cinv, *ta, t, t))
                .collect();
        for (ia, (oa, ta, _)) in l.w.iter().enumerate() {
            let wca = &wc[ia];
            for i in 0..*ta {
                let mut s = 0.0;
                for j in 0..t {
                    s += wca[i * t + j] * l.gl[j];
                }
                rhs[oa + i] += s;
            }
            for (ob, tb, wbm) in &l.w {
                if ob < oa {
                    continue;
                }
                for i in 0..*ta {
                    let row = &mut a[(oa + i) * n + ob..(oa + i) * n + ob + tb];
                    for (jb, hv) in row.iter_mut().enumerate() {
                        let mut s = 0.0;
                        for k in 0..t {
                            s += wca[i * t + k] * wbm[jb * t + k];
                        }
                        *hv -= s;
                    }
                }
            }
        }
        cinv_all.push(Some(cinv));
    }
    Some(cinv_all)
}

/// Adds a factor's directly computed normal equations (see `Factor::normal_equations`) into the
/// reduced system; `false` if the factor does not provide them.
fn accumulate_direct(
    problem: &Problem,
    layout: &Layout,
    ri: usize,
    h: &mut Vec<f64>,
    g: &mut Vec<f64>,
    hxx: &mut [f64],
    gx: &mut [f64],
) -> bool {
    let res = &problem.residuals[ri];
    let tangents = res.factor.parameter_tangent_sizes();
    let total: usize = tangents.iter().sum();
    h.clear();
    h.resize(total * total, 0.0);
    g.clear();
    g.resize(total, 0.0);
    let params: Vec<&[f64]> = res
        .blocks
        .iter()
        .map(|b| {
            let blk = &problem.blocks[b.0];
            &problem.values[blk.offset..blk.offset + blk.manifold.ambient_size()]
        })
        .collect();
    if res.factor.normal_equations(&params, h, g).is_none() {
        return false;
    }
    let n = layout.n;
    let mut local = 0;
    let locals: Vec<usize> = tangents
        .iter()
        .map(|t| {
            let o = local;
            local += t;
            o
        })
        .collect();
    for (a, ba) in res.blocks.iter().enumerate() {
        let oa = layout.state_offset[ba.0];
        if oa == NONE {
            continue;
        }
        let (la, ta) = (locals[a], tangents[a]);
        for i in 0..ta {
            gx[oa + i] += g[la + i];
        }
        for (b, bb) in res.blocks.iter().enumerate() {
            let ob = layout.state_offset[bb.0];
            if ob == NONE || ob < oa {
                continue;
            }
            let (lb, tb) = (locals[b], tangents[b]);
            for i in 0..ta {
                for j in 0..tb {
                    hxx[(oa + i) * n + ob + j] += h[(la + i) * total + lb + j];
                }
            }
        }
    }
    true
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

/// A step in the full space: reduced states then stacked landmarks.
pub(crate) struct Step {
    pub dx: Vec<f64>,
    pub dl: Vec<f64>,
}

impl NormalEquations {
    /// Jacobi scaling `diag(H)` clamped from below, for states and landmarks.
    fn diagonal(&self, min_diag: f64) -> (Vec<f64>, Vec<Vec<f64>>) {
        let dx = (0..self.n)
            .map(|i| self.hxx[i * self.n + i].max(min_diag))
            .collect();
        let dl = self
            .landmarks
            .iter()
            .map(|l| (0..l.t).map(|i| l.hll[i * l.t + i].max(min_diag)).collect())
            .collect();
        (dx, dl)
    }

    /// Solves `(H + λD) δ = −g` by eliminating landmarks; `None` if the reduced matrix is not
    /// positive definite.
    pub fn solve_damped(&self, lambda: f64, min_diag: f64) -> Option<Step> {
        let n = self.n;
        let (dxd, dld) = self.diagonal(min_diag);
        let mut a = self.hxx.clone();
        let mut b: Vec<f64> = self.gx.iter().map(|g| -g).collect();
        for i in 0..n {
            a[i * n + i] += lambda * dxd[i];
        }
        let cinv_all =
            eliminate_landmarks(&self.landmarks, lambda, &dld, &mut a, &mut b, n, false)?;
        let cinv_all: Vec<Vec<f64>> = cinv_all.into_iter().map(|c| c.expect("all PD")).collect();
        mirror_upper(&mut a, n);
        let dx = if n > 0 {
            // Symmetric: the row-major buffer is also the column-major matrix.
            let am = DMatrix::from_vec(n, n, a);
            let chol = am.cholesky()?;
            chol.solve(&DVector::from_vec(b)).as_slice().to_vec()
        } else {
            Vec::new()
        };
        // Back-substitution: δl = C⁻¹ (−g_l − Wᵀ δx).
        let mut dl = Vec::new();
        for (l, cinv) in self.landmarks.iter().zip(&cinv_all) {
            let t = l.t;
            let mut rhs: Vec<f64> = l.gl.iter().map(|g| -g).collect();
            for (oa, ta, w) in &l.w {
                for i in 0..*ta {
                    for j in 0..t {
                        rhs[j] -= w[i * t + j] * dx[oa + i];
                    }
                }
            }
            for i in 0..t {
                dl.push((0..t).map(|j| cinv[i * t + j] * rhs[j]).sum());
            }
        }
        if dx.iter().chain(&dl).any(|v| !v.is_finite()) {
            return None;
        }
        Some(Step { dx, dl })
    }

    /// `vᵀ H v` for a full-space vector (undamped Hessian).
    fn quadratic(&self, v: &Step) -> f64 {
        let n = self.n;
        let mut s = 0.0;
        for i in 0..n {
            let mut row = 0.0;
            for j in 0..n {
                row += self.hxx[i * n + j] * v.dx[j];
            }
            s += v.dx[i] * row;
        }
        let mut off = 0;
        for l in &self.landmarks {
            let t = l.t;
            let vl = &v.dl[off..off + t];
            for i in 0..t {
                for j in 0..t {
                    s += vl[i] * l.hll[i * t + j] * vl[j];
                }
            }
            for (oa, ta, w) in &l.w {
                for i in 0..*ta {
                    for j in 0..t {
                        s += 2.0 * v.dx[oa + i] * w[i * t + j] * vl[j];
                    }
                }
            }
            off += t;
        }
        s
    }

    fn gradient_dot(&self, v: &Step) -> f64 {
        let mut s: f64 = self.gx.iter().zip(&v.dx).map(|(a, b)| a * b).sum();
        let mut off = 0;
        for l in &self.landmarks {
            for i in 0..l.t {
                s += l.gl[i] * v.dl[off + i];
            }
            off += l.t;
        }
        s
    }

    fn gradient_max_norm(&self) -> f64 {
        self.gx
            .iter()
            .chain(self.landmarks.iter().flat_map(|l| l.gl.iter()))
            .fold(0.0f64, |a, g| a.max(g.abs()))
    }

    fn gradient_step(&self) -> Step {
        Step {
            dx: self.gx.iter().map(|g| -g).collect(),
            dl: self
                .landmarks
                .iter()
                .flat_map(|l| l.gl.iter().map(|g| -g))
                .collect(),
        }
    }
}

fn mat_mul(a: &[f64], b: &[f64], r: usize, k: usize, c: usize) -> Vec<f64> {
    let mut out = vec![0.0; r * c];
    for i in 0..r {
        for j in 0..c {
            out[i * c + j] = (0..k).map(|x| a[i * k + x] * b[x * c + j]).sum();
        }
    }
    out
}

fn norm(s: &Step) -> f64 {
    s.dx.iter().chain(&s.dl).map(|v| v * v).sum::<f64>().sqrt()
}

/// Applies a full-space step to a copy of the problem's values.
pub(crate) fn apply_step(problem: &Problem, layout: &Layout, step: &Step, out: &mut Vec<f64>) {
    out.clear();
    out.extend_from_slice(&problem.values);
    for (i, b) in problem.blocks.iter().enumerate() {
        let delta = if layout.state_offset[i] != NONE {
            let o = layout.state_offset[i];
            &step.dx[o..o + b.manifold.tangent_size()]
        } else if layout.landmark_slot[i] != NONE {
            let o = layout.landmark_offset[layout.landmark_slot[i]];
            &step.dl[o..o + b.manifold.tangent_size()]
        } else {
            continue;
        };
        let a = b.manifold.ambient_size();
        b.manifold.plus(
            &problem.values[b.offset..b.offset + a],
            delta,
            &mut out[b.offset..b.offset + a],
        );
    }
}

/// Minimizes the problem's cost in place.
pub fn solve(problem: &mut Problem, options: &SolverOptions) -> SolverSummary {
    let start = Instant::now();
    let layout = Layout::new(problem);
    let mut summary = SolverSummary {
        iterations: 0,
        successful_steps: 0,
        initial_cost: f64::NAN,
        final_cost: f64::NAN,
        termination: Termination::NothingToDo,
        reduced_size: layout.n,
        landmarks: layout.landmarks.len(),
        time: Duration::ZERO,
    };
    let Some(mut cost) = problem.cost() else {
        summary.termination = Termination::InvalidInitialPoint;
        summary.time = start.elapsed();
        return summary;
    };
    summary.initial_cost = cost;
    summary.final_cost = cost;
    if layout.n + layout.n_landmark == 0 {
        summary.time = start.elapsed();
        return summary;
    }
    let mut radius = options.initial_trust_radius;
    let mut decrease_factor = 2.0;
    let mut candidate = Vec::with_capacity(problem.values.len());
    let mut eqs: Option<NormalEquations> = None;
    summary.termination = Termination::MaxIterations;
    while summary.iterations < options.max_iterations {
        if eqs.is_none() {
            summary.iterations += 1;
            eqs = linearize(problem, &layout, None);
            let Some(e) = &eqs else {
                summary.termination = Termination::InvalidInitialPoint;
                break;
            };
            if e.gradient_max_norm() <= options.gradient_tolerance {
                summary.termination = Termination::Converged;
                break;
            }
        }
        let e = eqs.as_ref().expect("linearized above");
        let step = match options.method {
            Method::LevenbergMarquardt => e.solve_damped(1.0 / radius, options.min_diagonal),
            Method::Dogleg => dogleg_step(e, radius, options.min_diagonal),
        };
        let Some(step) = step else {
            // Factorization failed: shrink the region and retry on the same linearization.
            radius /= decrease_factor;
            decrease_factor *= 2.0;
            if radius < 1e-32 {
                summary.termination = Termination::NoProgress;
                break;
            }
            continue;
        };
        let step_norm = norm(&step);
        let x_norm = problem.values.iter().map(|v| v * v).sum::<f64>().sqrt();
        if step_norm <= options.parameter_tolerance * (x_norm + options.parameter_tolerance) {
            summary.termination = Termination::Converged;
            break;
        }
        // Predicted decrease of the (undamped) quadratic model.
        let model_decrease = -(e.gradient_dot(&step) + 0.5 * e.quadratic(&step));
        apply_step(problem, &layout, &step, &mut candidate);
        let new_cost = problem.cost_at(&candidate);
        let accepted = match new_cost {
            Some(nc) if model_decrease > 0.0 => {
                let rho = (cost - nc) / model_decrease;
                if rho > 1e-3 {
                    let rel = (cost - nc) / cost.max(f64::MIN_POSITIVE);
                    std::mem::swap(&mut problem.values, &mut candidate);
                    cost = nc;
                    summary.successful_steps += 1;
                    radius = match options.method {
                        Method::LevenbergMarquardt => {
                            radius / (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3))
                        }
                        Method::Dogleg if rho > 0.75 => radius.max(3.0 * step_norm),
                        Method::Dogleg => radius,
                    }
                    .min(1e16);
                    decrease_factor = 2.0;
                    eqs = None;
                    if rel < options.function_tolerance {
                        summary.termination = Termination::Converged;
                        break;
                    }
                    true
                } else {
                    false
                }
            }
            _ => false,
        };
        if !accepted {
            radius /= decrease_factor;
            decrease_factor *= 2.0;
            if radius < 1e-32 {
                summary.termination = Termination::NoProgress;
                break;
            }
        }
    }
    summary.final_cost = cost;
    summary.time = start.elapsed();
    summary
}

/// Powell's dogleg step within `radius` (full-space Euclidean norm of the tangent step).
fn dogleg_step(e: &NormalEquations, radius: f64, min_diag: f64) -> Option<Step> {
    // Gauss–Newton step with a tiny regularization for gauge freedoms.
    let mut mu = 1e-10;
    let gn = loop {
        if let Some(s) = e.solve_damped(mu, min_diag) {
            break s;
        }
        mu *= 100.0;
        if mu > 1e-2 {
            return None;
        }
    };
    if norm(&gn) <= radius {
        return Some(gn);
    }
    let g = e.gradient_step(); // −g
    let g_sq: f64 = g.dx.iter().chain(&g.dl).map(|v| v * v).sum();
    let ghg = e.quadratic(&g);
    if ghg <= 0.0 || g_sq == 0.0 {
        return Some(scale(&gn, radius / norm(&gn)));
    }
    let alpha = g_sq / ghg;
    let sd = scale(&g, alpha);
    let sd_norm = norm(&sd);
    if sd_norm >= radius {
        return Some(scale(&g, radius / g_sq.sqrt()));
    }
    // Find β ∈ [0, 1] with ‖sd + β (gn − sd)‖ = radius.
    let diff = Step {
        dx: gn.dx.iter().zip(&sd.dx).map(|(a, b)| a - b).collect(),
        dl: gn.dl.iter().zip(&sd.dl).map(|(a, b)| a - b).collect(),
    };
    let a: f64 = diff.dx.iter().chain(&diff.dl).map(|v| v * v).sum();
    let b: f64 = 2.0
        * sd.dx
            .iter()
            .chain(&sd.dl)
            .zip(diff.dx.iter().chain(&diff.dl))
            .map(|(s, d)| s * d)
            .sum::<f64>();
    let c = sd_norm * sd_norm - radius * radius;
    let beta = (-b + (b * b - 4.0 * a * c).max(0.0).sqrt()) / (2.0 * a);
    Some(Step {
        dx: sd
            .dx
            .iter()
            .zip(&diff.dx)
            .map(|(s, d)| s + beta * d)
            .collect(),
        dl: sd
            .dl
            .iter()
            .zip(&diff.dl)
            .map(|(s, d)| s + beta * d)
            .collect(),
    })
}

fn scale(s: &Step, k: f64) -> Step {
    Step {
        dx: s.dx.iter().map(|v| v * k).collect(),
        dl: s.dl.iter().map(|v| v * k).collect(),
    }
}

/// The full normal equations `H = Σ JᵀJ`, `g = Σ Jᵀr` at the current values with every variable
/// block (landmarks included) in one dense system, in block-id order. Returns `(H, g, blocks)`,
/// where `blocks` lists the variable blocks in the order of their tangent coordinates. For
/// analysis and tests (gauge freedoms, consistency); the solver itself never forms this matrix.
pub fn dense_normal_equations(
    problem: &Problem,
) -> Option<(DMatrix<f64>, DVector<f64>, Vec<super::BlockId>)> {
    let mut layout = Layout::new(problem);
    let mut n = 0;
    let mut blocks = Vec::new();
    for (i, b) in problem.blocks.iter().enumerate() {
        if layout.state_offset[i] != NONE || layout.landmark_slot[i] != NONE {
            layout.state_offset[i] = n;
            layout.landmark_slot[i] = NONE;
            n += b.manifold.tangent_size();
            blocks.push(super::BlockId(i));
        }
    }
    layout.n = n;
    layout.landmarks.clear();
    layout.landmark_offset.clear();
    layout.n_landmark = 0;
    let eqs = linearize(problem, &layout, None)?;
    Some((
        DMatrix::from_row_slice(n, n, &eqs.hxx),
        DVector::from_vec(eqs.gx),
        blocks,
    ))
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::factors::LinearFactor;
    use crate::problem::{BlockKind, Euclidean};

    /// Deterministic pseudo-random numbers in [−1, 1] (no RNG dependency in the library).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

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
        let eqs = linearize(&p, &layout, None).unwrap();
        let (h, g, _) = dense_normal_equations(&p).unwrap();
        for lambda in [0.0, 1e-3, 10.0] {
            let step = eqs.solve_damped(lambda, 1e-6).unwrap();
            let d = DMatrix::from_diagonal(&h.diagonal().map(|v| v.max(1e-6)));
            let dense = (&h + d * lambda).cholesky().unwrap().solve(&(-&g));
            let ours: Vec<f64> = step.dx.iter().chain(&step.dl).copied().collect();
            let err = ours
                .iter()
                .zip(dense.iter())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-9 * dense.amax().max(1.0), "λ={lambda}: {err:e}");
        }
    }
}
