//! Levenberg–Marquardt and Powell's dogleg on the manifold, with landmark blocks eliminated by
//! the Schur complement and the reduced system solved by dense Cholesky (faer's LLT).
//!
//! A solve plans its normal equations once (`NormalEquations::new`: residuals grouped by
//! landmark, the landmark–state coupling blocks `H_xl` laid out in one buffer) and every
//! linearization refills the same buffers. Rotation matrices of pose blocks are computed once
//! per evaluation pass and handed to the factors (`Factor::evaluate_with_rotations`).
//!
//! Everything is deterministic: blocks are visited in id order, no threads (faer runs with
//! `Par::Seq`), and stopping is decided by iteration count, cost change, gradient and step size
//! — never by wall-clock time. Timing is measured for reports only.

use std::time::{Duration, Instant};

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::linalg::matmul::matmul;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, MatMut, MatRef, Par};
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

/// How one parameter block of a residual enters the linear system.
#[derive(Clone, Copy, Debug)]
struct Slot {
    /// Offset in the reduced system (`NONE` unless a variable state block).
    offset: usize,
    /// Tangent size.
    t: usize,
    /// Offset of this block's Jacobian (`m × t`, row-major) in the residual's scratch buffer;
    /// `NONE` for blocks held constant (no Jacobian requested).
    jpos: usize,
    /// Index of the coupling block `H_xl` with the residual's landmark (state blocks of a
    /// residual that touches a variable landmark), `NONE` otherwise.
    coupling: usize,
}

/// One residual's plan: which blocks are variable and where their rows go.
#[derive(Clone, Debug)]
struct ResidualPlan {
    /// Residual index in the problem.
    ri: usize,
    /// Residual dimension.
    m: usize,
    /// Range of this residual's slots in `Plan::slots`.
    slots: (usize, usize),
    /// Position (within the residual's blocks) of its variable landmark, `NONE` if none.
    landmark: usize,
    /// Index of that landmark in the landmark list.
    lm: usize,
    /// Total scratch length of the Jacobians (`m × Σ t` over variable blocks).
    jlen: usize,
    /// Whether to try the factor's `normal_equations` (no loss, no variable landmark).
    direct: bool,
}

/// Coupling block `H_xl` of one landmark with one state block.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Coupling {
    /// Offset of the state block in the reduced system.
    pub offset: usize,
    /// Tangent size of the state block.
    pub t: usize,
    /// Position of the `t × t_l` row-major block in [`NormalEquations::w`].
    pub pos: usize,
    /// Offset of the state block among the coupled coordinates (see `NormalEquations::zblocks`).
    pub z: usize,
}

/// Normal equations `H δ = −g` at a linearization point, landmarks kept apart, together with
/// the problem's sparsity plan (computed once, reused by every linearization of a solve: no
/// per-iteration allocation).
pub(crate) struct NormalEquations {
    /// Size of the reduced system.
    pub n: usize,
    /// Reduced-state block `H_xx` (row-major, full).
    pub hxx: Vec<f64>,
    /// Reduced-state gradient.
    pub gx: Vec<f64>,
    /// `½ Σ ρ` at the linearization point.
    pub cost: f64,
    /// Tangent size of each landmark.
    pub lt: Vec<usize>,
    /// Offset of each landmark in the stacked landmark vector (`gl`, steps).
    pub loff: Vec<usize>,
    /// Offset of each landmark's `t × t` block in `hll`.
    pub lhoff: Vec<usize>,
    /// Stacked `H_ll` blocks.
    pub hll: Vec<f64>,
    /// Stacked landmark gradients.
    pub gl: Vec<f64>,
    /// Landmark `l`'s couplings are `couplings[cstart[l]..cstart[l + 1]]`, sorted by offset.
    pub cstart: Vec<usize>,
    /// Coupling blocks of all landmarks.
    pub couplings: Vec<Coupling>,
    /// Values of the coupling blocks.
    pub w: Vec<f64>,
    /// The state blocks coupled to any landmark: (offset, tangent size, compact offset), by
    /// offset; `zdim` compact coordinates in all.
    zblocks: Vec<(usize, usize, usize)>,
    zdim: usize,
    /// Whether inverse-depth landmarks are eliminated by one dense product over the coupled
    /// coordinates (small windows) rather than block pair by block pair (large, sparse
    /// problems such as a batch solve).
    dense_schur: bool,
    /// Residuals without a variable landmark, in id order.
    state_res: Vec<ResidualPlan>,
    /// Residuals with a variable landmark, grouped by landmark, in id order within a group.
    lm_res: Vec<ResidualPlan>,
    slots: Vec<Slot>,
    /// Rotation matrices of the blocks at the values being evaluated (`Problem::fill_rotations`).
    rot: Vec<nalgebra::Matrix3<f64>>,
    /// Scratch: residual, Jacobians, a factor's direct normal equations.
    r: Vec<f64>,
    jac: Vec<f64>,
    direct_h: Vec<f64>,
    direct_g: Vec<f64>,
}

