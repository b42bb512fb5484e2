//! Marginalization: fold the information that residuals carry about removed blocks into a
//! linear prior on the blocks that stay (Schur complement), as in VINS-Fusion and OKVIS.
//!
//! Steps, for residuals R touching removed blocks M and kept blocks K:
//! 1. linearize R at the current values: `H = Σ JᵀJ`, `g = Σ Jᵀr` and the model's constant
//!    `Σ ‖r‖²`;
//! 2. eliminate removed landmark blocks per block (block-diagonal Schur complement);
//! 3. eliminate the removed state blocks with a pseudo-inverse from a symmetric eigen-decomposition
//!    whose eigenvalues below `eigen_threshold` are treated as zero (rank deficiency is normal:
//!    gauge directions carry no information);
//! 4. keep the result in information form (`H*`, `g*` and the constant): the solver adds it to
//!    its normal equations as it is, so no factorization of the ~450-coordinate marginal of a
//!    window with persistent points is needed (its square root is factored only if someone
//!    evaluates the prior as residuals).
//!
//! The prior keeps the linearization point of K (first-estimate Jacobians): its Jacobian never
//! changes, so it cannot inject information along directions it had none in. Blocks that
//! already carry a first-estimate point ([`Problem::set_linearization_point`]) keep it: the
//! residuals are linearized with Jacobians there and the prior is expressed around it.

use std::sync::Arc;

use nalgebra::DVector;

use super::graph::{BlockId, BlockKind, Problem, ResidualId};
use super::prior::{PriorError, PriorFactor, eliminate_leading};
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
}

