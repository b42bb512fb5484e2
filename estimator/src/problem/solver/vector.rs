//! The bottom floor of the solver: full-space steps and the few vector and row-major matrix
//! operations every other solver file shares, each summed in a fixed order.

/// Dot product with four independent partial sums (vectorizable; a fixed summation order, so
/// results are deterministic).
#[inline(always)]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let b = &b[..a.len()];
    let (ac, ar) = a.as_chunks::<4>();
    let (bc, br) = b.as_chunks::<4>();
    let mut s = [0.0; 4];
    for (x, y) in ac.iter().zip(bc) {
        for k in 0..4 {
            s[k] += x[k] * y[k];
        }
    }
    let mut t = (s[0] + s[2]) + (s[1] + s[3]);
    for (x, y) in ar.iter().zip(br) {
        t += x * y;
    }
    t
}

/// A step in the full space: reduced states then stacked landmarks.
pub(crate) struct Step {
    pub dx: Vec<f64>,
    pub dl: Vec<f64>,
}

/// `gᵀv` for a full-space gradient given as its state and landmark parts.
pub(crate) fn split_dot((gx, gl): (&[f64], &[f64]), v: &Step) -> f64 {
    let s: f64 = gx.iter().zip(&v.dx).map(|(a, b)| a * b).sum();
    s + gl.iter().zip(&v.dl).map(|(a, b)| a * b).sum::<f64>()
}

/// `max |v|` over a full-space vector.
pub(crate) fn max_abs(v: &Step) -> f64 {
    v.dx.iter().chain(&v.dl).fold(0.0f64, |a, x| a.max(x.abs()))
}

/// Euclidean norm of a full-space vector.
pub(crate) fn norm(s: &Step) -> f64 {
    s.dx.iter().chain(&s.dl).map(|v| v * v).sum::<f64>().sqrt()
}

/// `k · s`.
pub(crate) fn scale(s: &Step, k: f64) -> Step {
    Step {
        dx: s.dx.iter().map(|v| v * k).collect(),
        dl: s.dl.iter().map(|v| v * k).collect(),
    }
}

/// Copies the upper triangle of a row-major square matrix onto its lower triangle.
///
/// Tile by tile (`TILE` square): a column of the lower triangle written in one sweep
/// strides a whole row per element, one cache line each, which at the ~465 coordinates of a
/// window with 100 persistent points cost more than the linearization's own arithmetic.
pub(crate) fn mirror_upper(h: &mut [f64], n: usize) {
    for i0 in (0..n).step_by(TILE) {
        let i1 = (i0 + TILE).min(n);
        for j0 in (i0..n).step_by(TILE) {
            let j1 = (j0 + TILE).min(n);
            for i in i0..i1 {
                for j in j0.max(i + 1)..j1 {
                    h[j * n + i] = h[i * n + j];
                }
            }
        }
    }
}

/// Whether the row-major `n × n` matrix `h` equals its transpose exactly, compared tile by
/// tile as [`mirror_upper`] copies.
pub(crate) fn is_symmetric(h: &[f64], n: usize) -> bool {
    (0..n).step_by(TILE).all(|i0| {
        (0..=i0).step_by(TILE).all(|j0| {
            (i0..(i0 + TILE).min(n))
                .all(|i| (j0..(j0 + TILE).min(i)).all(|j| h[i * n + j] == h[j * n + i]))
        })
    })
}

/// Side of the tiles [`mirror_upper`] and [`is_symmetric`] sweep: 32 × 32 doubles read and 32
/// rows of 256 bytes written stay in the first-level cache.
const TILE: usize = 32;

/// `dst` (resized to `n × n`) takes the upper triangle of the row-major `src`, row by row; its
/// lower triangle is left as it was (whoever reads these matrices reads only the upper one).
pub(crate) fn copy_upper(dst: &mut Vec<f64>, src: &[f64], n: usize) {
    dst.resize(n * n, 0.0);
    for i in 0..n {
        dst[i * n + i..(i + 1) * n].copy_from_slice(&src[i * n + i..(i + 1) * n]);
    }
}

#[cfg(test)]
mod tests {
    use super::{copy_upper, is_symmetric, mirror_upper};

    /// Tile by tile, the same matrix as the element-by-element copy: sizes below, at and
    /// across the tile's, the upper triangle and diagonal untouched.
    #[test]
    fn the_tiled_mirror_is_the_elementwise_one() {
        for n in [0, 1, 5, 31, 32, 33, 64, 70] {
            let upper: Vec<f64> = (0..n * n)
                .map(|k| {
                    if k % n.max(1) >= k / n.max(1) {
                        k as f64 + 0.5
                    } else {
                        -1.0
                    }
                })
                .collect();
            let mut expected = upper.clone();
            for i in 0..n {
                for j in i + 1..n {
                    expected[j * n + i] = expected[i * n + j];
                }
            }
            let mut h = upper.clone();
            mirror_upper(&mut h, n);
            assert_eq!(h, expected, "n = {n}");
            assert!(
                h.iter().all(|v| *v >= 0.0),
                "n = {n}: every lower entry written"
            );
        }
    }

    /// The tiled symmetry check finds one asymmetric pair wherever it lies, and the upper
    /// copy takes exactly the upper triangle (a fresh destination keeps zeros below it).
    #[test]
    fn symmetry_check_and_upper_copy_see_every_entry() {
        for n in [2, 31, 33, 70] {
            let h: Vec<f64> = (0..n * n)
                .map(|k| ((k / n) * (k % n)) as f64 + 1.0)
                .collect();
            assert!(is_symmetric(&h, n), "n = {n}");
            for (i, j) in [(n - 1, 0), (n / 2, n / 3), (n - 1, n - 2)] {
                if i == j {
                    continue;
                }
                let mut g = h.clone();
                g[i * n + j] += 1.0;
                assert!(!is_symmetric(&g, n), "n = {n}: ({i}, {j})");
            }
            let mut dst = Vec::new();
            copy_upper(&mut dst, &h, n);
            for i in 0..n {
                for j in 0..n {
                    let want = if j >= i { h[i * n + j] } else { 0.0 };
                    assert_eq!(dst[i * n + j], want, "n = {n}: ({i}, {j})");
                }
            }
        }
    }
}
