//! The normal equations `H δ = −g` of a planned system: their buffers, the plan that lays them
//! out (residuals grouped by landmark, the couplings `H_xl` in one buffer), and the quadratic
//! model the trust region uses. Filling them from the residuals is `accumulate.rs`.

use super::plan::{Coupling, Layout, NONE, ResidualPlan, Slot};
use super::vector::{Step, dot, split_dot};
use crate::problem::graph::Problem;

/// Normal equations `H δ = −g` at a linearization point, landmarks kept apart, together with
/// the problem's sparsity plan (computed once, reused by every linearization of a solve: no
/// per-iteration allocation).
pub(crate) struct NormalEquations {
    /// Size of the reduced system.
    pub n: usize,
    /// Reduced-state block `H_xx` (row-major), its upper triangle: the lower one is left as
    /// it was (the Cholesky of the column-major view reads only this triangle; whoever needs
    /// the full matrix mirrors it).
    pub hxx: Vec<f64>,
    /// Reduced-state gradient.
    pub gx: Vec<f64>,
    /// `½ Σ ρ` at the linearization point.
    pub cost: f64,
    /// `Σ ‖r̃‖²` at the linearization point: the constant of the Gauss-Newton model
    /// `Σ ‖r̃ + J̃ δ‖²` (robust residuals as their loss corrects them; direct factors' own
    /// `‖r‖²`), which the model never drops below the minimum of.
    pub model_constant: f64,
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
    pub(super) zblocks: Vec<(usize, usize, usize)>,
    pub(super) zdim: usize,
    /// Whether inverse-depth landmarks are eliminated by one dense product over the coupled
    /// coordinates (small windows) rather than block pair by block pair (large, sparse
    /// problems such as a batch solve).
    pub(super) dense_schur: bool,
    /// Residuals without a variable landmark, in id order.
    pub(super) state_res: Vec<ResidualPlan>,
    /// Residuals with a variable landmark, grouped by landmark, in id order within a group.
    pub(super) lm_res: Vec<ResidualPlan>,
    pub(super) slots: Vec<Slot>,
    /// Rotation matrices of the blocks at the values being evaluated (`Problem::fill_rotations`).
    pub(super) rot: Vec<nalgebra::Matrix3<f64>>,
    /// The same where the Jacobians are evaluated (`Problem::fill_linearization_rotations`).
    pub(super) rot_lin: Vec<nalgebra::Matrix3<f64>>,
    /// Scratch: residual, Jacobians, a factor's direct normal equations.
    pub(super) r: Vec<f64>,
    pub(super) jac: Vec<f64>,
    pub(super) direct_h: Vec<f64>,
    pub(super) direct_g: Vec<f64>,
}

impl NormalEquations {
    /// Plans the normal equations of `residual_ids` (all residuals if `None`) under `layout`
    /// and allocates every buffer; [`Self::linearize`] fills them.
    pub fn new(problem: &Problem, layout: &Layout, residual_ids: Option<&[usize]>) -> Self {
        Self::new_in(problem, layout, residual_ids, Vec::new())
    }

    /// [`Self::new`] with `H_xx` in `hxx`, the buffer of an earlier system (its contents do
    /// not matter: [`Self::linearize`] zeroes the triangle it fills), so that a solve per frame
    /// does not allocate and fault in an `n × n` matrix each time.
    pub fn new_in(
        problem: &Problem,
        layout: &Layout,
        residual_ids: Option<&[usize]>,
        mut hxx: Vec<f64>,
    ) -> Self {
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
        let lt: Vec<usize> = layout
            .landmarks
            .iter()
            .map(|&b| problem.blocks[b].manifold.tangent_size())
            .collect();
        let sparse_work: usize = (0..nl)
            .map(|l| {
                let k: usize = couplings[cstart[l]..cstart[l + 1]]
                    .iter()
                    .map(|c| c.t)
                    .sum();
                k * k * lt[l]
            })
            .sum();
        let dense_schur = zdim * zdim * layout.n_landmark <= 8 * sparse_work;
        let mut lhoff = Vec::with_capacity(nl);
        let mut hlen = 0;
        for t in &lt {
            lhoff.push(hlen);
            hlen += t * t;
        }
        let n = layout.n;
        hxx.resize(n * n, 0.0);
        Self {
            n,
            hxx,
            gx: vec![0.0; n],
            cost: f64::NAN,
            model_constant: f64::NAN,
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
            rot_lin: Vec::new(),
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

    /// `vᵀ H v` for a full-space vector (undamped Hessian; `H_xx` from its upper triangle).
    pub(super) fn quadratic(&self, v: &Step) -> f64 {
        let n = self.n;
        let mut s = 0.0;
        for i in 0..n {
            let row = &self.hxx[i * n + i..i * n + n];
            s += v.dx[i] * (row[0] * v.dx[i] + 2.0 * dot(&row[1..], &v.dx[i + 1..]));
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

    pub(super) fn gradient_dot(&self, v: &Step) -> f64 {
        split_dot((&self.gx, &self.gl), v)
    }

    pub(super) fn gradient_max_norm(&self) -> f64 {
        self.gx
            .iter()
            .chain(&self.gl)
            .fold(0.0f64, |a, g| a.max(g.abs()))
    }

    pub(super) fn gradient_step(&self) -> Step {
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
