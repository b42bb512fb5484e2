//! Powell's dogleg step: Gauss–Newton inside the trust region, else the Cauchy point, else the
//! point on the segment between them where it leaves the region.

use super::normal_equations::NormalEquations;
use super::schur::ReducedSystem;
use super::vector::{Step, norm, scale};

/// Powell's dogleg step within `radius` (full-space Euclidean norm of the tangent step).
pub(super) fn dogleg_step(
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
