//! The `Manifold` trait: how a parameter block is updated by a tangent-space step.

use nalgebra::Vector3;

use crate::geometry::{quat_from_xyzw, quat_minus, quat_plus, quat_to_xyzw, right_jacobian_inv};

/// A smooth manifold a parameter block lives on (Ceres' `Manifold`, right-perturbation form).
///
/// Storage is "ambient" (e.g. 4 numbers for a quaternion), steps are "tangent" (3 numbers).
/// All matrices are row-major `&mut [f64]` buffers.
pub trait Manifold: Send + Sync + std::fmt::Debug {
    /// Number of stored values.
    fn ambient_size(&self) -> usize;
    /// Number of degrees of freedom.
    fn tangent_size(&self) -> usize;
    /// `out = x ⊞ delta`.
    fn plus(&self, x: &[f64], delta: &[f64], out: &mut [f64]);
    /// `out = y ⊟ x`, the tangent step with `x ⊞ (y ⊟ x) = y`.
    fn minus(&self, y: &[f64], x: &[f64], out: &mut [f64]);
    /// `∂(x ⊞ δ)/∂δ` at `δ = 0`: ambient × tangent, row-major.
    fn plus_jacobian(&self, x: &[f64], out: &mut [f64]);
    /// `∂((y ⊞ δ) ⊟ x)/∂δ` at `δ = 0`: tangent × tangent, row-major. Identity when `y = x`.
    fn minus_jacobian(&self, y: &[f64], x: &[f64], out: &mut [f64]);
    /// Where a unit quaternion `[qx, qy, qz, qw]` sits in the stored values, if the block
    /// carries a rotation (the solver then converts it to a matrix once per evaluation pass
    /// for [`crate::problem::Factor::evaluate_with_rotations`]). Default: none.
    fn rotation_offset(&self) -> Option<usize> {
        None
    }
}

fn write_identity(n: usize, out: &mut [f64]) {
    out[..n * n].fill(0.0);
    for i in 0..n {
        out[i * n + i] = 1.0;
    }
}

/// A Euclidean block of dimension `dim` (velocities, biases, inverse depths, time offsets).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Euclidean {
    /// Dimension of the block.
    pub dim: usize,
}

impl Euclidean {
    /// A Euclidean manifold of dimension `dim`.
    pub const fn new(dim: usize) -> Self {
        Self { dim }
    }
}

impl Manifold for Euclidean {
    fn ambient_size(&self) -> usize {
        self.dim
    }
    fn tangent_size(&self) -> usize {
        self.dim
    }
    fn plus(&self, x: &[f64], delta: &[f64], out: &mut [f64]) {
        for i in 0..self.dim {
            out[i] = x[i] + delta[i];
        }
    }
    fn minus(&self, y: &[f64], x: &[f64], out: &mut [f64]) {
        for i in 0..self.dim {
            out[i] = y[i] - x[i];
        }
    }
    fn plus_jacobian(&self, _x: &[f64], out: &mut [f64]) {
        write_identity(self.dim, out);
    }
    fn minus_jacobian(&self, _y: &[f64], _x: &[f64], out: &mut [f64]) {
        write_identity(self.dim, out);
    }
}

/// Unit quaternion `[qx, qy, qz, qw]` with right perturbation `q · Exp(δ)` (ambient 4, tangent 3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct QuaternionManifold;

/// Writes `∂(q · Exp(δ))/∂δ|₀` (4×3, storage order x, y, z, w) into `out` rows starting at `row0`
/// of a matrix with `cols` columns, at column `col0`.
fn quat_plus_jacobian_into(q: &[f64], out: &mut [f64], cols: usize, row0: usize, col0: usize) {
    // q ⊗ (0, δ/2): vector part ½(w δ + q_v × δ), scalar part −½ q_v·δ.
    let (x, y, z, w) = (q[0], q[1], q[2], q[3]);
    let m = [[w, -z, y], [z, w, -x], [-y, x, w], [-x, -y, -z]];
    for (r, row) in m.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            out[(row0 + r) * cols + col0 + c] = 0.5 * v;
        }
    }
}

/// Writes `Jr⁻¹(Log(q0⁻¹ q1))` (3×3) into a row-major matrix with `cols` columns at (row0, col0).
fn quat_minus_jacobian_into(q1: &[f64], q0: &[f64], out: &mut [f64], cols: usize, off: usize) {
    let d = quat_minus(&quat_from_xyzw(q1), &quat_from_xyzw(q0));
    let j = right_jacobian_inv(&d);
    for r in 0..3 {
        for c in 0..3 {
            out[(off + r) * cols + off + c] = j[(r, c)];
        }
    }
}

impl Manifold for QuaternionManifold {
    fn rotation_offset(&self) -> Option<usize> {
        Some(0)
    }
    fn ambient_size(&self) -> usize {
        4
    }
    fn tangent_size(&self) -> usize {
        3
    }
    fn plus(&self, x: &[f64], delta: &[f64], out: &mut [f64]) {
        let q = quat_plus(
            &quat_from_xyzw(x),
            &Vector3::new(delta[0], delta[1], delta[2]),
        );
        quat_to_xyzw(&q, out);
    }
    fn minus(&self, y: &[f64], x: &[f64], out: &mut [f64]) {
        let d = quat_minus(&quat_from_xyzw(y), &quat_from_xyzw(x));
        out[..3].copy_from_slice(d.as_slice());
    }
    fn plus_jacobian(&self, x: &[f64], out: &mut [f64]) {
        quat_plus_jacobian_into(x, out, 3, 0, 0);
    }
    fn minus_jacobian(&self, y: &[f64], x: &[f64], out: &mut [f64]) {
        quat_minus_jacobian_into(y, x, out, 3, 0);
    }
}

/// Pose `[px, py, pz, qx, qy, qz, qw]` (ambient 7, tangent 6 = `[δp, δθ]`).
///
/// Decoupled update as in VINS-Fusion: `p + δp`, `q · Exp(δθ)` — the translation step is in the
/// world (parent) frame, the rotation step in the body (child) frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PoseManifold;

impl Manifold for PoseManifold {
    fn rotation_offset(&self) -> Option<usize> {
        Some(3)
    }
    fn ambient_size(&self) -> usize {
        7
    }
    fn tangent_size(&self) -> usize {
        6
    }
    fn plus(&self, x: &[f64], delta: &[f64], out: &mut [f64]) {
        for i in 0..3 {
            out[i] = x[i] + delta[i];
        }
        QuaternionManifold.plus(&x[3..7], &delta[3..6], &mut out[3..7]);
    }
    fn minus(&self, y: &[f64], x: &[f64], out: &mut [f64]) {
        for i in 0..3 {
            out[i] = y[i] - x[i];
        }
        QuaternionManifold.minus(&y[3..7], &x[3..7], &mut out[3..6]);
    }
    fn plus_jacobian(&self, x: &[f64], out: &mut [f64]) {
        out[..42].fill(0.0);
        for i in 0..3 {
            out[i * 6 + i] = 1.0;
        }
        quat_plus_jacobian_into(&x[3..7], out, 6, 3, 3);
    }
    fn minus_jacobian(&self, y: &[f64], x: &[f64], out: &mut [f64]) {
        out[..36].fill(0.0);
        for i in 0..3 {
            out[i * 6 + i] = 1.0;
        }
        quat_minus_jacobian_into(&y[3..7], &x[3..7], out, 6, 3);
    }
}
