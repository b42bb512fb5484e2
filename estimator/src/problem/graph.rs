//! The factor graph: parameter blocks (with manifolds) and residual blocks over them.

use std::sync::Arc;

use nalgebra::Matrix3;

use super::{Factor, LossFunction, Manifold, apply_loss, rotation_matrix};

/// The rotation matrices of one evaluation pass: at the values ([`Problem::fill_rotations`])
/// and where the Jacobians are taken ([`Problem::fill_linearization_rotations`]).
pub(crate) type PassRotations<'a> = (&'a [Matrix3<f64>], &'a [Matrix3<f64>]);

/// Handle of a parameter block in a [`Problem`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct BlockId(pub usize);

/// Handle of a residual block in a [`Problem`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ResidualId(pub usize);

/// How the solver treats a parameter block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockKind {
    /// Solved for in the reduced (dense) system: poses, speed-biases, extrinsics, td.
    State,
    /// Eliminated per block by the Schur complement before the dense solve (landmarks, e.g.
    /// inverse depths). A residual may touch at most one eliminated block.
    Landmark,
}

#[derive(Clone, Debug)]
pub(crate) struct Block {
    pub offset: usize,
    /// `manifold.ambient_size()`, cached (read for every residual evaluation).
    pub ambient: usize,
    /// `manifold.rotation_offset()`, cached.
    pub rotation: Option<usize>,
    pub manifold: Arc<dyn Manifold>,
    pub kind: BlockKind,
    pub constant: bool,
    /// First-estimate linearization point: where every factor's Jacobians with respect to this
    /// block are evaluated (see [`Problem::set_linearization_point`]).
    pub lin_point: Option<Box<[f64]>>,
}

/// The blocks of one residual, stored inline for the usual few (no allocation per residual).
#[derive(Clone, Debug)]
pub(crate) enum BlockList {
    Inline([BlockId; INLINE_BLOCKS], u8),
    Heap(Vec<BlockId>),
}

const INLINE_BLOCKS: usize = 6;

impl BlockList {
    fn new(blocks: &[BlockId]) -> Self {
        if blocks.len() <= INLINE_BLOCKS {
            let mut a = [BlockId(0); INLINE_BLOCKS];
            a[..blocks.len()].copy_from_slice(blocks);
            Self::Inline(a, blocks.len() as u8)
        } else {
            Self::Heap(blocks.to_vec())
        }
    }
}

impl std::ops::Deref for BlockList {
    type Target = [BlockId];
    #[inline]
    fn deref(&self) -> &[BlockId] {
        match self {
            Self::Inline(a, n) => &a[..*n as usize],
            Self::Heap(v) => v,
        }
    }
}

impl<'a> IntoIterator for &'a BlockList {
    type Item = &'a BlockId;
    type IntoIter = std::slice::Iter<'a, BlockId>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

#[derive(Clone)]
pub(crate) struct Residual {
    pub factor: Arc<dyn Factor>,
    pub loss: Option<Arc<dyn LossFunction>>,
    /// `loss.quadratic_up_to()`, cached: below it the loss is skipped.
    pub quadratic_up_to: f64,
    pub blocks: BlockList,
}

/// Errors building a [`Problem`].
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProblemError {
    /// A block id does not exist.
    #[error("unknown parameter block {0:?}")]
    UnknownBlock(BlockId),
    /// The factor's block sizes disagree with the blocks it was given.
    #[error("factor expects {expected} blocks of sizes {sizes:?}; block {index} has size {got}")]
    SizeMismatch {
        /// Number of blocks the factor expects.
        expected: usize,
        /// The factor's ambient sizes.
        sizes: Vec<usize>,
        /// First offending position.
        index: usize,
        /// Size of the block given there.
        got: usize,
    },
    /// A residual touches two eliminated (landmark) blocks.
    #[error("a residual may touch at most one landmark block")]
    TwoLandmarks,
    /// Initial values hold NaN/∞.
    #[error("parameter block values are not finite")]
    NonFinite,
}

/// A nonlinear least-squares problem `min ½ Σ ρᵢ(‖rᵢ(x)‖²)` over parameter blocks on manifolds.
#[derive(Clone, Default)]
pub struct Problem {
    pub(crate) values: Vec<f64>,
    pub(crate) blocks: Vec<Block>,
    pub(crate) residuals: Vec<Residual>,
}

impl Problem {
    /// An empty problem.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a parameter block with initial `values` on `manifold`.
    pub fn add_block(
        &mut self,
        values: &[f64],
        manifold: Arc<dyn Manifold>,
        kind: BlockKind,
    ) -> Result<BlockId, ProblemError> {
        if values.len() != manifold.ambient_size() {
            return Err(ProblemError::SizeMismatch {
                expected: 1,
                sizes: vec![manifold.ambient_size()],
                index: 0,
                got: values.len(),
            });
        }
        if values.iter().any(|v| !v.is_finite()) {
            return Err(ProblemError::NonFinite);
        }
        let id = BlockId(self.blocks.len());
        self.blocks.push(Block {
            offset: self.values.len(),
            ambient: manifold.ambient_size(),
            rotation: manifold.rotation_offset(),
            manifold,
            kind,
            constant: false,
            lin_point: None,
        });
        self.values.extend_from_slice(values);
        Ok(id)
    }

