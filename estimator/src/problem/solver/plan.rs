//! The plan of a linear system: where each variable block lives ([`Layout`]) and how each
//! residual's Jacobian rows enter the normal equations (slots, landmark couplings), computed
//! once per solve by [`NormalEquations::new`].

use super::normal_equations::NormalEquations;
use crate::problem::graph::{BlockKind, Problem};

/// Marks a block or coupling that has no place in the system.
pub(crate) const NONE: usize = usize::MAX;

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
pub(super) struct Slot {
    /// Offset in the reduced system (`NONE` unless a variable state block).
    pub(super) offset: usize,
    /// Tangent size.
    pub(super) t: usize,
    /// Offset of this block's Jacobian (`m × t`, row-major) in the residual's scratch buffer;
    /// `NONE` for blocks held constant (no Jacobian requested).
    pub(super) jpos: usize,
    /// Index of the coupling block `H_xl` with the residual's landmark (state blocks of a
    /// residual that touches a variable landmark), `NONE` otherwise.
    pub(super) coupling: usize,
}

/// One residual's plan: which blocks are variable and where their rows go.
#[derive(Clone, Debug)]
pub(super) struct ResidualPlan {
    /// Residual index in the problem.
    pub(super) ri: usize,
    /// Residual dimension.
    pub(super) m: usize,
    /// Range of this residual's slots in `Plan::slots`.
    pub(super) slots: (usize, usize),
    /// Position (within the residual's blocks) of its variable landmark, `NONE` if none.
    pub(super) landmark: usize,
    /// Index of that landmark in the landmark list.
    pub(super) lm: usize,
    /// Total scratch length of the Jacobians (`m × Σ t` over variable blocks).
    pub(super) jlen: usize,
    /// Whether to try the factor's `normal_equations` (no loss, no variable landmark).
    pub(super) direct: bool,
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
            rot_lin: Vec::new(),
            r: vec![0.0; max_m],
            jac: vec![0.0; max_j],
            direct_h: Vec::new(),
            direct_g: Vec::new(),
        }
    }
}
