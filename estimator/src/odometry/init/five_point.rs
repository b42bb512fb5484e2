//! Relative pose of two calibrated views: the five-point essential-matrix solver (Nistér 2004,
//! solved through the action matrix of Stewénius et al. 2006), its RANSAC, and the
//! decomposition of the essential matrix by cheirality.
//!
//! Convention: points are normalized image coordinates; the pose `(R, t)` maps camera-1
//! coordinates to camera 2 (`X₂ = R X₁ + t`), so `E = [t]ₓ R` and `x₂ᵀ E x₁ = 0`.

use nalgebra::{DMatrix, Matrix3, SMatrix, SVD, SymmetricEigen, Vector2, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

use crate::geometry::skew;

/// A polynomial in `(x, y, z)` of degree ≤ 3, by the coefficients of [`MONOMIALS`].
type Poly = [f64; 20];

/// Exponents `(x, y, z)` of the 20 monomials of degree ≤ 3: the ten cubics first (eliminated),
/// then the quotient basis `x², xy, xz, y², yz, z², x, y, z, 1`.
const MONOMIALS: [(u8, u8, u8); 20] = [
    (3, 0, 0),
    (2, 1, 0),
    (2, 0, 1),
    (1, 2, 0),
    (1, 1, 1),
    (1, 0, 2),
    (0, 3, 0),
    (0, 2, 1),
    (0, 1, 2),
    (0, 0, 3),
    (2, 0, 0),
    (1, 1, 0),
    (1, 0, 1),
    (0, 2, 0),
    (0, 1, 1),
    (0, 0, 2),
    (1, 0, 0),
    (0, 1, 0),
    (0, 0, 1),
    (0, 0, 0),
];

fn monomial_index(e: (u8, u8, u8)) -> usize {
    MONOMIALS.iter().position(|m| *m == e).expect("degree ≤ 3")
}

fn poly_mul(a: &Poly, b: &Poly) -> Poly {
    let mut out = [0.0; 20];
    for (i, ca) in a.iter().enumerate().filter(|(_, c)| **c != 0.0) {
        for (j, cb) in b.iter().enumerate().filter(|(_, c)| **c != 0.0) {
            let (ea, eb) = (MONOMIALS[i], MONOMIALS[j]);
            let e = (ea.0 + eb.0, ea.1 + eb.1, ea.2 + eb.2);
            out[monomial_index(e)] += ca * cb;
        }
    }
    out
}

fn poly_add(a: &Poly, b: &Poly, scale_b: f64) -> Poly {
    std::array::from_fn(|i| a[i] + scale_b * b[i])
}

/// The essential matrices (up to ten) consistent with five correspondences `x1[i] ↔ x2[i]`.
pub fn essential_five_point(x1: &[Vector2<f64>; 5], x2: &[Vector2<f64>; 5]) -> Vec<Matrix3<f64>> {
    // Epipolar constraints x₂ᵀ E x₁ = 0 as rows over E's entries (row-major); the four
    // smallest eigenvectors of AᵀA span the null space.
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    for (p, q) in x1.iter().zip(x2) {
        let (a, b) = (p.push(1.0), q.push(1.0));
        let row = SMatrix::<f64, 9, 1>::from_fn(|k, _| b[k / 3] * a[k % 3]);
        ata += row * row.transpose();
    }
    let eig = SymmetricEigen::new(ata);
    let mut order: Vec<usize> = (0..9).collect();
    order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
    let basis: Vec<Matrix3<f64>> = order[..4]
        .iter()
        .map(|&k| Matrix3::from_fn(|r, c| eig.eigenvectors[(3 * r + c, k)]))
        .collect();
    // E = x X + y Y + z Z + W, each entry a linear polynomial.
    let e: [[Poly; 3]; 3] = std::array::from_fn(|r| {
        std::array::from_fn(|c| {
            let mut p = [0.0; 20];
            p[monomial_index((1, 0, 0))] = basis[0][(r, c)];
            p[monomial_index((0, 1, 0))] = basis[1][(r, c)];
            p[monomial_index((0, 0, 1))] = basis[2][(r, c)];
            p[monomial_index((0, 0, 0))] = basis[3][(r, c)];
            p
        })
    });
    let mut rows: Vec<Poly> = Vec::with_capacity(10);
    // det(E) = 0.
    let minor = |r0: usize, r1: usize, c0: usize, c1: usize| {
        poly_add(
            &poly_mul(&e[r0][c0], &e[r1][c1]),
            &poly_mul(&e[r0][c1], &e[r1][c0]),
            -1.0,
        )
    };
    let mut det = poly_mul(&e[0][0], &minor(1, 2, 1, 2));
    det = poly_add(&det, &poly_mul(&e[0][1], &minor(1, 2, 0, 2)), -1.0);
    det = poly_add(&det, &poly_mul(&e[0][2], &minor(1, 2, 0, 1)), 1.0);
    rows.push(det);
    // 2 E Eᵀ E − tr(E Eᵀ) E = 0.
    let eet: [[Poly; 3]; 3] = std::array::from_fn(|r| {
        std::array::from_fn(|c| {
            (0..3).fold([0.0; 20], |acc, k| {
                poly_add(&acc, &poly_mul(&e[r][k], &e[c][k]), 1.0)
            })
        })
    });
    let trace = poly_add(&poly_add(&eet[0][0], &eet[1][1], 1.0), &eet[2][2], 1.0);
    for r in 0..3 {
        for c in 0..3 {
            let mut p = [0.0; 20];
            for k in 0..3 {
                p = poly_add(&p, &poly_mul(&eet[r][k], &e[k][c]), 2.0);
            }
            rows.push(poly_add(&p, &poly_mul(&trace, &e[r][c]), -1.0));
        }
    }
    let m = DMatrix::from_fn(10, 20, |r, c| rows[r][c]);
    // Eliminate the cubics: [I | B] = M₁⁻¹ [M₁ | M₂].
    let Some(b) = m
        .columns(0, 10)
        .into_owned()
        .lu()
        .solve(&m.columns(10, 10).into_owned())
    else {
        return Vec::new();
    };
    // Action matrix of x on the basis (x², xy, xz, y², yz, z², x, y, z, 1): row i holds x·bᵢ.
    let mut action = DMatrix::<f64>::zeros(10, 10);
    for (i, &(ex, ey, ez)) in MONOMIALS[10..].iter().enumerate() {
        let prod = (ex + 1, ey, ez);
        let k = monomial_index(prod);
        if k >= 10 {
            action[(i, k - 10)] = 1.0;
        } else {
            for j in 0..10 {
                action[(i, j)] = -b[(k, j)];
            }
        }
    }
    let mut out = Vec::new();
    for lambda in action.clone().complex_eigenvalues().iter() {
        if lambda.im.abs() > 1e-8 * (1.0 + lambda.re.abs()) {
            continue;
        }
        // The eigenvector is the basis evaluated at the solution.
        let shifted = &action - DMatrix::<f64>::identity(10, 10) * lambda.re;
        let svd = SVD::new(shifted, false, true);
        let Some(vt) = svd.v_t else { continue };
        let v = vt.row(9);
        if v[9].abs() < 1e-12 {
            continue;
        }
        let (x, y, z) = (v[6] / v[9], v[7] / v[9], v[8] / v[9]);
        let em = basis[0] * x + basis[1] * y + basis[2] * z + basis[3];
        let n = em.norm();
        if n.is_finite() && n > 0.0 {
            out.push(em / n);
        }
    }
    out
}

/// The four `(R, t)` (unit `t`) that an essential matrix factors into.
fn decompose(e: &Matrix3<f64>) -> Vec<(Matrix3<f64>, Vector3<f64>)> {
    let svd = SVD::new(*e, true, true);
    let (Some(mut u), Some(mut vt)) = (svd.u, svd.v_t) else {
        return Vec::new();
    };
    if u.determinant() < 0.0 {
        u = -u;
    }
    if vt.determinant() < 0.0 {
        vt = -vt;
    }
    let w = Matrix3::new(0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0);
    let t: Vector3<f64> = u.column(2).into_owned();
    let (r1, r2) = (u * w * vt, u * w.transpose() * vt);
    vec![(r1, t), (r1, -t), (r2, t), (r2, -t)]
}

/// Depths `(z₁, z₂)` of the point seen at `a` (camera 1) and `b` (camera 2), by the midpoint
/// of the two rays; `None` for parallel rays.
fn depths(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    a: &Vector2<f64>,
    b: &Vector2<f64>,
) -> Option<(f64, f64)> {
    // z₂ b̄ = z₁ R ā + t  ⇒  [R ā, −b̄] (z₁, z₂)ᵀ = −t in least squares.
    let ra = r * a.push(1.0);
    let bb = b.push(1.0);
    let m = nalgebra::Matrix3x2::from_columns(&[ra, -bb]);
    let z = (m.transpose() * m).try_inverse()? * (m.transpose() * -t);
    Some((z[0], z[1]))
}

/// The decomposition of `e` that puts most of the correspondences in front of both cameras.
fn pose_from_essential(
    e: &Matrix3<f64>,
    x1: &[Vector2<f64>],
    x2: &[Vector2<f64>],
) -> Option<(Matrix3<f64>, Vector3<f64>, usize)> {
    decompose(e)
        .into_iter()
        .map(|(r, t)| {
            let front = x1
                .iter()
                .zip(x2)
                .filter(|(a, b)| depths(&r, &t, a, b).is_some_and(|(z1, z2)| z1 > 0.0 && z2 > 0.0))
                .count();
            (r, t, front)
        })
        .max_by_key(|(_, _, n)| *n)
}

/// The Sampson terms of a correspondence under `e`: the epipolar residual `x₂ᵀ E x₁` and the
/// squared norm of its image gradient (the distance is their ratio, `num / √den`).
fn sampson_terms(e: &Matrix3<f64>, a: &Vector2<f64>, b: &Vector2<f64>) -> (f64, f64) {
    let (a, b) = (a.push(1.0), b.push(1.0));
    let ea = e * a;
    let etb = e.transpose() * b;
    let den = ea.x * ea.x + ea.y * ea.y + etb.x * etb.x + etb.y * etb.y;
    (b.dot(&ea), den)
}

/// Squared Sampson distance of a correspondence to the epipolar geometry `e` (normalized
/// units²).
fn sampson_sq(e: &Matrix3<f64>, a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    let (num, den) = sampson_terms(e, a, b);
    if den <= 0.0 {
        return f64::INFINITY;
    }
    num * num / den
}

/// A relative pose found by [`relative_pose_ransac`].
#[derive(Clone, Debug)]
pub struct RelativePose {
    /// Rotation from camera 1 to camera 2.
    pub r: Matrix3<f64>,
    /// Unit translation (camera 2 frame): `X₂ = R X₁ + t`.
    pub t: Vector3<f64>,
    /// Which correspondences are inliers.
    pub inliers: Vec<bool>,
}

/// Relative pose from normalized correspondences by five-point RANSAC: inliers are within
/// `threshold` (Sampson distance, normalized units) of the epipolar geometry; the
/// hypothesis with most inliers wins and is decomposed by cheirality on them. The sampling is
/// seeded by `seed` (same data and seed ⇒ same result); iterations stop at 99 % confidence or
/// `max_iterations`. `None` with fewer than five correspondences or no hypothesis.
pub fn relative_pose_ransac(
    x1: &[Vector2<f64>],
    x2: &[Vector2<f64>],
    threshold: f64,
    max_iterations: usize,
    seed: u64,
) -> Option<RelativePose> {
    let n = x1.len();
    if n < 5 || x2.len() != n {
        return None;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let th2 = threshold * threshold;
    let mut best: Option<(Matrix3<f64>, usize)> = None;
    let mut needed = max_iterations;
    let mut it = 0;
    while it < needed.min(max_iterations) {
        it += 1;
        let mut idx = [0usize; 5];
        let mut k = 0;
        while k < 5 {
            let c = (rng.next_u64() % n as u64) as usize;
            if !idx[..k].contains(&c) {
                idx[k] = c;
                k += 1;
            }
        }
        let s1 = idx.map(|i| x1[i]);
        let s2 = idx.map(|i| x2[i]);
        for e in essential_five_point(&s1, &s2) {
            let count = (0..n)
                .filter(|&i| sampson_sq(&e, &x1[i], &x2[i]) < th2)
                .count();
            if best.as_ref().is_none_or(|(_, c)| count > *c) {
                best = Some((e, count));
                // Iterations for 99 % confidence of one all-inlier sample at this ratio.
                let w = count as f64 / n as f64;
                let p_good = w.powi(5);
                if p_good >= 1.0 {
                    needed = it;
                } else if p_good > 0.0 {
                    needed = ((0.01f64).ln() / (1.0 - p_good).ln()).ceil() as usize;
                }
            }
        }
    }
    let (e, _) = best?;
    let inliers: Vec<bool> = (0..n)
        .map(|i| sampson_sq(&e, &x1[i], &x2[i]) < th2)
        .collect();
    let (i1, i2): (Vec<_>, Vec<_>) = (0..n)
        .filter(|&i| inliers[i])
        .map(|i| (x1[i], x2[i]))
        .unzip();
    let (r, t, _) = pose_from_essential(&e, &i1, &i2)?;
    let (r, t) = refine(r, t, &i1, &i2);
    let e = essential_from_pose(&r, &t);
    let inliers: Vec<bool> = (0..n)
        .map(|i| sampson_sq(&e, &x1[i], &x2[i]) < th2)
        .collect();
    Some(RelativePose { r, t, inliers })
}

/// Signed Sampson distances of the correspondences to the geometry of `(r, t)`.
fn sampson_residuals(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    x1: &[Vector2<f64>],
    x2: &[Vector2<f64>],
) -> Vec<f64> {
    let e = essential_from_pose(r, t);
    x1.iter()
        .zip(x2)
        .map(|(a, b)| {
            let (num, den) = sampson_terms(&e, a, b);
            num / den.max(1e-300).sqrt()
        })
        .collect()
}

/// Gauss-Newton on the inliers' Sampson distances over the five degrees of freedom of a
/// relative pose (rotation, and the unit translation on its sphere), with central-difference
/// Jacobians; a step is kept only when it lowers the cost.
fn refine(
    mut r: Matrix3<f64>,
    mut t: Vector3<f64>,
    x1: &[Vector2<f64>],
    x2: &[Vector2<f64>],
) -> (Matrix3<f64>, Vector3<f64>) {
    let cost = |r: &Matrix3<f64>, t: &Vector3<f64>| {
        sampson_residuals(r, t, x1, x2)
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
    };
    let apply = |r: &Matrix3<f64>, t: &Vector3<f64>, d: &[f64; 5]| {
        let (b1, b2) = crate::geometry::sphere_tangent_basis(t);
        let dr = crate::geometry::so3_exp(&Vector3::new(d[0], d[1], d[2]))
            .to_rotation_matrix()
            .into_inner();
        (dr * r, (t + b1 * d[3] + b2 * d[4]).normalize())
    };
    let mut current = cost(&r, &t);
    for _ in 0..10 {
        let r0 = sampson_residuals(&r, &t, x1, x2);
        let h = 1e-7;
        let mut jac = DMatrix::<f64>::zeros(r0.len(), 5);
        for k in 0..5 {
            let mut d = [0.0; 5];
            d[k] = h;
            let (rp, tp) = apply(&r, &t, &d);
            d[k] = -h;
            let (rm, tm) = apply(&r, &t, &d);
            let (fp, fm) = (
                sampson_residuals(&rp, &tp, x1, x2),
                sampson_residuals(&rm, &tm, x1, x2),
            );
            for i in 0..r0.len() {
                jac[(i, k)] = (fp[i] - fm[i]) / (2.0 * h);
            }
        }
        let res = nalgebra::DVector::from_vec(r0);
        let Some(step) = (jac.transpose() * &jac)
            .cholesky()
            .map(|c| c.solve(&(jac.transpose() * -res)))
        else {
            break;
        };
        let d = [step[0], step[1], step[2], step[3], step[4]];
        let (rn, tn) = apply(&r, &t, &d);
        let next = cost(&rn, &tn);
        if next.is_nan() || next >= current {
            break;
        }
        let done = current - next < 1e-10 * current;
        (r, t, current) = (rn, tn, next);
        if done {
            break;
        }
    }
    (r, t)
}

/// `[t]ₓ R`, the essential matrix of a relative pose.
pub fn essential_from_pose(r: &Matrix3<f64>, t: &Vector3<f64>) -> Matrix3<f64> {
    skew(t) * r
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::so3_exp;

    /// Random points in front of two cameras a few metres apart: returns (x1, x2, R, t).
    #[allow(clippy::type_complexity)]
    fn scene(
        n: usize,
        seed: u64,
        noise: f64,
    ) -> (
        Vec<Vector2<f64>>,
        Vec<Vector2<f64>>,
        Matrix3<f64>,
        Vector3<f64>,
    ) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut u = || (rng.next_u64() as f64 / u64::MAX as f64) * 2.0 - 1.0;
        let r = so3_exp(&Vector3::new(0.1 * u(), 0.2 * u(), 0.1 * u()))
            .to_rotation_matrix()
            .into_inner();
        let t = Vector3::new(0.5 + 0.2 * u(), 0.1 * u(), 0.1 * u());
        let (mut x1, mut x2) = (Vec::new(), Vec::new());
        while x1.len() < n {
            let p = Vector3::new(2.0 * u(), 1.5 * u(), 4.0 + 2.0 * u());
            let q = r * p + t;
            if q.z <= 0.1 {
                continue;
            }
            x1.push(Vector2::new(
                p.x / p.z + noise * u(),
                p.y / p.z + noise * u(),
            ));
            x2.push(Vector2::new(
                q.x / q.z + noise * u(),
                q.y / q.z + noise * u(),
            ));
        }
        (x1, x2, r, t.normalize())
    }

    /// Noise-free: one of the solutions is the true essential matrix (up to sign), and every
    /// solution satisfies the five constraints and the essential-matrix identities.
    #[test]
    fn five_point_recovers_the_true_essential_matrix() {
        for seed in 0..20 {
            let (x1, x2, r, t) = scene(5, seed, 0.0);
            let s1: [Vector2<f64>; 5] = std::array::from_fn(|i| x1[i]);
            let s2: [Vector2<f64>; 5] = std::array::from_fn(|i| x2[i]);
            let sols = essential_five_point(&s1, &s2);
            assert!(
                !sols.is_empty() && sols.len() <= 10,
                "seed {seed}: {} solutions",
                sols.len()
            );
            let truth = essential_from_pose(&r, &t).normalize();
            let best = sols
                .iter()
                .map(|e| (e - truth).norm().min((e + truth).norm()))
                .fold(f64::INFINITY, f64::min);
            assert!(best < 1e-8, "seed {seed}: closest solution {best:e}");
            for e in &sols {
                for i in 0..5 {
                    assert!(x2[i].push(1.0).dot(&(e * x1[i].push(1.0))).abs() < 1e-9);
                }
                assert!(e.determinant().abs() < 1e-9);
                let c = 2.0 * e * e.transpose() * e - (e * e.transpose()).trace() * e;
                assert!(c.norm() < 1e-9, "seed {seed}: {:e}", c.norm());
            }
        }
    }

    /// With 1 px noise (focal 460) and 30 % gross outliers (uniform over the image), RANSAC
    /// recovers the rotation and the translation direction (bounds: the measured worst over the
    /// ten seeds, 0.43° and 1.26°, with a 1.5× margin) and keeps as inliers only correspondences
    /// that the true geometry also explains (an outlier may fall near its epipolar line: the
    /// worst one taken lies 1.71 thresholds from the true geometry; bound 2.5).
    #[test]
    fn ransac_recovers_the_pose_with_outliers() {
        let f = 460.0;
        for seed in 0..10 {
            let (mut x1, x2, r, t) = scene(120, 100 + seed, 1.0 / f);
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut u = || (rng.next_u64() as f64 / u64::MAX as f64) * 2.0 - 1.0;
            let outliers: Vec<bool> = (0..x1.len()).map(|i| i % 10 < 3).collect();
            for (p, o) in x1.iter_mut().zip(&outliers) {
                if *o {
                    *p = Vector2::new(0.8 * u(), 0.5 * u());
                }
            }
            let th = 2.0 / f;
            let pose = relative_pose_ransac(&x1, &x2, th, 200, 1).expect("pose");
            let rot_err = crate::geometry::so3_log(&nalgebra::UnitQuaternion::from_matrix(
                &(pose.r.transpose() * r),
            ))
            .norm()
            .to_degrees();
            let t_err = pose.t.angle(&t).to_degrees();
            assert!(
                rot_err < 0.65 && t_err < 1.9,
                "seed {seed}: {rot_err}° {t_err}°"
            );
            let truth = essential_from_pose(&r, &t);
            for i in 0..x1.len() {
                if pose.inliers[i] && outliers[i] {
                    let d = sampson_sq(&truth, &x1[i], &x2[i]).sqrt();
                    assert!(d < 2.5 * th, "seed {seed}: outlier {i} at {d:e} taken");
                }
            }
            let kept = pose.inliers.iter().filter(|i| **i).count();
            assert!(kept * 10 >= 6 * x1.len(), "seed {seed}: {kept} inliers");
        }
    }
}
