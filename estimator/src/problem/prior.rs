//! The linearized prior left behind by marginalization.

mod marginal;
mod square_root;

use std::sync::{Arc, OnceLock};

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::DMatrix;

pub(crate) use marginal::eliminate_leading;
use square_root::SquareRoot;

use crate::problem::solver::{dot, is_symmetric, mirror_upper};
use crate::problem::{Factor, Manifold};

/// A linear(ized) prior over parameter blocks, the quadratic
/// `‖r‖² = c + 2 bᵀd + dᵀH d` in `d = [x₁ ⊟ x̄₁, …, xₙ ⊟ x̄ₙ]`, held in information form (`H`,
/// `b`, `c`), as marginalization produces it: the solver adds `H` and `b` to its normal
/// equations as they are. `x̄` are the linearization points (first-estimate Jacobians: `H`
/// never changes while the prior lives). As a [`Factor`] its residual is a square root
/// `r = r₀ + J d` with `JᵀJ = H`, `Jᵀr₀ = b`, `‖r₀‖² = c`: the one it was built from
/// ([`Self::new`]), or one factored on first use ([`Self::from_information`]: `n + 1` rows).
#[derive(Clone, Debug)]
pub struct PriorFactor {
    manifolds: Vec<Arc<dyn Manifold>>,
    linearization_points: Vec<Vec<f64>>,
    sizes: Vec<usize>,
    tangents: Vec<usize>,
    offsets: Vec<usize>,
    /// `H` (row-major, n × n, exactly symmetric), `b` and `c`.
    hessian: Vec<f64>,
    gradient: Vec<f64>,
    constant: f64,
    /// Rows of the square-root form.
    rows: usize,
    root: OnceLock<SquareRoot>,
}

/// Whether a row-major `t × t` matrix is exactly the identity.
fn is_identity(b: &[f64], t: usize) -> bool {
    (0..t).all(|i| (0..t).all(|j| b[i * t + j] == if i == j { 1.0 } else { 0.0 }))
}

/// Largest tangent size of a prior block (the evaluation uses fixed scratch buffers).
pub const MAX_TANGENT: usize = 16;

/// Errors constructing a [`PriorFactor`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PriorError {
    /// Dimensions do not agree.
    #[error("prior dimensions disagree: {0}")]
    Dimension(String),
    /// NaN or ∞ in the Jacobian, residual or linearization point.
    #[error("prior has non-finite values")]
    NonFinite,
}

/// Tangent sizes and offsets of `manifolds`, checked against the linearization points.
type Blocks = (Vec<usize>, Vec<usize>, Vec<usize>);

fn check_blocks(
    manifolds: &[Arc<dyn Manifold>],
    linearization_points: &[Vec<f64>],
) -> Result<Blocks, PriorError> {
    if manifolds.len() != linearization_points.len() {
        return Err(PriorError::Dimension(format!(
            "{} manifolds, {} linearization points",
            manifolds.len(),
            linearization_points.len()
        )));
    }
    let sizes: Vec<usize> = manifolds.iter().map(|m| m.ambient_size()).collect();
    let tangents: Vec<usize> = manifolds.iter().map(|m| m.tangent_size()).collect();
    for (k, (x, s)) in linearization_points.iter().zip(&sizes).enumerate() {
        if x.len() != *s {
            return Err(PriorError::Dimension(format!(
                "block {k}: {} values, manifold needs {s}",
                x.len()
            )));
        }
    }
    if let Some(t) = tangents.iter().find(|t| **t > MAX_TANGENT) {
        return Err(PriorError::Dimension(format!(
            "block tangent size {t} exceeds {MAX_TANGENT}"
        )));
    }
    if !linearization_points.iter().flatten().all(|v| v.is_finite()) {
        return Err(PriorError::NonFinite);
    }
    let mut offsets = Vec::with_capacity(tangents.len());
    let mut n = 0;
    for t in &tangents {
        offsets.push(n);
        n += t;
    }
    Ok((sizes, tangents, offsets))
}