    /// Fixes where the Jacobians of every factor with respect to block `id` are evaluated
    /// (first-estimate Jacobians, as in Basalt and OpenVINS): residuals are still evaluated at
    /// the current values, but the Jacobian columns of this block — and the other blocks of
    /// any factor touching it — come from `values` for this block. States constrained by a
    /// marginalization prior keep the prior's linearization point this way, so every factor
    /// sees them at one point and the window gains no information along directions that are
    /// unobservable (global position and yaw).
    pub fn set_linearization_point(
        &mut self,
        id: BlockId,
        values: &[f64],
    ) -> Result<(), ProblemError> {
        let b = self
            .blocks
            .get_mut(id.0)
            .ok_or(ProblemError::UnknownBlock(id))?;
        if values.len() != b.ambient {
            return Err(ProblemError::SizeMismatch {
                expected: 1,
                sizes: vec![b.ambient],
                index: 0,
                got: values.len(),
            });
        }
        if values.iter().any(|v| !v.is_finite()) {
            return Err(ProblemError::NonFinite);
        }
        b.lin_point = Some(values.into());
        Ok(())
    }

    /// The first-estimate linearization point of block `id`, if it has one.
    pub fn linearization_point(&self, id: BlockId) -> Option<&[f64]> {
        self.blocks[id.0].lin_point.as_deref()
    }

    /// Whether residual `id` touches a block with a first-estimate linearization point.
    fn uses_linearization_points(&self, id: usize) -> bool {
        self.residuals[id]
            .blocks
            .iter()
            .any(|b| self.blocks[b.0].lin_point.is_some())
    }

    /// Holds a block fixed (`true`) or lets the solver move it (`false`).
    pub fn set_constant(&mut self, id: BlockId, constant: bool) {
        self.blocks[id.0].constant = constant;
    }

    /// Whether a block is held fixed.
    pub fn is_constant(&self, id: BlockId) -> bool {
        self.blocks[id.0].constant
    }

    /// Adds a residual block `factor(blocks…)`, optionally robustified by `loss`.
    pub fn add_factor(
        &mut self,
        factor: Arc<dyn Factor>,
        loss: Option<Arc<dyn LossFunction>>,
        blocks: &[BlockId],
    ) -> Result<ResidualId, ProblemError> {
        let sizes = factor.parameter_block_sizes();
        let tangents = factor.parameter_tangent_sizes();
        let mut landmarks = 0;
        for (i, id) in blocks.iter().enumerate() {
            let b = self
                .blocks
                .get(id.0)
                .ok_or(ProblemError::UnknownBlock(*id))?;
            if i >= sizes.len()
                || sizes[i] != b.manifold.ambient_size()
                || tangents[i] != b.manifold.tangent_size()
            {
                return Err(ProblemError::SizeMismatch {
                    expected: sizes.len(),
                    sizes: sizes.to_vec(),
                    index: i,
                    got: b.manifold.ambient_size(),
                });
            }
            landmarks += usize::from(b.kind == BlockKind::Landmark);
        }
        if blocks.len() != sizes.len() {
            return Err(ProblemError::SizeMismatch {
                expected: sizes.len(),
                sizes: sizes.to_vec(),
                index: blocks.len(),
                got: 0,
            });
        }
        if landmarks > 1 {
            return Err(ProblemError::TwoLandmarks);
        }
        let quadratic_up_to = loss.as_ref().map_or(-1.0, |l| l.quadratic_up_to());
        self.residuals.push(Residual {
            factor,
            loss,
            quadratic_up_to,
            blocks: BlockList::new(blocks),
        });
        Ok(ResidualId(self.residuals.len() - 1))
    }

