//! Linear-Gaussian exactness of the solver and of marginalization: a sliding window that
//! marginalizes its oldest state reproduces the full batch solution, and each prior's
//! information equals the inverse of the batch marginal covariance of the states it keeps.

use std::sync::Arc;

use estimator::problem::marginalization::{MarginalizationOptions, marginalize};
use estimator::problem::solver::dense_normal_equations;
use estimator::problem::{
    BlockId, BlockKind, Euclidean, Factor, LinearFactor, Problem, ResidualId, SolverOptions, solve,
};
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const N: usize = 14;
const WINDOW: usize = 4;

/// A factor over global state indices.
struct Measurement {
    factor: Arc<dyn Factor>,
    states: Vec<usize>,
}

fn measurements(rng: &mut ChaCha8Rng) -> Vec<Measurement> {
    let truth: Vec<[f64; 3]> = (0..N)
        .map(|k| [k as f64, (k as f64 * 0.3).sin(), 0.1 * k as f64])
        .collect();
    let mut out = Vec::new();
    let mut noise = |s: f64| rng.random_range(-1.0..1.0) * s;
    let identity =
        |w: f64| -> Vec<f64> { (0..9).map(|i| if i % 4 == 0 { w } else { 0.0 }).collect() };
    // Absolute position of x0 and of every fourth state (σ = 0.1 → weight 10).
    for k in (0..N).step_by(4) {
        let b = (0..3).map(|i| 10.0 * (truth[k][i] + noise(0.1))).collect();
        out.push(Measurement {
            factor: Arc::new(LinearFactor::new(vec![identity(10.0)], b, vec![3]).unwrap()),
            states: vec![k],
        });
    }
    // Relative displacements to the previous and the one before (σ = 0.05 → weight 20).
    for k in 1..N {
        for back in [1usize, 2] {
            if k < back {
                continue;
            }
            let j = k - back;
            let b = (0..3)
                .map(|i| 20.0 * (truth[k][i] - truth[j][i] + noise(0.05)))
                .collect();
            let f =
                LinearFactor::new(vec![identity(20.0), identity(-20.0)], b, vec![3, 3]).unwrap();
            out.push(Measurement {
                factor: Arc::new(f),
                states: vec![k, j],
            });
        }
    }
    out
}

fn tight() -> SolverOptions {
    SolverOptions {
        max_iterations: 50,
        function_tolerance: 1e-16,
        parameter_tolerance: 1e-14,
        gradient_tolerance: 1e-14,
        ..SolverOptions::default()
    }
}