impl PriorFactor {
    /// Builds a prior from per-block manifolds and linearization points, a row-major Jacobian
    /// (`r0.len()` rows × total tangent size) and the residual at the linearization point: its
    /// square-root form, kept as given.
    pub fn new(
        manifolds: Vec<Arc<dyn Manifold>>,
        linearization_points: Vec<Vec<f64>>,
        jacobian: Vec<f64>,
        r0: Vec<f64>,
    ) -> Result<Self, PriorError> {
        let (_, tangents, _) = check_blocks(&manifolds, &linearization_points)?;
        let n: usize = tangents.iter().sum();
        let m = r0.len();
        if jacobian.len() != m * n {
            return Err(PriorError::Dimension(format!(
                "Jacobian has {} entries, expected {m} × {n}",
                jacobian.len(),
            )));
        }
        if !jacobian.iter().chain(&r0).all(|v| v.is_finite()) {
            return Err(PriorError::NonFinite);
        }
        let mut gradient = vec![0.0; n];
        for r in 0..m {
            let row = &jacobian[r * n..(r + 1) * n];
            for i in 0..n {
                gradient[i] += row[i] * r0[r];
            }
        }
        // JᵀJ by one dense product, exactly symmetric (its upper triangle mirrored).
        let mut hessian = vec![0.0; n * n];
        if m > 0 && n > 0 {
            let j = MatRef::from_row_major_slice(&jacobian, m, n);
            matmul(
                MatMut::from_column_major_slice_mut(&mut hessian, n, n),
                Accum::Replace,
                j.transpose(),
                j,
                1.0,
                Par::Seq,
            );
        }
        mirror_upper(&mut hessian, n);
        let constant = r0.iter().map(|v| v * v).sum();
        let mut prior = Self::from_symmetric_information(
            manifolds,
            linearization_points,
            hessian,
            gradient,
            constant,
        )?;
        prior.rows = m;
        prior
            .root
            .set(SquareRoot { jacobian, r0 })
            .expect("a new prior's square root is unset");
        Ok(prior)
    }

    /// Builds a prior from its information form: `hessian` `H` (row-major, n × n, exactly
    /// symmetric, positive semi-definite), `gradient` `b` and `constant` `c`, the value at the
    /// linearization points. A sum of squares needs `b` in the range of `H` and
    /// `c ≥ bᵀH⁺b`, as a marginalization of residuals gives them; the square-root form is
    /// factored only if asked for ([`Self::jacobian`], [`Factor::evaluate`]).
    pub fn from_information(
        manifolds: Vec<Arc<dyn Manifold>>,
        linearization_points: Vec<Vec<f64>>,
        hessian: Vec<f64>,
        gradient: Vec<f64>,
        constant: f64,
    ) -> Result<Self, PriorError> {
        let prior = Self::from_symmetric_information(
            manifolds,
            linearization_points,
            hessian,
            gradient,
            constant,
        )?;
        if !is_symmetric(&prior.hessian, prior.tangent_dim()) {
            return Err(PriorError::Dimension("the Hessian is not symmetric".into()));
        }
        Ok(prior)
    }

    /// [`Self::from_information`] for a Hessian that is exactly symmetric by construction (a
    /// mirrored triangle: what marginalization makes), not checked again.
    pub(crate) fn from_symmetric_information(
        manifolds: Vec<Arc<dyn Manifold>>,
        linearization_points: Vec<Vec<f64>>,
        hessian: Vec<f64>,
        gradient: Vec<f64>,
        constant: f64,
    ) -> Result<Self, PriorError> {
        let (sizes, tangents, offsets) = check_blocks(&manifolds, &linearization_points)?;
        let n: usize = tangents.iter().sum();
        if hessian.len() != n * n || gradient.len() != n {
            return Err(PriorError::Dimension(format!(
                "Hessian of {} and gradient of {} entries, expected {n} × {n} and {n}",
                hessian.len(),
                gradient.len()
            )));
        }
        if !all_finite(&hessian) || !all_finite(&gradient) || !constant.is_finite() {
            return Err(PriorError::NonFinite);
        }
        Ok(Self {
            manifolds,
            linearization_points,
            sizes,
            tangents,
            offsets,
            hessian,
            gradient,
            constant,
            rows: n + 1,
            root: OnceLock::new(),
        })
    }

