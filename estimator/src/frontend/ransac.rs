//! Outlier rejection for temporal tracks: RANSAC over the eight-point fundamental matrix of
//! undistorted normalized coordinates (the essential matrix, with its constraints unenforced
//! except rank 2), scored by the Sampson distance.
//!
//! Deterministic: samples come from a ChaCha8 stream seeded by the caller (per frame).

use nalgebra::{Matrix3, SMatrix, SymmetricEigen, Vector2, Vector3};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// RANSAC settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RansacParams {
    /// Inlier threshold on the Sampson distance, normalized-plane units (px / focal).
    pub threshold: f64,
    /// Stop once an all-inlier sample has been drawn with this probability.
    pub confidence: f64,
    /// Hypothesis cap.
    pub max_iterations: usize,
}

/// Inlier mask of the correspondences `x1[i] ↔ x2[i]` (normalized coordinates) under the best
/// fundamental matrix found; all `true` when fewer than eight are given.
pub fn ransac_fundamental(
    x1: &[Vector2<f64>],
    x2: &[Vector2<f64>],
    params: &RansacParams,
    seed: u64,
) -> Vec<bool> {
    let n = x1.len();
    assert_eq!(n, x2.len());
    if n < 8 {
        return vec![true; n];
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let t2 = params.threshold * params.threshold;
    let mut best: Vec<bool> = vec![false; n];
    let mut best_count = 0usize;
    let mut needed = params.max_iterations;
    let mut mask = vec![false; n];
    let mut it = 0;
    while it < needed.min(params.max_iterations) {
        it += 1;
        let mut idx = [0usize; 8];
        let mut k = 0;
        while k < 8 {
            let c = ((rng.next_u32() as u64 * n as u64) >> 32) as usize;
            if !idx[..k].contains(&c) {
                idx[k] = c;
                k += 1;
            }
        }
        let Some(f) = eight_point(idx.iter().map(|&i| (x1[i], x2[i]))) else {
            continue;
        };
        let mut count = 0;
        for i in 0..n {
            mask[i] = sampson2(&f, &x1[i], &x2[i]) < t2;
            count += mask[i] as usize;
        }
        if count > best_count {
            best_count = count;
            best.copy_from_slice(&mask);
            let w = count as f64 / n as f64;
            let p_good = w.powi(8);
            needed = if p_good >= 1.0 - 1e-12 {
                0
            } else if p_good <= 0.0 {
                params.max_iterations
            } else {
                ((1.0 - params.confidence).ln() / (1.0 - p_good).ln()).ceil() as usize
            };
        }
    }
    if best_count < 8 {
        return vec![true; n];
    }
    // Refit on all inliers and take its inlier set (one step of local optimization).
    if let Some(f) = eight_point((0..n).filter(|&i| best[i]).map(|i| (x1[i], x2[i]))) {
        let refit: Vec<bool> = (0..n).map(|i| sampson2(&f, &x1[i], &x2[i]) < t2).collect();
        if refit.iter().filter(|&&b| b).count() >= best_count {
            return refit;
        }
    }
    best
}

/// Linear eight-point estimate (≥ 8 correspondences) of `F` with `x2ᵀ F x1 = 0`, rank 2.
pub fn eight_point(
    pairs: impl Iterator<Item = (Vector2<f64>, Vector2<f64>)>,
) -> Option<Matrix3<f64>> {
    let mut ata = SMatrix::<f64, 9, 9>::zeros();
    let mut count = 0;
    for (a, b) in pairs {
        let row = SMatrix::<f64, 1, 9>::from_row_slice(&[
            b.x * a.x,
            b.x * a.y,
            b.x,
            b.y * a.x,
            b.y * a.y,
            b.y,
            a.x,
            a.y,
            1.0,
        ]);
        ata += row.transpose() * row;
        count += 1;
    }
    if count < 8 {
        return None;
    }
    let eig = SymmetricEigen::new(ata);
    let (imin, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let v = eig.eigenvectors.column(imin);
    let f = Matrix3::new(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]);
    let svd = f.svd(true, true);
    let (u, vt) = (svd.u?, svd.v_t?);
    let mut s = svd.singular_values;
    s[2] = 0.0;
    let f = u * Matrix3::from_diagonal(&s) * vt;
    f.iter().all(|x| x.is_finite()).then_some(f)
}

/// Squared Sampson distance of `x1 ↔ x2` under `F`.
pub fn sampson2(f: &Matrix3<f64>, x1: &Vector2<f64>, x2: &Vector2<f64>) -> f64 {
    let (p1, p2) = (Vector3::new(x1.x, x1.y, 1.0), Vector3::new(x2.x, x2.y, 1.0));
    let fx1 = f * p1;
    let ftx2 = f.transpose() * p2;
    let e = p2.dot(&fx1);
    let d = fx1.x * fx1.x + fx1.y * fx1.y + ftx2.x * ftx2.x + ftx2.y * ftx2.y;
    if d <= 0.0 { f64::INFINITY } else { e * e / d }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3};

    #[test]
    fn ransac_separates_gross_outliers_from_a_rigid_motion() {
        let r = Rotation3::from_euler_angles(0.02, -0.05, 0.03);
        let t = Vector3::new(0.1, 0.02, 0.01);
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (mut x1, mut x2, mut truth) = (Vec::new(), Vec::new(), Vec::new());
        for i in 0..120 {
            let u = |rng: &mut ChaCha8Rng| (rng.next_u32() as f64 / u32::MAX as f64) * 2.0 - 1.0;
            let p = Vector3::new(
                u(&mut rng) * 2.0,
                u(&mut rng) * 1.5,
                2.0 + 3.0 * u(&mut rng).abs(),
            );
            let q = r * p + t;
            x1.push(p.xy() / p.z);
            let mut b = q.xy() / q.z;
            let outlier = i % 10 == 3;
            if outlier {
                b += Vector2::new(0.03, -0.02);
            }
            x2.push(b);
            truth.push(!outlier);
        }
        let params = RansacParams {
            threshold: 1.0 / 460.0,
            confidence: 0.99,
            max_iterations: 200,
        };
        let mask = ransac_fundamental(&x1, &x2, &params, 7);
        assert_eq!(mask, truth);
        // Same seed, same answer.
        assert_eq!(ransac_fundamental(&x1, &x2, &params, 7), mask);
    }
}