#[test]
fn sliding_window_with_marginalization_equals_batch() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let meas = measurements(&mut rng);

    // Batch: every state, every factor.
    let mut batch = Problem::new();
    let ids: Vec<BlockId> = (0..N)
        .map(|_| {
            batch
                .add_block(&[0.0; 3], Arc::new(Euclidean::new(3)), BlockKind::State)
                .unwrap()
        })
        .collect();
    for m in &meas {
        let blocks: Vec<BlockId> = m.states.iter().map(|s| ids[*s]).collect();
        batch.add_factor(m.factor.clone(), None, &blocks).unwrap();
    }
    solve(&mut batch, &tight());
    let (h_batch, _, _) = dense_normal_equations(&batch).unwrap();
    let cov_batch = h_batch.clone().try_inverse().unwrap();

    // Sliding window over the same measurements in time order.
    let mut values: Vec<[f64; 3]> = vec![[0.0; 3]; N];
    let mut prior: Option<(Arc<dyn Factor>, Vec<usize>)> = None;
    let mut first = 0usize;
    let mut removed_measurements: Vec<usize> = Vec::new();
    for newest in 0..N {
        let mut p = Problem::new();
        let mut block_of = vec![None; N];
        for s in first..=newest {
            block_of[s] = Some(
                p.add_block(&values[s], Arc::new(Euclidean::new(3)), BlockKind::State)
                    .unwrap(),
            );
        }
        let mut live: Vec<(usize, ResidualId)> = Vec::new();
        for (mi, m) in meas.iter().enumerate() {
            let inside = m.states.iter().all(|s| *s >= first && *s <= newest);
            if inside && !removed_measurements.contains(&mi) {
                let blocks: Vec<BlockId> = m.states.iter().map(|s| block_of[*s].unwrap()).collect();
                live.push((mi, p.add_factor(m.factor.clone(), None, &blocks).unwrap()));
            }
        }
        let prior_id = prior.as_ref().map(|(f, states)| {
            let blocks: Vec<BlockId> = states.iter().map(|s| block_of[*s].unwrap()).collect();
            p.add_factor(f.clone(), None, &blocks).unwrap()
        });
        solve(&mut p, &tight());
        for s in first..=newest {
            values[s].copy_from_slice(p.values(block_of[s].unwrap()));
        }
        if newest - first + 1 > WINDOW {
            // Linearize away from the optimum (a linear prior is exact at any point, and a
            // gradient term that is wrong would show only here, where g ≠ 0).
            for s in first..=newest {
                let b = block_of[s].unwrap();
                let moved: Vec<f64> = p
                    .values(b)
                    .iter()
                    .map(|v| v + rng.random_range(-0.5..0.5))
                    .collect();
                p.set_values(b, &moved);
            }
            // Marginalize the oldest state with every residual touching it.
            let oldest = block_of[first].unwrap();
            let mut touching: Vec<ResidualId> = live
                .iter()
                .filter(|(mi, _)| meas[*mi].states.contains(&first))
                .map(|(_, r)| *r)
                .collect();
            touching.extend(prior_id.filter(|r| p.residual_blocks(*r).contains(&oldest)));
            let mp =
                marginalize(&p, &touching, &[oldest], &MarginalizationOptions::default()).unwrap();
            for (mi, _) in &live {
                if meas[*mi].states.contains(&first) {
                    removed_measurements.push(*mi);
                }
            }
            let kept_states: Vec<usize> = mp
                .blocks
                .iter()
                .map(|b| (first..=newest).find(|s| block_of[*s] == Some(*b)).unwrap())
                .collect();

            // The prior's information equals the inverse marginal covariance of the kept states
            // in the batch problem of every measurement removed so far.
            let mut sub = Problem::new();
            let sub_ids: Vec<BlockId> = (0..N)
                .map(|s| {
                    sub.add_block(&values[s], Arc::new(Euclidean::new(3)), BlockKind::State)
                        .unwrap()
                })
                .collect();
            for mi in &removed_measurements {
                let blocks: Vec<BlockId> = meas[*mi].states.iter().map(|s| sub_ids[*s]).collect();
                sub.add_factor(meas[*mi].factor.clone(), None, &blocks)
                    .unwrap();
            }
            let (h_sub, _, order) = dense_normal_equations(&sub).unwrap();
            let cov_sub = h_sub.try_inverse().unwrap();
            let idx: Vec<usize> = kept_states
                .iter()
                .flat_map(|s| {
                    let pos = order.iter().position(|b| *b == sub_ids[*s]).unwrap();
                    (3 * pos)..(3 * pos + 3)
                })
                .collect();
            let marginal_cov =
                DMatrix::from_fn(idx.len(), idx.len(), |i, j| cov_sub[(idx[i], idx[j])]);
            let expected_info = marginal_cov.try_inverse().unwrap();
            let nk = idx.len();
            let jp = DMatrix::from_row_slice(mp.factor.residual_dim(), nk, mp.factor.jacobian());
            let info = jp.transpose() * &jp;
            let rel = (&info - &expected_info).norm() / expected_info.norm();
            assert!(
                rel < 1e-9,
                "prior information differs by {rel:e} after removing x{first}"
            );

            prior = Some((Arc::new(mp.factor), kept_states));
            first += 1;
        }
    }
    for s in first..N {
        for i in 0..3 {
            let b = batch.values(ids[s])[i];
            assert!(
                (values[s][i] - b).abs() < 1e-9,
                "x{s}[{i}]: window {} vs batch {b}",
                values[s][i]
            );
        }
    }
    // The batch solution is the exact least-squares optimum: its gradient vanishes.
    let (_, g, _) = dense_normal_equations(&batch).unwrap();
    assert!(g.amax() < 1e-9, "batch gradient {}", g.amax());
    assert!(cov_batch.iter().all(|v| v.is_finite()));
}