    /// Current values of a block.
    pub fn values(&self, id: BlockId) -> &[f64] {
        let b = &self.blocks[id.0];
        &self.values[b.offset..b.offset + b.ambient]
    }

    /// Overwrites the values of a block.
    pub fn set_values(&mut self, id: BlockId, values: &[f64]) {
        let b = &self.blocks[id.0];
        let n = b.manifold.ambient_size();
        self.values[b.offset..b.offset + n].copy_from_slice(&values[..n]);
    }

    /// The manifold of a block.
    pub fn manifold(&self, id: BlockId) -> &Arc<dyn Manifold> {
        &self.blocks[id.0].manifold
    }

    /// The kind of a block.
    pub fn kind(&self, id: BlockId) -> BlockKind {
        self.blocks[id.0].kind
    }

    /// Number of parameter blocks.
    pub fn num_blocks(&self) -> usize {
        self.blocks.len()
    }

    /// Number of residual blocks.
    pub fn num_residuals(&self) -> usize {
        self.residuals.len()
    }

    /// The blocks a residual touches.
    pub fn residual_blocks(&self, id: ResidualId) -> &[BlockId] {
        &self.residuals[id.0].blocks
    }

    /// The factor of a residual.
    pub fn factor(&self, id: ResidualId) -> &Arc<dyn Factor> {
        &self.residuals[id.0].factor
    }

    /// Fills `out[b]` with the rotation matrix of every block `b` that carries a rotation (see
    /// `Manifold::rotation_offset`) at `values`; other entries are left as they are.
    pub(crate) fn fill_rotations(&self, values: &[f64], out: &mut Vec<Matrix3<f64>>) {
        out.resize(self.blocks.len(), Matrix3::identity());
        for (b, blk) in self.blocks.iter().enumerate() {
            if let Some(o) = blk.rotation {
                let q = blk.offset + o;
                out[b] = rotation_matrix(&values[q..q + 4]);
            }
        }
    }

    /// [`Self::fill_rotations`] where the Jacobians are evaluated: at a block's first-estimate
    /// linearization point where it has one (copied from `at_values` otherwise).
    pub(crate) fn fill_linearization_rotations(
        &self,
        at_values: &[Matrix3<f64>],
        out: &mut Vec<Matrix3<f64>>,
    ) {
        out.clear();
        out.extend_from_slice(at_values);
        for (b, blk) in self.blocks.iter().enumerate() {
            if let (Some(o), Some(x0)) = (blk.rotation, &blk.lin_point) {
                out[b] = rotation_matrix(&x0[o..o + 4]);
            }
        }
    }

    /// Calls `f` with the value slices of residual `id`'s blocks taken from `values` (a full
    /// value vector); no allocation for residuals of up to 8 blocks (every factor but the
    /// marginalization prior, which allocates once per linearization).
    #[inline]
    pub(crate) fn with_residual_params<R>(
        &self,
        values: &[f64],
        id: usize,
        f: impl FnOnce(&[&[f64]]) -> R,
    ) -> R {
        self.with_params(values, id, false, f)
    }

    /// Calls `f` with the slices at which residual `id`'s Jacobians are evaluated: each block's
    /// first-estimate linearization point where it has one, its entry of `values` otherwise.
    #[inline]
    pub(crate) fn with_linearization_params<R>(
        &self,
        values: &[f64],
        id: usize,
        f: impl FnOnce(&[&[f64]]) -> R,
    ) -> R {
        self.with_params(values, id, true, f)
    }

