//! Marginal covariances from the Gauss-Newton information of a whole problem, computed on the
//! Schur-complement (reduced) system the solver works with: landmark blocks are eliminated
//! first, so the cost is one linearization, one elimination and one Cholesky factorization of
//! the state-sized system, never a dense inverse over the landmarks.

use nalgebra::DMatrix;

use super::graph::{BlockId, BlockKind, Problem, ResidualId};
use super::solver::{Layout, NONE, covariance_of_picks, schur_complement_system};

/// The joint covariance of the tangent coordinates `coords` (each `(block, index in its
/// tangent)`): the matching part of the inverse of the problem's Gauss-Newton information over
/// every variable block at the current values (first-estimate points honoured). Landmark blocks
/// that no coordinate asks for are eliminated by the undamped Schur complement (a landmark
/// without information folds nothing in); the reduced system is factored by Cholesky and solved
/// for the requested columns only. Coordinates of blocks that are not variables (constant or
/// untouched) get zero rows and columns. `None` if the reduced information is not positive
/// definite or a residual cannot be evaluated.
pub fn marginal_covariance(problem: &Problem, coords: &[(BlockId, usize)]) -> Option<DMatrix<f64>> {
    let layout = Layout::new(problem);
    let asked = |i: usize| coords.iter().any(|(b, _)| b.0 == i);
    let (mut states, mut eliminated) = (Vec::new(), Vec::new());
    for i in 0..problem.num_blocks() {
        let variable = layout.state_offset[i] != NONE || layout.landmark_slot[i] != NONE;
        if !variable {
            continue;
        }
        if problem.kind(BlockId(i)) == BlockKind::Landmark && !asked(i) {
            eliminated.push(BlockId(i));
        } else {
            states.push(BlockId(i));
        }
    }
    let residuals: Vec<ResidualId> = (0..problem.num_residuals()).map(ResidualId).collect();
    let mut h = schur_complement_system(problem, &residuals, &states, &eliminated)?.hessian;
    let mut offsets = Vec::with_capacity(states.len());
    let mut at = 0;
    for b in &states {
        offsets.push(at);
        at += problem.manifold(*b).tangent_size();
    }
    // (row in the output, column in H) of every coordinate of a variable block.
    let picks: Vec<(usize, usize)> = coords
        .iter()
        .enumerate()
        .filter_map(|(r, (id, i))| Some((r, offsets[states.iter().position(|b| b == id)?] + i)))
        .collect();
    // H is symmetric: its column-major buffer is also the row-major one the solve expects.
    covariance_of_picks(h.as_mut_slice(), at, &picks, coords.len())
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::problem::solver::dense_normal_equations;
    use crate::problem::{Euclidean, LinearFactor, test_lcg as lcg};

    /// States and 3-dof landmarks coupled by random linear factors, one state constant.
    fn random_problem() -> (Problem, Vec<BlockId>, Vec<BlockId>) {
        let mut seed = 11u64;
        let mut p = Problem::new();
        let states: Vec<_> = (0..5)
            .map(|_| {
                p.add_block(&[0.0; 6], Arc::new(Euclidean::new(6)), BlockKind::State)
                    .unwrap()
            })
            .collect();
        let lms: Vec<_> = (0..20)
            .map(|_| {
                p.add_block(&[0.1; 3], Arc::new(Euclidean::new(3)), BlockKind::Landmark)
                    .unwrap()
            })
            .collect();
        for (li, l) in lms.iter().enumerate() {
            for s in states.iter().skip(li % 3) {
                let a = vec![
                    (0..18).map(|_| lcg(&mut seed)).collect(),
                    (0..9).map(|_| lcg(&mut seed)).collect(),
                ];
                let b = (0..3).map(|_| lcg(&mut seed)).collect();
                p.add_factor(
                    Arc::new(LinearFactor::new(a, b, vec![6, 3]).unwrap()),
                    None,
                    &[*s, *l],
                )
                .unwrap();
            }
        }
        let prior: Vec<f64> = (0..36)
            .map(|i| if i % 7 == 0 { 2.0 } else { 0.0 })
            .collect();
        let f = LinearFactor::new(vec![prior], vec![0.0; 6], vec![6]).unwrap();
        p.add_factor(Arc::new(f), None, &[states[1]]).unwrap();
        p.set_constant(states[0], true);
        (p, states, lms)
    }

    #[test]
    fn schur_covariance_equals_the_dense_inverse() {
        let (p, states, lms) = random_problem();
        let (h, _, blocks) = dense_normal_equations(&p).unwrap();
        let hinv = h.cholesky().unwrap().inverse();
        let offset = |id: BlockId| -> usize {
            let k = blocks.iter().position(|b| *b == id).unwrap();
            blocks[..k]
                .iter()
                .map(|b| p.manifold(*b).tangent_size())
                .sum()
        };
        // Two states, a landmark (kept as a state for the request) and a constant block.
        let mut coords: Vec<(BlockId, usize)> = (0..6).map(|i| (states[4], i)).collect();
        coords.extend((0..6).map(|i| (states[2], i)));
        coords.extend((0..3).map(|i| (lms[7], i)));
        coords.push((states[0], 2));
        let cov = marginal_covariance(&p, &coords).unwrap();
        for (r, (br, ir)) in coords.iter().enumerate() {
            for (c, (bc, ic)) in coords.iter().enumerate() {
                let want = if *br == states[0] || *bc == states[0] {
                    0.0
                } else {
                    hinv[(offset(*br) + ir, offset(*bc) + ic)]
                };
                let got = cov[(r, c)];
                assert!(
                    (got - want).abs() <= 1e-9 * hinv.amax(),
                    "({r}, {c}): {got} against {want}"
                );
            }
        }
    }

    #[test]
    fn the_solves_linearization_gives_the_same_covariance_on_a_linear_problem() {
        // Linear factors: the information does not depend on the point, so the covariance of
        // the solve's last linearization equals the one at the solution.
        // Solved from a damping of 1e-4 (the undamped system is factored for the covariance),
        // and of 1e-12 in one step (the solve's own factor stands for it, as in the window;
        // a solve that linearizes again after its last step has none).
        for (radius, max_iterations, own_factor) in [(1e4, 10, false), (1e12, 1, true)] {
            let (mut p, states, lms) = random_problem();
            let options = crate::problem::SolverOptions {
                initial_trust_radius: radius,
                max_iterations,
                ..Default::default()
            };
            let (summary, lin) = crate::problem::solve_keeping_linearization(&mut p, &options);
            assert!(summary.iterations >= 1);
            let lin = lin.expect("linearized");
            assert_eq!(lin.holds_a_factor(), own_factor, "radius {radius}");
            let mut coords: Vec<(BlockId, usize)> = (0..6).map(|i| (states[3], i)).collect();
            coords.extend((0..6).map(|i| (states[1], i)));
            coords.push((states[0], 4));
            let kept = lin.marginal_covariance(&coords).unwrap();
            let fresh = marginal_covariance(&p, &coords).unwrap();
            let err = (&kept - &fresh).amax();
            assert!(err <= 1e-9 * fresh.amax(), "radius {radius}: {err:e}");
            assert!(fresh.amax() > 0.0);
            // A second request reads the same factor.
            assert_eq!(lin.marginal_covariance(&coords).unwrap(), kept);
            // Landmarks are eliminated in the kept system: their coordinates are refused.
            assert!(lin.marginal_covariance(&[(lms[0], 0)]).is_none());
        }
    }
}