/// `H[a, b] += Jaᵀ Jb` on a row-major `n × n` buffer (only the block with the smaller offset
/// first is written; [`mirror_upper`] completes the matrix).
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

impl NormalEquations {
    /// Plans the normal equations of `residual_ids` (all residuals if `None`) under `layout`
    /// and allocates every buffer; [`Self::linearize`] fills them.
    pub fn new(problem: &Problem, layout: &Layout, residual_ids: Option<&[usize]>) -> Self {
        let nl = layout.landmarks.len();
        let all: Vec<usize>;
        let ids = match residual_ids {
            Some(ids) => ids,
            None => {
                all = (0..problem.residuals.len()).collect();
                &all
            }
        };
        // Group the residuals by landmark (a stable counting sort: id order within a group).
        let mut lm_of = Vec::with_capacity(ids.len());
        let mut gstart = vec![0usize; nl + 1];
        let mut state_ids = Vec::new();
        for &ri in ids {
            let l = problem.residuals[ri]
                .blocks
                .iter()
                .map(|b| layout.landmark_slot[b.0])
                .find(|&l| l != NONE)
                .unwrap_or(NONE);
            lm_of.push(l);
            if l == NONE {
                state_ids.push(ri);
            } else {
                gstart[l + 1] += 1;
            }
        }
        for l in 0..nl {
            gstart[l + 1] += gstart[l];
        }
        let mut grouped = vec![0usize; gstart[nl]];
        let mut fill = gstart.clone();
        for (&ri, &l) in ids.iter().zip(&lm_of) {
            if l != NONE {
                grouped[fill[l]] = ri;
                fill[l] += 1;
            }
        }
        let mut slots = Vec::with_capacity(ids.len() * 6);
        let mut max_m = 0;
        let mut max_j = 0;
        // `coupling_of[offset]`: index of the current landmark's coupling with that state block.
        let mut coupling_of = vec![NONE; layout.n];
        let mut plan = |ri: usize, l: usize, coupling_of: &[usize]| -> ResidualPlan {
            let res = &problem.residuals[ri];
            let m = res.factor.residual_dim();
            let tangents = res.factor.parameter_tangent_sizes();
            let start = slots.len();
            let mut jlen = 0;
            let mut landmark = NONE;
            for (k, b) in res.blocks.iter().enumerate() {
                let t = tangents[k];
                let offset = layout.state_offset[b.0];
                let is_lm = layout.landmark_slot[b.0] != NONE;
                if is_lm {
                    landmark = k;
                }
                let active = offset != NONE || is_lm;
                let coupling = if offset != NONE && l != NONE {
                    coupling_of[offset]
                } else {
                    NONE
                };
                slots.push(Slot {
                    offset,
                    t,
                    jpos: if active { jlen } else { NONE },
                    coupling,
                });
                if active {
                    jlen += m * t;
                }
            }
            max_m = max_m.max(m);
            max_j = max_j.max(jlen);
            ResidualPlan {
                ri,
                m,
                slots: (start, slots.len()),
                landmark,
                lm: l,
                jlen,
                direct: res.loss.is_none() && landmark == NONE,
            }
        };
        let state_res: Vec<ResidualPlan> = state_ids
            .iter()
            .map(|&ri| plan(ri, NONE, &coupling_of))
            .collect();
        // Couplings: the distinct state blocks each landmark's residuals touch, by offset.
        let mut cstart = Vec::with_capacity(nl + 1);
        let mut couplings: Vec<Coupling> = Vec::new();
        let mut lm_res = Vec::with_capacity(grouped.len());
        let mut wlen = 0;
        for (l, &b) in layout.landmarks.iter().enumerate() {
            let tl = problem.blocks[b].manifold.tangent_size();
            cstart.push(couplings.len());
            let first = couplings.len();
            let group = &grouped[gstart[l]..gstart[l + 1]];
            for &ri in group {
                for bb in &problem.residuals[ri].blocks {
                    let o = layout.state_offset[bb.0];
                    if o != NONE && coupling_of[o] != l {
                        coupling_of[o] = l;
                        couplings.push(Coupling {
                            offset: o,
                            t: problem.blocks[bb.0].manifold.tangent_size(),
                            pos: 0,
                            z: 0,
                        });
                    }
                }
            }
            couplings[first..].sort_by_key(|c| c.offset);
            for (k, c) in couplings[first..].iter_mut().enumerate() {
                c.pos = wlen;
                wlen += c.t * tl;
                coupling_of[c.offset] = first + k;
            }
            for &ri in group {
                lm_res.push(plan(ri, l, &coupling_of));
            }
            // Reset the marks (a coupling index may equal a later landmark's index).
            for c in &couplings[first..] {
                coupling_of[c.offset] = NONE;
            }
        }
        cstart.push(couplings.len());
        // The state blocks any landmark couples to, by offset, and their compact offsets.
        let mut zblocks: Vec<(usize, usize, usize)> = Vec::new();
        for c in &couplings {
            if coupling_of[c.offset] == NONE {
                coupling_of[c.offset] = 0;
                zblocks.push((c.offset, c.t, 0));
            }
        }
        zblocks.sort_unstable();
        let mut zdim = 0;
        for zb in &mut zblocks {
            zb.2 = zdim;
            coupling_of[zb.0] = zdim;
            zdim += zb.1;
        }
        for c in &mut couplings {
            c.z = coupling_of[c.offset];
        }
        // Dense when its multiply-adds are within a small factor of the sparse updates' (the
        // dense product runs many times faster per multiply-add).
        let sparse_work: usize = (0..nl)
            .map(|l| {
                let k: usize = couplings[cstart[l]..cstart[l + 1]]
                    .iter()
                    .map(|c| c.t)
                    .sum();
                k * k
            })
            .sum();
        let dense_schur = zdim * zdim * nl <= 8 * sparse_work;
        let lt: Vec<usize> = layout
            .landmarks
            .iter()
            .map(|&b| problem.blocks[b].manifold.tangent_size())
            .collect();
        let mut lhoff = Vec::with_capacity(nl);
        let mut hlen = 0;
        for t in &lt {
            lhoff.push(hlen);
            hlen += t * t;
        }
        let n = layout.n;
        Self {
            n,
            hxx: vec![0.0; n * n],
            gx: vec![0.0; n],
            cost: f64::NAN,
            loff: layout.landmark_offset.clone(),
            lhoff,
            hll: vec![0.0; hlen],
            gl: vec![0.0; layout.n_landmark],
            lt,
            cstart,
            couplings,
            w: vec![0.0; wlen],
            zblocks,
            zdim,
            dense_schur,
            state_res,
            lm_res,
            slots,
            rot: Vec::new(),
            r: vec![0.0; max_m],
            jac: vec![0.0; max_j],
            direct_h: Vec::new(),
            direct_g: Vec::new(),
        }
    }

