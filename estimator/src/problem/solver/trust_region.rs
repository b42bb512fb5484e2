//! The trust-region loop: linearize, step (Levenberg–Marquardt or dogleg), accept or shrink,
//! until a tolerance or the iteration cap; optional modified Gauss–Newton steps in between.

use std::time::{Duration, Instant};

use super::dogleg::dogleg_step;
use super::linearization::Linearization;
use super::normal_equations::NormalEquations;
use super::options::{Method, SolverOptions, SolverSummary, Termination};
use super::plan::{Layout, NONE};
use super::schur::ReducedSystem;
use super::vector::{Step, max_abs, norm};
use crate::problem::graph::Problem;

/// Applies a full-space step to a copy of the problem's values.
fn apply_step(problem: &Problem, layout: &Layout, step: &Step, out: &mut Vec<f64>) {
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
    solve_keeping_linearization(problem, options).0
}

/// Minimizes the problem's cost in place, like [`solve`], and also returns the normal
/// equations of the solve's last linearization (the system its last step was computed from;
/// `None` if nothing was linearized or the last linearization failed), for marginal
/// covariances without another linearization.
pub fn solve_keeping_linearization(
    problem: &mut Problem,
    options: &SolverOptions,
) -> (SolverSummary, Option<Linearization>) {
    solve_keeping_linearization_in(problem, options, &mut SolverWorkspace::default())
}

/// Scratch of the solver's reduced system (the damped Schur complement, its Cholesky
/// workspace, the dense Schur product's columns) and the `H_xx` buffer of a finished solve,
/// kept between solves so that a sliding window does not allocate and fault them in again
/// every frame. It holds no state: a solve's result does not depend on the workspace it was
/// given, and a clone is a fresh workspace.
#[derive(Default)]
pub struct SolverWorkspace {
    sys: ReducedSystem,
    hxx: Vec<f64>,
    factor: Vec<f64>,
}

impl SolverWorkspace {
    /// Takes back the buffers of a solve's kept linearization once it is no longer needed:
    /// the next solve fills them instead of allocating its own.
    pub fn recycle(&mut self, linearization: Linearization) {
        let (hxx, factor, spare) = linearization.into_buffers();
        self.hxx = hxx;
        for buffer in [factor, spare].into_iter().filter(|b| b.capacity() > 0) {
            if let Some(buffer) = self.sys.give_back(buffer) {
                self.factor = buffer;
            }
        }
    }
}

/// The largest Levenberg–Marquardt damping `λ` whose factor a kept linearization uses as the
/// factor of its undamped information (see [`Linearization::marginal_covariance`]): it changes
/// the information by a relative 1e-10 of its diagonal at most, far below the precision any
/// covariance is read to. The window's solves start at `λ` = 1e-12.
const UNDAMPED_LAMBDA: f64 = 1e-10;

impl Clone for SolverWorkspace {
    fn clone(&self) -> Self {
        Self::default()
    }
}