    /// The square-root form, factored on first use.
    fn root(&self) -> &SquareRoot {
        self.root.get_or_init(|| {
            SquareRoot::of(
                &self.hessian,
                &self.gradient,
                self.constant,
                self.tangent_dim(),
            )
        })
    }

    /// Total tangent dimension of the prior's blocks.
    pub fn tangent_dim(&self) -> usize {
        self.tangents.iter().sum()
    }

    /// Linearization points `x̄`.
    pub fn linearization_points(&self) -> &[Vec<f64>] {
        &self.linearization_points
    }

    /// The row-major square-root information Jacobian ([`Factor::residual_dim`] rows).
    pub fn jacobian(&self) -> &[f64] {
        &self.root().jacobian
    }

    /// Residual at the linearization point.
    pub fn r0(&self) -> &[f64] {
        &self.root().r0
    }

    /// The quadratic at `d = x ⊟ x̄` (all blocks' tangent coordinates): its value
    /// `c + 2bᵀd + dᵀHd` and `b + H d` (half its gradient in `d`).
    fn quadratic_at(&self, d: &[f64]) -> (f64, Vec<f64>) {
        let n = self.tangent_dim();
        let hd: Vec<f64> = (0..n)
            .map(|i| dot(&self.hessian[i * n..(i + 1) * n], d))
            .collect();
        let value = self.constant
            + d.iter()
                .zip(self.gradient.iter().zip(&hd))
                .map(|(di, (bi, hdi))| 2.0 * bi * di + di * hdi)
                .sum::<f64>();
        let gradient = self.gradient.iter().zip(&hd).map(|(b, h)| b + h).collect();
        (value, gradient)
    }

    /// Whether the prior says anything: some diagonal entry of `H` is positive.
    pub fn has_information(&self) -> bool {
        let n = self.tangent_dim();
        (0..n).any(|i| self.hessian[i * n + i] > 0.0)
    }

    /// The same prior with the linearization points of some blocks moved: `(k, x)` moves
    /// block `k` to `x` and the quadratic is re-expressed around it (`H` kept, `b ← b + HΔ`,
    /// `c ← c + 2bᵀΔ + ΔᵀHΔ` for the step `Δ = x ⊟ x̄`). Exact on Euclidean blocks (the prior is
    /// linear in them: the cost is unchanged everywhere); on others it holds to first order, so
    /// move only Euclidean ones.
    pub fn relinearized(&self, moves: &[(usize, &[f64])]) -> Result<Self, PriorError> {
        let n = self.tangent_dim();
        let mut points = self.linearization_points.clone();
        let mut step = vec![0.0; n];
        for &(k, x) in moves {
            let manifold = self.manifolds.get(k).ok_or_else(|| {
                PriorError::Dimension(format!("block {k} of {}", self.manifolds.len()))
            })?;
            if x.len() != self.sizes[k] {
                return Err(PriorError::Dimension(format!(
                    "block {k}: {} values, manifold needs {}",
                    x.len(),
                    self.sizes[k]
                )));
            }
            let (t, off) = (self.tangents[k], self.offsets[k]);
            manifold.minus(x, &points[k], &mut step[off..off + t]);
            points[k] = x.to_vec();
        }
        let (constant, gradient) = self.quadratic_at(&step);
        Self::from_symmetric_information(
            self.manifolds.clone(),
            points,
            self.hessian.clone(),
            gradient,
            constant,
        )
    }