    /// The two above: `first_estimates` picks the blocks' linearization points where set.
    #[inline]
    fn with_params<R>(
        &self,
        values: &[f64],
        id: usize,
        first_estimates: bool,
        f: impl FnOnce(&[&[f64]]) -> R,
    ) -> R {
        let blocks = &self.residuals[id].blocks;
        let slice = |b: &BlockId| {
            let blk = &self.blocks[b.0];
            let own = &values[blk.offset..blk.offset + blk.ambient];
            match &blk.lin_point {
                Some(x0) if first_estimates => &x0[..],
                _ => own,
            }
        };
        let mut small: [&[f64]; 8] = [&[]; 8];
        if blocks.len() <= small.len() {
            for (k, b) in blocks.iter().enumerate() {
                small[k] = slice(b);
            }
            f(&small[..blocks.len()])
        } else {
            let large: Vec<&[f64]> = blocks.iter().map(slice).collect();
            f(&large)
        }
    }

    /// The factor of residual `id` at `values`, without loss: `false` if it cannot be
    /// evaluated there.
    fn evaluate_factor(
        &self,
        values: &[f64],
        rotations: Option<&[Matrix3<f64>]>,
        id: usize,
        r: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        self.evaluate_factor_at(values, false, rotations, id, r, jacobians)
    }

    /// [`Self::evaluate_factor`], at the blocks' linearization points where they have one if
    /// `first_estimates` (`rotations` then holds [`Self::fill_linearization_rotations`]).
    fn evaluate_factor_at(
        &self,
        values: &[f64],
        first_estimates: bool,
        rotations: Option<&[Matrix3<f64>]>,
        id: usize,
        r: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let res = &self.residuals[id];
        self.with_params(values, id, first_estimates, |params| match rotations {
            Some(rot) if res.blocks.len() <= INLINE_BLOCKS => {
                let mut rots: [Option<&Matrix3<f64>>; INLINE_BLOCKS] = [None; INLINE_BLOCKS];
                for (k, b) in res.blocks.iter().enumerate() {
                    if self.blocks[b.0].rotation.is_some() {
                        rots[k] = Some(&rot[b.0]);
                    }
                }
                res.factor
                    .evaluate_with_rotations(params, &rots[..res.blocks.len()], r, jacobians)
            }
            _ => res.factor.evaluate(params, r, jacobians),
        })
    }

