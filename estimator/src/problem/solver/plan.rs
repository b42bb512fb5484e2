//! The plan of a linear system: where each variable block lives ([`Layout`]) and how each
//! residual's Jacobian rows enter the normal equations (slots, landmark couplings), computed
//! once per solve by `NormalEquations::new`.

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