impl Default for MarginalizationOptions {
    fn default() -> Self {
        Self {
            eigen_threshold: 1e-8,
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
    let system = schur_complement_system(problem, residual_ids, &states, &removed_landmarks)
        .ok_or(MarginalizationError::Evaluation)?;
    // 3. Remove the state blocks with an eigen-thresholded pseudo-inverse.
    let (h_star, g_star, c_star) = eliminate_leading(
        system.hessian,
        &system.gradient,
        system.constant,
        nm,
        options.eigen_threshold,
    );
    let nk = h_star.nrows();

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
    // The model `c + 2gᵀδ + δᵀHδ` in `d = δ + s`: `g ← g − H s`, `c ← c − 2gᵀs + sᵀH s`.
    let (g_star, c_star) = if shift.iter().any(|v| *v != 0.0) {
        let hs = &h_star * &shift;
        let c = c_star - 2.0 * g_star.dot(&shift) + shift.dot(&hs);
        (&g_star - hs, c)
    } else {
        (g_star, c_star)
    };

    // 4. The information form, as it is.
    let manifolds: Vec<Arc<dyn Manifold>> = kept
        .iter()
        .map(|b| problem.blocks[b.0].manifold.clone())
        .collect();
    let factor = PriorFactor::from_symmetric_information(
        manifolds,
        points,
        h_star.data.into(),
        g_star.data.into(),
        c_star,
    )?;
    Ok(MarginalPrior {
        factor,
        blocks: kept,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::solver::dense_normal_equations;
    use crate::problem::test_lcg as lcg;
    use crate::problem::{BlockKind, Euclidean, Factor, HuberLoss, LinearFactor, LossFunction};
    use nalgebra::DMatrix;

    /// On a linear problem (three 2-D states, a landmark seen from each, one residual under a
    /// Huber loss outside its quadratic region), the prior left by marginalizing the first
    /// state and the landmark is what the Gauss-Newton model of those residuals costs at every
    /// value of the kept states, minimized over the removed ones: `H`, `g` and the constant
    /// together (`c + 2gᵀd + dᵀHd`), also when read through the square root that `evaluate`
    /// factors.
    #[test]
    fn the_prior_is_the_minimized_model_of_what_it_replaces() {
        let mut seed = 11u64;
        let mut p = Problem::new();
        let e = |t| Arc::new(Euclidean::new(t)) as Arc<dyn Manifold>;
        let x: Vec<BlockId> = (0..3)
            .map(|_| {
                let v = [lcg(&mut seed), lcg(&mut seed)];
                p.add_block(&v, e(2), BlockKind::State).unwrap()
            })
            .collect();
        let v = [lcg(&mut seed), lcg(&mut seed), lcg(&mut seed)];
        let l = p.add_block(&v, e(3), BlockKind::Landmark).unwrap();
        let huber: Arc<dyn LossFunction> = Arc::new(HuberLoss { delta: 0.5 });
        let mut r = Vec::new();
        for (blocks, m, robust) in [
            (vec![x[0]], 3, false),
            (vec![x[0], x[1]], 2, false),
            (vec![x[0], x[2]], 2, true),
            (vec![x[0], l], 2, false),
            (vec![x[1], l], 2, false),
            (vec![x[2], l], 2, false),
        ] {
            let sizes: Vec<usize> = blocks
                .iter()
                .map(|b| p.manifold(*b).tangent_size())
                .collect();
            let a = sizes
                .iter()
                .map(|t| (0..m * t).map(|_| lcg(&mut seed)).collect())
                .collect();
            let b = (0..m).map(|_| 3.0 * lcg(&mut seed)).collect();
            let factor = Arc::new(LinearFactor::new(a, b, sizes).unwrap());
            let loss = robust.then(|| huber.clone());
            r.push(p.add_factor(factor, loss, &blocks).unwrap());
        }
        let mp = marginalize(&p, &r, &[x[0], l], &MarginalizationOptions::default()).unwrap();
        assert_eq!(mp.blocks, vec![x[1], x[2]]);
        // The model's constant: the residuals as the loss corrects them (the Huber one is
        // outside its quadratic region, so the correction matters).
        let mut model_sq = 0.0;
        for id in &r {
            let mut res = vec![0.0; p.factor(*id).residual_dim()];
            let rho = p
                .evaluate_residual(&p.values, id.0, &mut res, None)
                .unwrap();
            let sq: f64 = res.iter().map(|v| v * v).sum();
            if *id == r[2] {
                assert!((rho - sq).abs() > 1e-3, "the Huber residual is robustified");
            }
            model_sq += sq;
        }
        // H, g of exactly these residuals (the problem holds no others).
        let (h, g, order) = dense_normal_equations(&p).unwrap();
        let idx = |b: BlockId| -> Vec<usize> {
            let mut off = 0;
            for o in &order {
                let t = p.manifold(*o).tangent_size();
                if *o == b {
                    return (off..off + t).collect();
                }
                off += t;
            }
            unreachable!("{b:?} not in the system")
        };
        let m_idx: Vec<usize> = idx(x[0]).into_iter().chain(idx(l)).collect();
        let k_idx: Vec<usize> = idx(x[1]).into_iter().chain(idx(x[2])).collect();
        let pick =
            |a: &[usize], b: &[usize]| DMatrix::from_fn(a.len(), b.len(), |i, j| h[(a[i], b[j])]);
        let hmm_inv = pick(&m_idx, &m_idx).try_inverse().unwrap();
        for trial in 0..4 {
            let d = DVector::from_fn(4, |_, _| 0.3 * trial as f64 * lcg(&mut seed));
            // min over δ_m of c + 2gᵀδ + δᵀHδ with δ_k = d.
            let gm = DVector::from_fn(5, |i, _| g[m_idx[i]]) + pick(&m_idx, &k_idx) * &d;
            let gk = DVector::from_fn(4, |i, _| g[k_idx[i]]);
            let want = model_sq + 2.0 * gk.dot(&d) + d.dot(&(pick(&k_idx, &k_idx) * &d))
                - gm.dot(&(&hmm_inv * &gm));
            let kept: Vec<Vec<f64>> = [x[1], x[2]]
                .iter()
                .enumerate()
                .map(|(k, b)| {
                    let step = &d.as_slice()[2 * k..2 * k + 2];
                    p.values(*b).iter().zip(step).map(|(v, s)| v + s).collect()
                })
                .collect();
            let params: Vec<&[f64]> = kept.iter().map(|v| v.as_slice()).collect();
            let (mut hh, mut gg) = (vec![0.0; 16], vec![0.0; 4]);
            let got = mp
                .factor
                .normal_equations(&params, &params, &mut hh, &mut gg)
                .unwrap();
            let tol = 1e-9 * want.abs().max(1.0);
            assert!((got - want).abs() < tol, "trial {trial}: {got} vs {want}");
            let mut res = vec![0.0; mp.factor.residual_dim()];
            assert!(mp.factor.evaluate(&params, &mut res, None));
            let sq: f64 = res.iter().map(|v| v * v).sum();
            assert!(
                (sq - want).abs() < 10.0 * tol,
                "trial {trial}: ‖r‖² {sq} vs {want}"
            );
        }
    }
}