    /// Evaluates residual `id` at `values` (a full value vector), optionally with loss, into
    /// `r`; Jacobians where requested (at the first-estimate linearization points of blocks
    /// that have one, see [`Self::set_linearization_point`]). `rotations`, if given, holds
    /// [`Self::fill_rotations`] for `values`. Returns the robustified `ρ(‖r‖²)` or `None` if
    /// the factor cannot be evaluated.
    pub(crate) fn evaluate_residual_with(
        &self,
        values: &[f64],
        rotations: Option<PassRotations<'_>>,
        id: usize,
        r: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> Option<f64> {
        let res = &self.residuals[id];
        let has_j = jacobians.is_some();
        let mut jacobians = jacobians;
        let (rotations, lin_rotations) = match rotations {
            Some((at_values, at_lin)) => (Some(at_values), Some(at_lin)),
            None => (None, None),
        };
        let ok = match jacobians.as_deref_mut() {
            Some(js) if self.uses_linearization_points(id) => {
                // Jacobians at the linearization points, then the residual at `values`. Where
                // the factor cannot be evaluated at the linearization points but can at
                // `values` (a wide-angle camera's point whose first estimate lies behind the
                // image plane while its estimate does not), its Jacobians come from `values`:
                // this one residual loses its first-estimate Jacobians instead of failing the
                // whole linearization.
                (self.evaluate_factor_at(values, true, lin_rotations, id, r, Some(&mut *js))
                    || self.evaluate_factor(values, rotations, id, r, Some(js)))
                    && self.evaluate_factor(values, rotations, id, r, None)
            }
            js => self.evaluate_factor(values, rotations, id, r, js),
        };
        if !ok {
            return None;
        }
        if r.iter().any(|v| !v.is_finite()) {
            return None;
        }
        match &res.loss {
            Some(loss) => {
                let s: f64 = r.iter().map(|v| v * v).sum();
                if s <= res.quadratic_up_to {
                    // ρ(s) = s, ρ' = 1, ρ'' = 0: `apply_loss` would change nothing.
                    return Some(s);
                }
                let mut empty: [Option<&mut [f64]>; 0] = [];
                let js = if has_j {
                    jacobians.unwrap()
                } else {
                    &mut empty[..]
                };
                Some(apply_loss(loss.as_ref(), r, js))
            }
            None => Some(r.iter().map(|v| v * v).sum()),
        }
    }

    /// [`Self::evaluate_residual_with`] without precomputed rotations.
    pub(crate) fn evaluate_residual(
        &self,
        values: &[f64],
        id: usize,
        r: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> Option<f64> {
        self.evaluate_residual_with(values, None, id, r, jacobians)
    }

    /// The squared norm `‖r‖²` of residual `id` (whitened, before its loss) at the current
    /// values: a χ² variable with `residual_dim` degrees of freedom for a consistent factor;
    /// `None` if the factor fails to evaluate.
    pub fn residual_squared_norm(&self, id: ResidualId) -> Option<f64> {
        let m = self.residuals.get(id.0)?.factor.residual_dim();
        let mut r = vec![0.0; m];
        self.evaluate_factor(&self.values, None, id.0, &mut r, None)
            .then(|| r.iter().map(|v| v * v).sum())
    }

    /// Total cost `½ Σ ρ(‖r‖²)` at the current values; `None` if a factor fails to evaluate.
    pub fn cost(&self) -> Option<f64> {
        self.cost_at(&self.values)
    }

    pub(crate) fn cost_at(&self, values: &[f64]) -> Option<f64> {
        let mut r = [0.0; 64];
        let mut total = 0.0;
        for i in 0..self.residuals.len() {
            let m = self.residuals[i].factor.residual_dim();
            let mut heap;
            let r = if m <= r.len() {
                &mut r[..m]
            } else {
                heap = vec![0.0; m];
                &mut heap[..]
            };
            total += self.evaluate_residual(values, i, r, None)?;
        }
        Some(0.5 * total)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::{Euclidean, SolverOptions, Termination, solve};

    /// `r = √x − 3`, defined for `x > 0` only (like a projection behind the camera).
    struct SqrtFactor;

    impl Factor for SqrtFactor {
        fn residual_dim(&self) -> usize {
            1
        }
        fn parameter_block_sizes(&self) -> &[usize] {
            &[1]
        }
        fn parameter_tangent_sizes(&self) -> &[usize] {
            &[1]
        }
        fn evaluate(
            &self,
            params: &[&[f64]],
            residuals: &mut [f64],
            jacobians: Option<&mut [Option<&mut [f64]>]>,
        ) -> bool {
            let x = params[0][0];
            if x <= 0.0 {
                return false;
            }
            residuals[0] = x.sqrt() - 3.0;
            if let Some(j) = jacobians.and_then(|js| js[0].as_deref_mut()) {
                j[0] = 0.5 / x.sqrt();
            }
            true
        }
    }

    /// A factor that cannot be evaluated at its block's first estimate (x̄ = −1) but can at
    /// the current value takes its Jacobian there: the solve converges to √x = 3 instead of
    /// failing its first linearization (which reset the whole window).
    #[test]
    fn a_first_estimate_the_factor_cannot_evaluate_falls_back_to_the_current_value() {
        let mut problem = Problem::new();
        let x = problem
            .add_block(&[4.0], Arc::new(Euclidean::new(1)), BlockKind::State)
            .unwrap();
        problem.set_linearization_point(x, &[-1.0]).unwrap();
        problem
            .add_factor(Arc::new(SqrtFactor), None, &[x])
            .unwrap();
        let summary = solve(&mut problem, &SolverOptions::default());
        assert_eq!(summary.termination, Termination::Converged, "{summary:?}");
        assert!(
            (problem.values(x)[0] - 9.0).abs() < 1e-6,
            "{:?}",
            problem.values(x)
        );
    }
}