    /// The same prior with tangent directions `from` carried to `to` (each [`Self::tangent_dim`]
    /// long, over all blocks in order), changing only the tangent coordinates marked in
    /// `columns`: with `A = (F − T)(T_cᵀ T_c)⁻¹ T_cᵀ` (`T_c`: `to` with the other rows zeroed;
    /// its columns must be independent) the prior's square root becomes `J (I + A)`, the least
    /// change of `J` with `J' · to = J · from` (`r₀` kept, so in information form
    /// `H' = (I + A)ᵀ H (I + A)`, `b' = (I + A)ᵀ b`, `c` unchanged). When linearization points move, the unobservable
    /// directions of a problem move with them; carrying the prior's along keeps it saying along
    /// the new ones exactly what it said along the old ones (nothing, unless something observed
    /// them), as an observability-constrained estimator does.
    pub fn with_directions_moved(
        &self,
        from: &[Vec<f64>],
        to: &[Vec<f64>],
        columns: &[bool],
    ) -> Result<Self, PriorError> {
        let n = self.tangent_dim();
        if from.len() != to.len()
            || from.iter().chain(to).any(|v| v.len() != n)
            || columns.len() != n
        {
            return Err(PriorError::Dimension(format!(
                "{} and {} directions and a column mask of {n} entries expected",
                from.len(),
                to.len()
            )));
        }
        let k = to.len();
        // A = U Vᵀ with V = T_c and U = (F − T)(T_cᵀ T_c)⁻¹.
        let v = DMatrix::from_fn(n, k, |i, j| if columns[i] { to[j][i] } else { 0.0 });
        let change = DMatrix::from_fn(n, k, |i, j| from[j][i] - to[j][i]);
        let gram_inv = (v.transpose() * &v)
            .try_inverse()
            .ok_or_else(|| PriorError::Dimension("target directions are dependent".into()))?;
        let u = change * gram_inv;
        // On the square root, J' = J + (J U) Vᵀ, and H' = J'ᵀJ' by a product: the carried
        // directions stay null to second order (‖J'·to‖² is round-off squared), where the same
        // update on H (H + V(HU)ᵀ + (HU)Vᵀ + V(UᵀHU)Vᵀ) leaves first-order round-off along them
        // that repeated moves pile up (measured: a yaw leak of 5e-10 after 30 s of moves at every
        // solve, against 1e-14).
        let root = self.root();
        let rows = self.rows;
        let j = DMatrix::from_row_slice(rows, n, &root.jacobian);
        let moved = &j + (&j * u) * v.transpose();
        // Row-major: the column-major storage of the transpose.
        Self::new(
            self.manifolds.clone(),
            self.linearization_points.clone(),
            moved.transpose().as_slice().to_vec(),
            root.r0.clone(),
        )
    }
}

impl Factor for PriorFactor {
    fn residual_dim(&self) -> usize {
        self.rows
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &self.sizes
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &self.tangents
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        mut jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let root = self.root();
        let m = self.rows;
        let n = self.tangent_dim();
        residuals[..m].copy_from_slice(&root.r0);
        let mut dx = [0.0; MAX_TANGENT];
        let mut mj = [0.0; MAX_TANGENT * MAX_TANGENT];
        for (k, manifold) in self.manifolds.iter().enumerate() {
            let t = self.tangents[k];
            let off = self.offsets[k];
            let x0 = &self.linearization_points[k];
            let dx = &mut dx[..t];
            manifold.minus(params[k], x0, dx);
            for r in 0..m {
                let row = &root.jacobian[r * n + off..r * n + off + t];
                residuals[r] += row.iter().zip(dx.iter()).map(|(a, b)| a * b).sum::<f64>();
            }
            if let Some(js) = jacobians.as_deref_mut()
                && let Some(out) = js[k].as_deref_mut()
            {
                // ∂r/∂δ = J_k · ∂((x ⊞ δ) ⊟ x̄)/∂δ.
                let mj = &mut mj[..t * t];
                manifold.minus_jacobian(params[k], x0, mj);
                for r in 0..m {
                    let row = &root.jacobian[r * n + off..r * n + off + t];
                    for c in 0..t {
                        let mut s = 0.0;
                        for (i, a) in row.iter().enumerate() {
                            s += a * mj[i * t + c];
                        }
                        out[r * t + c] = s;
                    }
                }
            }
        }
        residuals[..m].iter().all(|v| v.is_finite())
    }