    /// Number of landmarks.
    pub fn num_landmarks(&self) -> usize {
        self.lt.len()
    }

    /// Evaluates every planned residual with Jacobians at the problem's current values and
    /// accumulates the normal equations; `false` if a residual cannot be evaluated.
    ///
    /// Also sets [`Self::cost`], summed in the same order as [`Self::cost_at`].
    pub fn linearize(&mut self, problem: &Problem) -> bool {
        self.hxx.fill(0.0);
        self.gx.fill(0.0);
        self.hll.fill(0.0);
        self.gl.fill(0.0);
        self.w.fill(0.0);
        let mut total = 0.0;
        problem.fill_rotations(&problem.values, &mut self.rot);
        let plans = std::mem::take(&mut self.state_res);
        let mut ok = true;
        for p in &plans {
            let rho = if p.direct && self.accumulate_direct(problem, p) {
                // The cost as `evaluate` gives it (as `cost_at` computes it).
                self.evaluate_cost(problem, &problem.values, p)
            } else {
                self.accumulate(problem, p)
            };
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
        mirror_upper(&mut self.hxx, self.n);
        self.cost = 0.5 * total;
        ok
    }

    /// `ρ(‖r‖²)` of one planned residual at `values`, without Jacobians.
    fn evaluate_cost(
        &mut self,
        problem: &Problem,
        values: &[f64],
        p: &ResidualPlan,
    ) -> Option<f64> {
        // `self.rot` holds the rotations at `values` (filled by the caller).
        problem.evaluate_residual_with(values, Some(&self.rot), p.ri, &mut self.r[..p.m], None)
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

    /// Evaluates one residual with Jacobians and adds its rows; returns its `ρ(‖r‖²)`.
    fn accumulate(&mut self, problem: &Problem, p: &ResidualPlan) -> Option<f64> {
        let m = p.m;
        let slots = &self.slots[p.slots.0..p.slots.1];
        let nb = slots.len();
        let rho;
        {
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
            rho = problem.evaluate_residual_with(
                &problem.values,
                Some(&self.rot),
                p.ri,
                &mut self.r[..m],
                Some(js),
            )?;
        }
        let r = &self.r[..m];
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
                // Diagonal block: upper triangle only (`mirror_upper` fills the rest).
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

    /// Adds a factor's directly computed normal equations (see `Factor::normal_equations`);
    /// `false` if the factor does not provide them.
    fn accumulate_direct(&mut self, problem: &Problem, p: &ResidualPlan) -> bool {
        let res = &problem.residuals[p.ri];
        let slots = &self.slots[p.slots.0..p.slots.1];
        let total: usize = slots.iter().map(|s| s.t).sum();
        self.direct_h.clear();
        self.direct_h.resize(total * total, 0.0);
        self.direct_g.clear();
        self.direct_g.resize(total, 0.0);
        let (h, g) = (&mut self.direct_h, &mut self.direct_g);
        let direct = problem.with_residual_params(&problem.values, p.ri, |params| {
            res.factor.normal_equations(params, h, g)
        });
        if direct.is_none() {
            return false;
        }
        let (h, g, n) = (&self.direct_h, &self.direct_g, self.n);
        let mut la = 0;
        for sa in slots {
            let (oa, ta) = (sa.offset, sa.t);
            if oa != NONE {
                for i in 0..ta {
                    self.gx[oa + i] += g[la + i];
                }
                let mut lb = 0;
                for sb in slots {
                    let (ob, tb) = (sb.offset, sb.t);
                    if ob != NONE && ob >= oa {
                        for i in 0..ta {
                            let src = &h[(la + i) * total + lb..(la + i) * total + lb + tb];
                            let dst = &mut self.hxx[(oa + i) * n + ob..(oa + i) * n + ob + tb];
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
        true
    }

    /// Eliminates landmark blocks from the reduced system by the Schur complement, in place:
    /// `a ← a − W C⁻¹ Wᵀ` (upper block triangle; call [`mirror_upper`] after) and
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
        let (zd, nl) = (self.zdim, self.lt.len());
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
                        &mut z.z1[l * zd..(l + 1) * zd],
                        &mut z.z2[l * zd..(l + 1) * zd],
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
                        // Diagonal block: upper triangle only (`mirror_upper` fills the rest).
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

/// Inverts a small symmetric positive-definite matrix (row-major); `None` if not PD.
pub(crate) fn small_spd_inverse(a: &[f64], t: usize) -> Option<Vec<f64>> {
    if t == 1 {
        return (a[0] > 0.0).then(|| vec![1.0 / a[0]]);
    }
    let m = DMatrix::from_row_slice(t, t, a);
    let inv = m.cholesky()?.inverse();
    Some(inv.transpose().as_slice().to_vec())
}

/// Dot product with four independent partial sums (vectorizable; a fixed summation order, so
/// results are deterministic).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let b = &b[..a.len()];
    let (ac, ar) = a.as_chunks::<4>();
    let (bc, br) = b.as_chunks::<4>();
    let mut s = [0.0; 4];
    for (x, y) in ac.iter().zip(bc) {
        for k in 0..4 {
            s[k] += x[k] * y[k];
        }
    }
    let mut t = (s[0] + s[2]) + (s[1] + s[3]);
    for (x, y) in ar.iter().zip(br) {
        t += x * y;
    }
    t
}

/// A step in the full space: reduced states then stacked landmarks.
pub(crate) struct Step {
    pub dx: Vec<f64>,
    pub dl: Vec<f64>,
}

/// Buffers of the damped reduced system, reused across the steps of a solve.
#[derive(Default)]
pub(crate) struct ReducedSystem {
    a: Vec<f64>,
    rhs: Vec<f64>,
    cinv: Vec<f64>,
    valid: Vec<bool>,
    scratch: Option<(usize, MemBuffer)>,
    schur: SchurScratch,
}

/// Solves `A x = b` in place for a symmetric positive-definite row-major `n × n` matrix by
/// faer's blocked Cholesky factorization (single-threaded: `Par::Seq`), overwriting `a` with
/// the factor. The row-major buffer of a symmetric matrix is also its column-major buffer.
/// `false` if `A` is not positive definite.
pub(crate) fn dense_cholesky_solve(
    a: &mut [f64],
    n: usize,
    b: &mut [f64],
    scratch: &mut Option<(usize, MemBuffer)>,
) -> bool {
    if n == 0 {
        return true;
    }
    if scratch.as_ref().is_none_or(|(m, _)| *m != n) {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(n, Par::Seq, Default::default())
            .or(llt::solve::solve_in_place_scratch::<f64>(n, 1, Par::Seq));
        *scratch = Some((n, MemBuffer::new(req)));
    }
    let buf = &mut scratch.as_mut().expect("allocated above").1;
    let stack = MemStack::new(buf);
    let mut l = MatMut::from_column_major_slice_mut(a, n, n);
    if llt::factor::cholesky_in_place(
        l.rb_mut(),
        Default::default(),
        Par::Seq,
        stack,
        Default::default(),
    )
    .is_err()
    {
        return false;
    }
    let rhs = MatMut::from_column_major_slice_mut(b, n, 1);
    llt::solve::solve_in_place(l.rb(), rhs, Par::Seq, MemStack::new(buf));
    true
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
        sys.a.clear();
        sys.a.extend_from_slice(&self.hxx);
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
        // The Cholesky reads the lower triangle: copy the upper (written above) onto it.
        mirror_upper(&mut sys.a, n);
        let mut dx = std::mem::take(&mut sys.rhs);
        if !dense_cholesky_solve(&mut sys.a, n, &mut dx, &mut sys.scratch) {
            return None;
        }
        // Back-substitution: δl = C⁻¹ (−g_l − Wᵀ δx).
        let mut dl = vec![0.0; self.gl.len()];
        for l in 0..self.lt.len() {
            let t = self.lt[l];
            let (ho, go) = (self.lhoff[l], self.loff[l]);
            let cs = &self.couplings[self.cstart[l]..self.cstart[l + 1]];
            if t == 1 {
                let mut rhs = -self.gl[go];
                for c in cs {
                    rhs -= dot(&self.w[c.pos..c.pos + c.t], &dx[c.offset..c.offset + c.t]);
                }
                dl[go] = sys.cinv[ho] * rhs;
                continue;
            }
            let mut rhs: Vec<f64> = self.gl[go..go + t].iter().map(|g| -g).collect();
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

    /// `vᵀ H v` for a full-space vector (undamped Hessian).
    fn quadratic(&self, v: &Step) -> f64 {
        let n = self.n;
        let mut s = 0.0;
        for i in 0..n {
            s += v.dx[i] * dot(&self.hxx[i * n..i * n + n], &v.dx);
        }
        for l in 0..self.lt.len() {
            let t = self.lt[l];
            let (ho, go) = (self.lhoff[l], self.loff[l]);
            let vl = &v.dl[go..go + t];
            let hll = &self.hll[ho..ho + t * t];
            for i in 0..t {
                for j in 0..t {
                    s += vl[i] * hll[i * t + j] * vl[j];
                }
            }
            for c in &self.couplings[self.cstart[l]..self.cstart[l + 1]] {
                for i in 0..c.t {
                    for j in 0..t {
                        s += 2.0 * v.dx[c.offset + i] * self.w[c.pos + i * t + j] * vl[j];
                    }
                }
            }
        }
        s
    }

    fn gradient_dot(&self, v: &Step) -> f64 {
        let s: f64 = self.gx.iter().zip(&v.dx).map(|(a, b)| a * b).sum();
        s + self.gl.iter().zip(&v.dl).map(|(a, b)| a * b).sum::<f64>()
    }

    fn gradient_max_norm(&self) -> f64 {
        self.gx
            .iter()
            .chain(&self.gl)
            .fold(0.0f64, |a, g| a.max(g.abs()))
    }

    fn gradient_step(&self) -> Step {
        Step {
            dx: self.gx.iter().map(|g| -g).collect(),
            dl: self.gl.iter().map(|g| -g).collect(),
        }
    }
}

/// Plans and evaluates the normal equations of `residual_ids` (all if `None`) at the current
/// values; `None` if a residual cannot be evaluated.
pub(crate) fn linearize(
    problem: &Problem,
    layout: &Layout,
    residual_ids: Option<&[usize]>,
) -> Option<NormalEquations> {
    let mut eqs = NormalEquations::new(problem, layout, residual_ids);
    eqs.linearize(problem).then_some(eqs)
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
    if layout.n + layout.n_landmark == 0 || options.max_iterations == 0 {
        match problem.cost() {
            Some(cost) => {
                summary.initial_cost = cost;
                summary.final_cost = cost;
                if layout.n + layout.n_landmark > 0 {
                    summary.termination = Termination::MaxIterations;
                }
            }
            None => summary.termination = Termination::InvalidInitialPoint,
        }
        summary.time = start.elapsed();
        return summary;
    }
    // The plan and every buffer of the linear system are built once and reused by each
    // linearization and step. The first linearization also gives the initial cost.
    let mut e = NormalEquations::new(problem, &layout, None);
    if !e.linearize(problem) {
        summary.termination = Termination::InvalidInitialPoint;
        summary.time = start.elapsed();
        return summary;
    }
    summary.iterations = 1;
    let mut cost = e.cost;
    summary.initial_cost = cost;
    summary.final_cost = cost;
    let mut radius = options.initial_trust_radius;
    let mut decrease_factor = 2.0;
    let mut candidate = Vec::with_capacity(problem.values.len());
    let mut sys = ReducedSystem::default();
    let mut linearized = true;
    summary.termination = Termination::MaxIterations;
    if e.gradient_max_norm() <= options.gradient_tolerance {
        summary.termination = Termination::Converged;
        summary.time = start.elapsed();
        return summary;
    }
    // Every pass but the first (whose linearization happened above) checks the cap first.
    let mut first = true;
    loop {
        if !first && summary.iterations >= options.max_iterations {
            break;
        }
        first = false;
        if !linearized {
            summary.iterations += 1;
            if !e.linearize(problem) {
                summary.termination = Termination::InvalidInitialPoint;
                break;
            }
            linearized = true;
            if e.gradient_max_norm() <= options.gradient_tolerance {
                summary.termination = Termination::Converged;
                break;
            }
        }
        let step = match options.method {
            Method::LevenbergMarquardt => {
                e.solve_damped(1.0 / radius, options.min_diagonal, &mut sys)
            }
            Method::Dogleg => dogleg_step(&e, radius, options.min_diagonal, &mut sys),
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
        let new_cost = e.cost_at(problem, &candidate);
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
                    linearized = false;
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
fn dogleg_step(
    e: &NormalEquations,
    radius: f64,
    min_diag: f64,
    sys: &mut ReducedSystem,
) -> Option<Step> {
    // Gauss–Newton step with a tiny regularization for gauge freedoms.
    let mut mu = 1e-10;
    let gn = loop {
        if let Some(s) = e.solve_damped(mu, min_diag, sys) {
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
            let step = eqs
                .solve_damped(lambda, 1e-6, &mut ReducedSystem::default())
                .unwrap();
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