/// [`solve_keeping_linearization`] with the reduced system's buffers taken from (and left in)
/// `workspace`.
pub fn solve_keeping_linearization_in(
    problem: &mut Problem,
    options: &SolverOptions,
    workspace: &mut SolverWorkspace,
) -> (SolverSummary, Option<Linearization>) {
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
        return (summary, None);
    }
    // The plan and every buffer of the linear system are built once and reused by each
    // linearization and step. The first linearization also gives the initial cost.
    let mut e = NormalEquations::new_in(problem, &layout, None, std::mem::take(&mut workspace.hxx));
    if !e.linearize(problem) {
        summary.termination = Termination::InvalidInitialPoint;
        summary.time = start.elapsed();
        return (summary, None);
    }
    summary.iterations = 1;
    let mut cost = e.cost;
    summary.initial_cost = cost;
    summary.final_cost = cost;
    let mut radius = options.initial_trust_radius;
    let mut decrease_factor = 2.0;
    let mut candidate = Vec::with_capacity(problem.values.len());
    let sys = &mut workspace.sys;
    sys.forget_factorization();
    let mut linearized = true;
    summary.termination = Termination::MaxIterations;
    if e.gradient_max_norm() <= options.gradient_tolerance {
        summary.termination = Termination::Converged;
        summary.time = start.elapsed();
        let spare = std::mem::take(&mut workspace.factor);
        return (summary, Some(Linearization::new(e, layout, spare, None)));
    }
    // With modified steps: the gradient at the current values, when a step of the current
    // linearization reached them (evaluated once the step is taken, only if a modified step
    // follows).
    let modified = options.modified_newton && options.method == Method::LevenbergMarquardt;
    let mut gradient = Step {
        dx: Vec::new(),
        dl: Vec::new(),
    };
    let mut gradient_ready = false;
    // Every pass but the first (whose linearization happened above) checks the cap first.
    let mut first = true;
    loop {
        if !first && summary.iterations >= options.max_iterations {
            break;
        }
        first = false;
        if std::mem::take(&mut gradient_ready) {
            summary.iterations += 1;
            if max_abs(&gradient) <= options.gradient_tolerance {
                summary.termination = Termination::Converged;
                break;
            }
            // The last linearization's factorized system, the new gradient.
            let converged = e.solve_factored(&gradient, sys).and_then(|step| {
                let g = (&gradient.dx[..], &gradient.dl[..]);
                let model_decrease = e.damped_model_decrease(g, &step, sys);
                apply_step(problem, &layout, &step, &mut candidate);
                let nc = e.cost_at(problem, &candidate);
                accept(
                    problem,
                    &mut candidate,
                    (&mut cost, &mut summary),
                    nc,
                    model_decrease,
                )
                .map(|(_, rel)| rel < options.function_tolerance)
            });
            if converged == Some(true) {
                summary.termination = Termination::Converged;
                break;
            }
            continue;
        }
        if !linearized {
            summary.iterations += 1;
            if !e.linearize(problem) {
                summary.termination = Termination::InvalidInitialPoint;
                summary.final_cost = cost;
                summary.time = start.elapsed();
                return (summary, None);
            }
            linearized = true;
            // The last factorization belongs to the previous linearization.
            sys.forget_factorization();
            if e.gradient_max_norm() <= options.gradient_tolerance {
                summary.termination = Termination::Converged;
                break;
            }
        }
        let step = match options.method {
            Method::LevenbergMarquardt => e.solve_damped(1.0 / radius, options.min_diagonal, sys),
            Method::Dogleg => dogleg_step(&e, radius, options.min_diagonal, sys),
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
        let model_decrease = match options.method {
            Method::LevenbergMarquardt => e.damped_model_decrease((&e.gx, &e.gl), &step, sys),
            Method::Dogleg => -(e.gradient_dot(&step) + 0.5 * e.quadratic(&step)),
        };
        apply_step(problem, &layout, &step, &mut candidate);
        let new_cost = e.cost_at(problem, &candidate);
        let accepted = accept(
            problem,
            &mut candidate,
            (&mut cost, &mut summary),
            new_cost,
            model_decrease,
        );
        // The gradient only where a modified step follows: the step was taken, did not meet
        // the cost tolerance, and the cap leaves room for one. (Most frames of a window stop
        // at their first step, so its Jacobians are not evaluated for nothing; `gradient_at`'s
        // cost equals `cost_at`'s bit for bit, so nothing else changes.)
        let with_gradient = modified
            && summary.iterations < options.max_iterations
            && accepted.is_some_and(|(_, rel)| rel >= options.function_tolerance)
            && e.gradient_at(problem, &problem.values, &mut gradient)
                .is_some();
        if let Some((rho, rel)) = accepted {
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
            gradient_ready = with_gradient;
            if rel < options.function_tolerance {
                summary.termination = Termination::Converged;
                break;
            }
        }
        if accepted.is_none() {
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
    // The last factorization, of this linearization (a relinearization forgets it), is the
    // kept linearization's if it was as good as undamped.
    let factor = workspace.sys.take_factor(UNDAMPED_LAMBDA);
    let spare = std::mem::take(&mut workspace.factor);
    (summary, Some(Linearization::new(e, layout, spare, factor)))
}

/// The trust-region acceptance test shared by full and modified steps: a step whose cost
/// `new_cost` realizes more than 10⁻³ of the model's predicted `model_decrease` is taken (the
/// candidate values become current, its cost the current cost, one more successful step).
/// Returns the gain ratio `ρ` and the relative cost decrease; `None` (nothing changes) for a
/// rejected step, a non-positive predicted decrease or an unevaluable candidate.
fn accept(
    problem: &mut Problem,
    candidate: &mut Vec<f64>,
    (cost, summary): (&mut f64, &mut SolverSummary),
    new_cost: Option<f64>,
    model_decrease: f64,
) -> Option<(f64, f64)> {
    let nc = new_cost.filter(|_| model_decrease > 0.0)?;
    let rho = Some((*cost - nc) / model_decrease).filter(|rho| *rho > 1e-3)?;
    let rel = (*cost - nc) / cost.max(f64::MIN_POSITIVE);
    std::mem::swap(&mut problem.values, candidate);
    *cost = nc;
    summary.successful_steps += 1;
    Some((rho, rel))
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::problem::{BlockKind, Euclidean, Factor};

    /// Rosenbrock's function as residuals `[10 (y − x²), 1 − x]` over one 2-vector.
    struct Rosenbrock;

    impl Factor for Rosenbrock {
        fn residual_dim(&self) -> usize {
            2
        }
        fn parameter_block_sizes(&self) -> &[usize] {
            &[2]
        }
        fn parameter_tangent_sizes(&self) -> &[usize] {
            &[2]
        }
        fn evaluate(
            &self,
            params: &[&[f64]],
            residuals: &mut [f64],
            jacobians: Option<&mut [Option<&mut [f64]>]>,
        ) -> bool {
            let (x, y) = (params[0][0], params[0][1]);
            residuals[0] = 10.0 * (y - x * x);
            residuals[1] = 1.0 - x;
            if let Some(Some(j)) = jacobians.map(|js| js[0].as_deref_mut()) {
                j.copy_from_slice(&[-20.0 * x, 10.0, -1.0, 0.0]);
            }
            true
        }
    }

    fn rosenbrock() -> (Problem, crate::problem::BlockId) {
        let mut p = Problem::new();
        let b = p
            .add_block(&[-1.2, 1.0], Arc::new(Euclidean::new(2)), BlockKind::State)
            .unwrap();
        p.add_factor(Arc::new(Rosenbrock), None, &[b]).unwrap();
        (p, b)
    }

    /// Modified steps (the last linearization's factorization, the gradient at the new point)
    /// reach the same minimum as full Levenberg–Marquardt, and take some of its iterations.
    #[test]
    fn modified_newton_steps_reach_the_rosenbrock_minimum() {
        let run = |modified_newton| {
            let (mut p, b) = rosenbrock();
            let options = SolverOptions {
                max_iterations: 400,
                function_tolerance: 1e-14,
                initial_trust_radius: 1.0,
                modified_newton,
                ..Default::default()
            };
            let summary = solve(&mut p, &options);
            (summary, p.values(b).to_vec())
        };
        let (full, x_full) = run(false);
        let (modified, x) = run(true);
        assert_eq!(modified.termination, Termination::Converged, "{modified:?}");
        assert!(modified.final_cost < 1e-12, "{modified:?}");
        assert!(
            (x[0] - 1.0).abs() < 1e-5 && (x[1] - 1.0).abs() < 1e-5,
            "{x:?}"
        );
        assert!((x[0] - x_full[0]).abs() < 1e-5 && (x[1] - x_full[1]).abs() < 1e-5);
        // It is a different iteration (so the option is live), still monotone.
        assert_ne!(modified.iterations, full.iterations);
        assert!(modified.final_cost <= modified.initial_cost);
        // With no room for a modified step, the same iteration bit for bit.
        let one = |modified_newton| {
            let (mut p, b) = rosenbrock();
            let options = SolverOptions {
                max_iterations: 1,
                initial_trust_radius: 1.0,
                modified_newton,
                ..Default::default()
            };
            let summary = solve(&mut p, &options);
            (summary.final_cost, p.values(b).to_vec())
        };
        assert_eq!(one(true), one(false));
    }

    /// A workspace left by a larger solve (its kept linearization recycled into it) changes
    /// nothing in the next one: the same summary and values, bit for bit, as with a fresh
    /// workspace.
    #[test]
    fn a_reused_workspace_gives_the_same_solve_bit_for_bit() {
        let options = SolverOptions {
            max_iterations: 50,
            function_tolerance: 1e-14,
            initial_trust_radius: 1.0,
            modified_newton: true,
            ..Default::default()
        };
        let mut workspace = SolverWorkspace::default();
        // Two Rosenbrock valleys: a 4-coordinate system, factored when it stops.
        let mut larger = Problem::new();
        for start in [[-1.2, 1.0], [0.5, -0.3]] {
            let b = larger
                .add_block(&start, Arc::new(Euclidean::new(2)), BlockKind::State)
                .unwrap();
            larger.add_factor(Arc::new(Rosenbrock), None, &[b]).unwrap();
        }
        let (_, kept) = solve_keeping_linearization_in(&mut larger, &options, &mut workspace);
        // Its kept linearization's buffers handed back, one covariance read from it first.
        let kept = kept.expect("linearized");
        let block = crate::problem::BlockId(0);
        assert!(
            kept.marginal_covariance(&[(block, 0), (block, 1)])
                .is_some()
        );
        workspace.recycle(kept);
        let run = |workspace: &mut SolverWorkspace| {
            let (mut p, b) = rosenbrock();
            let (summary, _) = solve_keeping_linearization_in(&mut p, &options, workspace);
            let s = summary;
            (
                s.iterations,
                s.successful_steps,
                s.final_cost.to_bits(),
                p.values(b).to_vec(),
            )
        };
        assert_eq!(run(&mut workspace), run(&mut SolverWorkspace::default()));
    }

    #[test]
    fn both_trust_region_methods_reach_the_rosenbrock_minimum() {
        for method in [Method::LevenbergMarquardt, Method::Dogleg] {
            let (mut p, b) = rosenbrock();
            let options = SolverOptions {
                method,
                max_iterations: 200,
                function_tolerance: 1e-14,
                initial_trust_radius: 1.0,
                ..Default::default()
            };
            let summary = solve(&mut p, &options);
            let x = p.values(b);
            assert_eq!(summary.termination, Termination::Converged, "{method:?}");
            assert!(summary.final_cost < 1e-12, "{method:?}: {summary:?}");
            assert!(
                (x[0] - 1.0).abs() < 1e-5 && (x[1] - 1.0).abs() < 1e-5,
                "{method:?}: {x:?}"
            );
            // Rosenbrock's valley needs many steps; the cost only ever goes down.
            assert!(summary.successful_steps >= 5, "{method:?}: {summary:?}");
        }
    }

    #[test]
    fn dogleg_steps_stay_in_the_trust_region_and_reach_gauss_newton() {
        let (p, _) = rosenbrock();
        let layout = Layout::new(&p);
        let e = super::super::normal_equations::linearize(&p, &layout, None).unwrap();
        let mut sys = ReducedSystem::default();
        // The Gauss–Newton step as `dogleg_step` computes it (a 1e-10 regularization).
        let gn = e.solve_damped(1e-10, 1e-6, &mut sys).unwrap();
        let gn_norm = norm(&gn);
        for radius in [1e-3, 0.05, 0.3, 0.9 * gn_norm] {
            let s = dogleg_step(&e, radius, 1e-6, &mut sys).unwrap();
            assert!((norm(&s) - radius).abs() < 1e-9 * radius, "radius {radius}");
            // Every dogleg step decreases the quadratic model.
            assert!(e.gradient_dot(&s) + 0.5 * e.quadratic(&s) < 0.0);
        }
        // A region holding the Gauss–Newton step returns it.
        let s = dogleg_step(&e, 2.0 * gn_norm, 1e-6, &mut sys).unwrap();
        assert_eq!(s.dx, gn.dx);
    }
}