    /// `JᵀJ` itself where every block's minus-Jacobian at `lin_params` is the identity (the
    /// prior's own linearization points, or Euclidean blocks).
    fn constant_hessian(&self, lin_params: &[&[f64]]) -> Option<&[f64]> {
        let mut b = [0.0; MAX_TANGENT * MAX_TANGENT];
        for (k, manifold) in self.manifolds.iter().enumerate() {
            let x0 = &self.linearization_points[k];
            if lin_params[k] == &x0[..] {
                continue;
            }
            let t = self.tangents[k];
            manifold.minus_jacobian(lin_params[k], x0, &mut b[..t * t]);
            if !is_identity(&b[..t * t], t) {
                return None;
            }
        }
        Some(&self.hessian)
    }

    /// `‖r‖² = c + 2 bᵀd + dᵀHd`, `g = Mᵀ(b + H d)`, `JᵀJ = Mᵀ H M` with `d = x ⊟ x̄` and `M`
    /// the block-diagonal minus-Jacobian (identity for Euclidean blocks, `Jr⁻¹` for rotations)
    /// at `lin_params`: O(n²), from the information form alone.
    fn normal_equations(
        &self,
        params: &[&[f64]],
        lin_params: &[&[f64]],
        h: &mut [f64],
        g: &mut [f64],
    ) -> Option<f64> {
        let n = self.tangent_dim();
        let mut d = vec![0.0; n];
        // Minus-Jacobian blocks; `None` where it is exactly the identity.
        let mut mj: Vec<Option<Vec<f64>>> = Vec::with_capacity(self.manifolds.len());
        for (k, manifold) in self.manifolds.iter().enumerate() {
            let (t, off) = (self.tangents[k], self.offsets[k]);
            let x0 = &self.linearization_points[k];
            manifold.minus(params[k], x0, &mut d[off..off + t]);
            let mut b = vec![0.0; t * t];
            manifold.minus_jacobian(lin_params[k], x0, &mut b);
            mj.push((!is_identity(&b, t)).then_some(b));
        }
        let (cost, u) = self.quadratic_at(&d);
        let with_hessian = !h.is_empty();
        if with_hessian {
            h[..n * n].copy_from_slice(&self.hessian);
        }
        g[..n].copy_from_slice(&u);
        // Apply M on both sides, block by block (only non-identity blocks cost anything, and
        // only their trailing non-identity part: a pose's M is the identity on translation).
        for (k, m) in mj.iter().enumerate() {
            let Some(m) = m else { continue };
            let (t, off) = (self.tangents[k], self.offsets[k]);
            let e = |i: usize, j: usize| if i == j { 1.0 } else { 0.0 };
            // Leading rows and columns of M that are those of the identity.
            let lo = (0..t)
                .find(|&i| (0..t).any(|j| m[i * t + j] != e(i, j) || m[j * t + i] != e(j, i)))
                .unwrap_or(t);
            let (t0, tt) = (off + lo, t - lo);
            let mm = |r: usize, c: usize| m[(lo + r) * t + lo + c];
            // g_k ← M_kᵀ u_k
            let mut seg = [0.0; MAX_TANGENT];
            seg[..tt].copy_from_slice(&g[t0..t0 + tt]);
            for c in 0..tt {
                g[t0 + c] = (0..tt).map(|r| mm(r, c) * seg[r]).sum();
            }
            if !with_hessian {
                continue;
            }
            // Columns of block k: H[:, k] ← H[:, k] M_k.
            for row in 0..n {
                seg[..tt].copy_from_slice(&h[row * n + t0..row * n + t0 + tt]);
                for c in 0..tt {
                    h[row * n + t0 + c] = (0..tt).map(|r| seg[r] * mm(r, c)).sum();
                }
            }
            // Rows of block k: H[k, :] ← M_kᵀ H[k, :].
            for col in 0..n {
                for r in 0..tt {
                    seg[r] = h[(t0 + r) * n + col];
                }
                for c in 0..tt {
                    h[(t0 + c) * n + col] = (0..tt).map(|r| mm(r, c) * seg[r]).sum();
                }
            }
        }
        cost.is_finite().then_some(cost)
    }
}

/// Whether every entry is finite: each run of 64 entries tested without stopping early (a loop
/// the compiler vectorizes), stopping at the first run with an infinity or a NaN.
fn all_finite(v: &[f64]) -> bool {
    v.chunks(64)
        .all(|c| c.iter().fold(true, |ok, x| ok & x.is_finite()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::{Euclidean, PoseManifold};

    /// The blocks of the test priors: pose, point, pose, with their linearization points.
    pub(super) fn test_blocks() -> (Vec<Arc<dyn Manifold>>, Vec<Vec<f64>>) {
        let manifolds: Vec<Arc<dyn Manifold>> = vec![
            Arc::new(PoseManifold),
            Arc::new(Euclidean::new(3)),
            Arc::new(PoseManifold),
        ];
        let x0 = vec![
            vec![0.1, -0.2, 0.3, 0.0, 0.0, 0.0, 1.0],
            vec![1.0, 2.0, 3.0],
            vec![0.5, 0.4, -0.1, 0.1, -0.2, 0.3, 0.927_361_849_549_570_4],
        ];
        (manifolds, x0)
    }

    /// A 10-row prior over pose, point, pose, and a point `steps` away from its
    /// linearization point.
    /// Steps from x̄ to a point away from it in every block (rotations included).
    const AWAY: [&[f64]; 3] = [
        &[0.01, 0.02, -0.03, 0.2, -0.1, 0.15],
        &[0.1, -0.1, 0.2],
        &[-0.02, 0.0, 0.01, -0.3, 0.05, 0.1],
    ];

    fn test_prior(steps: [&[f64]; 3]) -> (PriorFactor, Vec<Vec<f64>>) {
        let (manifolds, x0) = test_blocks();
        let (m, n) = (10, 15);
        let jac: Vec<f64> = (0..m * n)
            .map(|i| ((i * 37 % 23) as f64 - 11.0) / 7.0)
            .collect();
        let r0: Vec<f64> = (0..m).map(|i| 0.1 * i as f64 - 0.3).collect();
        let prior = PriorFactor::new(manifolds.clone(), x0.clone(), jac, r0).unwrap();
        let mut x = x0.clone();
        for k in 0..3 {
            manifolds[k].plus(&x0[k], steps[k], &mut x[k]);
        }
        (prior, x)
    }

    /// Residual and block Jacobians of `prior` at `x`.
    fn evaluate_at(prior: &PriorFactor, x: &[Vec<f64>]) -> (Vec<f64>, Vec<Vec<f64>>) {
        let params: Vec<&[f64]> = x.iter().map(|v| v.as_slice()).collect();
        let m = prior.residual_dim();
        let mut r = vec![0.0; m];
        let mut blocks: Vec<Vec<f64>> = [6, 3, 6].iter().map(|t| vec![0.0; m * t]).collect();
        {
            let mut js: Vec<Option<&mut [f64]>> =
                blocks.iter_mut().map(|b| Some(b.as_mut_slice())).collect();
            assert!(prior.evaluate(&params, &mut r, Some(&mut js)));
        }
        (r, blocks)
    }

    /// `(‖r‖², g, H)` of `prior`'s normal equations at `x` (Jacobians at `x` too).
    fn quadratic_at(prior: &PriorFactor, x: &[Vec<f64>]) -> (f64, Vec<f64>, Vec<f64>) {
        let params: Vec<&[f64]> = x.iter().map(|v| v.as_slice()).collect();
        let n = prior.tangent_dim();
        let (mut h, mut g) = (vec![0.0; n * n], vec![0.0; n]);
        let cost = prior
            .normal_equations(&params, &params, &mut h, &mut g)
            .unwrap();
        (cost, g, h)
    }

    fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
        let scale = a.iter().chain(b).fold(1.0f64, |m, v| m.max(v.abs()));
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert!((x - y).abs() <= tol * scale, "{what}[{i}]: {x} vs {y}");
        }
    }

    /// Moving a point's linearization point changes nothing the prior says: cost, gradient
    /// and Hessian agree everywhere (here at the old and the new point and a third), and a
    /// wrong size or block is refused.
    #[test]
    fn relinearizing_a_point_is_exact() {
        let (prior, x) = test_prior([&[0.0; 6], &[0.1, -0.1, 0.2], &[0.0; 6]]);
        let moved = prior.relinearized(&[(1, &x[1])]).unwrap();
        assert_eq!(moved.linearization_points()[1], x[1]);
        let (_, far) = test_prior([
            &[0.01, 0.02, -0.03, 0.2, -0.1, 0.15],
            &[-0.3, 0.5, 0.05],
            &[-0.02, 0.0, 0.01, -0.3, 0.05, 0.1],
        ]);
        let x0 = prior.linearization_points().to_vec();
        for at in [&x0, &x, &far] {
            let (c_old, g_old, h_old) = quadratic_at(&prior, at);
            let (c_new, g_new, h_new) = quadratic_at(&moved, at);
            assert_close(&[c_old], &[c_new], 1e-12, "cost");
            assert_close(&g_old, &g_new, 1e-12, "gradient");
            assert_eq!(h_old, h_new);
            // The square root of the moved prior says the same.
            let (r, _) = evaluate_at(&moved, at);
            assert_close(&[r.iter().map(|v| v * v).sum()], &[c_old], 1e-10, "‖r‖²");
        }
        // The step moved b (the test would pass vacuously if it had not).
        assert!(
            prior
                .gradient
                .iter()
                .zip(&moved.gradient)
                .any(|(a, b)| (a - b).abs() > 1e-3)
        );
        assert!(prior.relinearized(&[(1, &[1.0, 2.0])]).is_err());
        assert!(prior.relinearized(&[(3, &x[1])]).is_err());
    }

    /// Carried directions: the information form is that of `J' = J (I + A)` (`J'·to = J·from`),
    /// so the carried prior says along `to` what the old one said along `from`; the
    /// coordinates outside the mask keep their `H` and `b`, the others change (so the test
    /// cannot pass with nothing moved); bad sizes are refused.
    #[test]
    fn directions_are_carried_through_the_marked_columns_only() {
        let (prior, _) = test_prior([&[0.0; 6], &[0.0; 3], &[0.0; 6]]);
        let (m, n) = (prior.residual_dim(), prior.tangent_dim());
        let direction = |seed: usize| -> Vec<f64> {
            (0..n)
                .map(|i| (((i + 3) * (seed + 5) * 31 % 17) as f64 - 8.0) / 5.0)
                .collect()
        };
        let from: Vec<Vec<f64>> = (0..2).map(direction).collect();
        let mut to = from.clone();
        to[1][7] += 0.5; // a point coordinate moves, as a point's yaw direction does
        // Columns: the first pose and the point.
        let columns: Vec<bool> = (0..n).map(|i| i < 9).collect();
        let moved = prior.with_directions_moved(&from, &to, &columns).unwrap();
        // J' = J + J (F − T)(T_cᵀT_c)⁻¹ T_cᵀ, formed densely.
        let j = DMatrix::from_row_slice(m, n, prior.jacobian());
        let tc = DMatrix::from_fn(n, 2, |i, k| if columns[i] { to[k][i] } else { 0.0 });
        let f_t = DMatrix::from_fn(n, 2, |i, k| from[k][i] - to[k][i]);
        let jm = &j + &j * f_t * (tc.transpose() * &tc).try_inverse().unwrap() * tc.transpose();
        let r0 = nalgebra::DVector::from_column_slice(prior.r0());
        let want_h = jm.transpose() * &jm;
        let want_b = jm.transpose() * &r0;
        let got_h = DMatrix::from_row_slice(n, n, &moved.hessian);
        assert_close(got_h.as_slice(), want_h.as_slice(), 1e-10, "H'");
        assert_close(&moved.gradient, want_b.as_slice(), 1e-10, "b'");
        assert_eq!(moved.constant, prior.constant);
        for (f, t) in from.iter().zip(&to) {
            let (f, t) = (
                nalgebra::DVector::from_column_slice(f),
                nalgebra::DVector::from_column_slice(t),
            );
            let h = DMatrix::from_row_slice(n, n, &prior.hessian);
            let (old, new) = ((&h * &f).dot(&f), (&got_h * &t).dot(&t));
            assert!((old - new).abs() < 1e-9 * old.abs(), "{new} vs {old}");
        }
        for i in 9..n {
            assert_eq!(moved.gradient[i], prior.gradient[i], "b[{i}] changed");
            for c in 9..n {
                assert_eq!(
                    moved.hessian[i * n + c],
                    prior.hessian[i * n + c],
                    "H[{i},{c}]"
                );
            }
        }
        assert!((0..n).any(|r| (moved.hessian[r * n + 7] - prior.hessian[r * n + 7]).abs() > 1e-3));
        assert!(
            prior
                .with_directions_moved(&from, &to[..1], &columns)
                .is_err()
        );
        assert!(
            prior
                .with_directions_moved(&from, &to, &columns[1..])
                .is_err()
        );
    }

    /// `normal_equations` equals `JᵀJ`, `Jᵀr`, `‖r‖²` formed from `evaluate` away from the
    /// linearization point (rotation blocks with a non-identity minus-Jacobian included).
    #[test]
    fn normal_equations_match_evaluate() {
        // A point away from x0.
        let (prior, x) = test_prior(AWAY);
        let (m, n) = (10, 15);
        let params: Vec<&[f64]> = x.iter().map(|v| v.as_slice()).collect();
        let (r, blocks) = evaluate_at(&prior, &x);
        // Full J (m × n) from the blocks.
        let mut full = vec![0.0; m * n];
        let mut off = 0;
        for (b, t) in blocks.iter().zip([6, 3, 6]) {
            for row in 0..m {
                for c in 0..t {
                    full[row * n + off + c] = b[row * t + c];
                }
            }
            off += t;
        }
        let (mut h, mut g) = (vec![0.0; n * n], vec![0.0; n]);
        let cost = prior
            .normal_equations(&params, &params, &mut h, &mut g)
            .unwrap();
        let r_sq: f64 = r.iter().map(|v| v * v).sum();
        assert!(
            (cost - r_sq).abs() < 1e-10 * r_sq.max(1.0),
            "{cost} vs {r_sq}"
        );
        for i in 0..n {
            let gi: f64 = (0..m).map(|k| full[k * n + i] * r[k]).sum();
            assert!((g[i] - gi).abs() < 1e-10 * gi.abs().max(1.0), "g[{i}]");
            for j in 0..n {
                let hij: f64 = (0..m).map(|k| full[k * n + i] * full[k * n + j]).sum();
                assert!(
                    (h[i * n + j] - hij).abs() < 1e-10 * hij.abs().max(1.0),
                    "h[{i},{j}]"
                );
            }
        }
    }

    /// The constant Hessian is offered exactly where `normal_equations` writes `JᵀJ` unchanged:
    /// at the prior's own points (or moved Euclidean blocks), not at a moved rotation.
    #[test]
    fn constant_hessian_only_at_identity_minus_jacobians() {
        let (prior, x) = test_prior(AWAY);
        let x0 = prior.linearization_points().to_vec();
        let at = |v: &[Vec<f64>]| v.iter().map(|b| b.to_vec()).collect::<Vec<_>>();
        let n = 15;
        let (mut h, mut g) = (vec![0.0; n * n], vec![0.0; n]);
        let params: Vec<&[f64]> = x.iter().map(|v| v.as_slice()).collect();
        // At x̄, and with only the point (Euclidean) moved.
        let mut moved_point = at(&x0);
        moved_point[1] = x[1].clone();
        for lin in [at(&x0), moved_point] {
            let lin: Vec<&[f64]> = lin.iter().map(|v| v.as_slice()).collect();
            prior
                .normal_equations(&params, &lin, &mut h, &mut g)
                .unwrap();
            assert_eq!(prior.constant_hessian(&lin), Some(&h[..]));
        }
        let mut moved_pose = at(&x0);
        moved_pose[0] = x[0].clone();
        let lin: Vec<&[f64]> = moved_pose.iter().map(|v| v.as_slice()).collect();
        assert_eq!(prior.constant_hessian(&lin), None);
    }
}
