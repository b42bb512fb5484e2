//! Eight-lane kernels of the KLT tracker: bilinear grid sampling of a bordered pyramid level,
//! template rows (grey levels and central-difference gradients), window sums against a
//! template, and lane sums and dot products.
//!
//! Every sum is accumulated in eight explicit lanes, so the order of the floating-point
//! operations is fixed by the source; the AVX/AVX2 paths perform the same IEEE operations in the
//! same order (multiplies and adds, no fused multiply–add), so results are bit-identical whichever
//! runs. Grey levels are 8-bit and converted to `f32` exactly as they are loaded.

use super::image::{PLANE_BORDER, Plane};

/// Lanes of every sum.
pub(super) const LANES: usize = 8;

/// Template rows from the sampled grid `s` (`sw` columns, `side + 2` rows): grey levels and
/// central-difference gradients of the `side × side` window, `pw` values per row, the padding
/// columns zero (`mask`).
#[allow(clippy::too_many_arguments)]
pub(super) fn template_rows(
    s: &[f32],
    sw: usize,
    side: usize,
    pw: usize,
    mask: &[f32],
    t: &mut [f32],
    gx: &mut [f32],
    gy: &mut [f32],
) {
    assert!(s.len() >= sw * (side + 2) && sw >= pw + 2 && mask.len() >= pw);
    assert!(t.len() >= side * pw && gx.len() >= side * pw && gy.len() >= side * pw);
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx") && !portable_only() {
        // SAFETY: AVX is present (checked); every access is in bounds (asserted above).
        unsafe { template_rows_avx(s, sw, side, pw, mask, t, gx, gy) };
        return;
    }
    for i in 0..side {
        let (up, mid, down) = (&s[i * sw + 1..], &s[(i + 1) * sw..], &s[(i + 2) * sw + 1..]);
        for j in 0..pw {
            let k = i * pw + j;
            t[k] = mid[j + 1] * mask[j];
            gx[k] = 0.5 * (mid[j + 2] - mid[j]) * mask[j];
            gy[k] = 0.5 * (down[j] - up[j]) * mask[j];
        }
    }
}

/// [`template_rows`] in AVX registers: the same operations in the same order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[allow(clippy::too_many_arguments)]
unsafe fn template_rows_avx(
    s: &[f32],
    sw: usize,
    side: usize,
    pw: usize,
    mask: &[f32],
    t: &mut [f32],
    gx: &mut [f32],
    gy: &mut [f32],
) {
    use std::arch::x86_64::*;
    let half = _mm256_set1_ps(0.5);
    let sp = s.as_ptr();
    for i in 0..side {
        for c in (0..pw).step_by(LANES) {
            // SAFETY: in bounds by the caller's assertions.
            unsafe {
                let m = _mm256_loadu_ps(mask.as_ptr().add(c));
                let mid = sp.add((i + 1) * sw + c);
                let (m0, m1, m2) = (
                    _mm256_loadu_ps(mid),
                    _mm256_loadu_ps(mid.add(1)),
                    _mm256_loadu_ps(mid.add(2)),
                );
                let u = _mm256_loadu_ps(sp.add(i * sw + 1 + c));
                let d = _mm256_loadu_ps(sp.add((i + 2) * sw + 1 + c));
                let k = i * pw + c;
                _mm256_storeu_ps(t.as_mut_ptr().add(k), _mm256_mul_ps(m1, m));
                let g = _mm256_mul_ps(_mm256_mul_ps(half, _mm256_sub_ps(m2, m0)), m);
                _mm256_storeu_ps(gx.as_mut_ptr().add(k), g);
                let g = _mm256_mul_ps(_mm256_mul_ps(half, _mm256_sub_ps(d, u)), m);
                _mm256_storeu_ps(gy.as_mut_ptr().add(k), g);
            }
        }
    }
}

/// Eight grey levels at `p` as eight exact `f32` (one 8-byte load).
///
/// # Safety
/// The CPU supports AVX2 and `p..p + 8` is readable.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn load_u8x8(p: *const u8) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    // SAFETY: by the caller's contract.
    unsafe { _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(p as *const __m128i))) }
}

/// Bilinear rows of [`sample_grid`]'s fast path in AVX2 registers, `cols` a multiple of eight:
/// the same operations in the same order as the portable loop.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bilinear_rows_avx2(
    data: &[u8],
    stride: usize,
    origin: usize,
    cols: usize,
    rows: usize,
    w: [f32; 4],
    out: &mut [f32],
) {
    use std::arch::x86_64::*;
    let (w0, w1, w2, w3) = (
        _mm256_set1_ps(w[0]),
        _mm256_set1_ps(w[1]),
        _mm256_set1_ps(w[2]),
        _mm256_set1_ps(w[3]),
    );
    let p = data.as_ptr();
    for r in 0..rows {
        let (ra, rb) = (origin + r * stride, origin + (r + 1) * stride);
        for c in (0..cols).step_by(LANES) {
            // SAFETY: in bounds by the caller's checks.
            unsafe {
                let load = |i: usize| load_u8x8(p.add(i));
                let v = _mm256_add_ps(
                    _mm256_add_ps(
                        _mm256_add_ps(
                            _mm256_mul_ps(w0, load(ra + c)),
                            _mm256_mul_ps(w1, load(ra + c + 1)),
                        ),
                        _mm256_mul_ps(w2, load(rb + c)),
                    ),
                    _mm256_mul_ps(w3, load(rb + c + 1)),
                );
                _mm256_storeu_ps(out.as_mut_ptr().add(r * cols + c), v);
            }
        }
    }
}

/// `[Σ I, Σ I², Σ gx·I, Σ gy·I]` over the `side × side` window with top-left sample at `(x, y)`.
///
/// On x86-64 with AVX the rows run through [`window_rows_avx`]: the same IEEE operations in the
/// same order per lane as the portable code, so the results are bit-identical whichever runs.
pub(super) fn window_sums(
    img: &Plane<'_>,
    x: f64,
    y: f64,
    side: usize,
    gx: &[f32],
    gy: &[f32],
) -> [f32; 4] {
    window_sums_lanes(img, x, y, side, gx, gy)
}

/// Row length of a padded window: the side rounded up to whole eight-value lanes.
pub(super) fn padded(side: usize) -> usize {
    side.div_ceil(LANES) * LANES
}

/// The body of [`window_sums`]: bilinear, one pass over padded rows (padding masked out), eight
/// lanes; replicated border near the edges.
#[inline(always)]
fn window_sums_lanes(
    img: &Plane<'_>,
    x: f64,
    y: f64,
    side: usize,
    gx: &[f32],
    gy: &[f32],
) -> [f32; 4] {
    let pw = padded(side);
    let mut mask = [0f32; 64];
    mask[..side].fill(1.0);
    let mask = &mask[..pw];
    let (fx0, fy0) = (x.floor(), y.floor());
    let (ix, iy) = (fx0 as i64, fy0 as i64);
    let (w, h) = (img.width as i64, img.height as i64);
    let bd = PLANE_BORDER as i64;
    let mut acc = [[0f32; LANES]; 4];
    if !(ix >= -bd && iy >= -bd && ix + (pw as i64) < w + bd && iy + (side as i64) < h + bd) {
        let mut buf = [0f32; 64 * 64];
        let s = &mut buf[..side * pw];
        sample_grid(img, x, y, pw, side, s);
        for r in 0..side {
            for c in (0..pw).step_by(LANES) {
                let k = r * pw + c;
                let v = lane(&s[k..]);
                value_lane(
                    v,
                    lane(&mask[c..]),
                    lane(&gx[k..]),
                    lane(&gy[k..]),
                    &mut acc,
                );
            }
        }
    } else {
        let (fx, fy) = ((x - fx0) as f32, (y - fy0) as f32);
        let (w00, w01, w10, w11) = (
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        );
        let data = img.data;
        let stride = img.stride;
        let origin = img.index(ix as isize, iy as isize);
        let wts = [w00, w01, w10, w11];
        // The fast-path condition keeps every read inside the bordered plane.
        assert!(origin + side * stride + pw < data.len());
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && !portable_only() {
            // SAFETY: AVX2 is present (checked) and every load is in bounds (asserted above;
            // `mask`, `gx`, `gy` hold `pw` and `side × pw` values).
            acc = unsafe { window_rows_avx(data, stride, origin, side, pw, mask, gx, gy, wts) };
            return [
                reduce(acc[0]),
                reduce(acc[1]),
                reduce(acc[2]),
                reduce(acc[3]),
            ];
        }
        for r in 0..side {
            let a = &data[origin + r * stride..origin + r * stride + pw + 1];
            let b = &data[origin + (r + 1) * stride..origin + (r + 1) * stride + pw + 1];
            for c in (0..pw).step_by(LANES) {
                let k = r * pw + c;
                bilinear_lane(
                    byte_lane(&a[c..]),
                    byte_lane(&a[c + 1..]),
                    byte_lane(&b[c..]),
                    byte_lane(&b[c + 1..]),
                    lane(&mask[c..]),
                    lane(&gx[k..]),
                    lane(&gy[k..]),
                    wts,
                    &mut acc,
                );
            }
        }
    }
    [
        reduce(acc[0]),
        reduce(acc[1]),
        reduce(acc[2]),
        reduce(acc[3]),
    ]
}

/// [`bilinear_lane`] over the window's rows with AVX registers: the same IEEE operations in the
/// same order per lane (multiplies and adds, no fused multiply–add), so bit-identical results.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
unsafe fn window_rows_avx(
    data: &[u8],
    stride: usize,
    origin: usize,
    side: usize,
    pw: usize,
    mask: &[f32],
    gx: &[f32],
    gy: &[f32],
    w: [f32; 4],
) -> [[f32; LANES]; 4] {
    use std::arch::x86_64::*;
    let (w0, w1, w2, w3) = (
        _mm256_set1_ps(w[0]),
        _mm256_set1_ps(w[1]),
        _mm256_set1_ps(w[2]),
        _mm256_set1_ps(w[3]),
    );
    let (mut s0, mut s1, mut s2, mut s3) = (
        _mm256_setzero_ps(),
        _mm256_setzero_ps(),
        _mm256_setzero_ps(),
        _mm256_setzero_ps(),
    );
    let p = data.as_ptr();
    for r in 0..side {
        let ra = origin + r * stride;
        let rb = ra + stride;
        for c in (0..pw).step_by(LANES) {
            // SAFETY: in bounds by the caller's contract.
            unsafe {
                let load = |i: usize| load_u8x8(p.add(i));
                let a0 = load(ra + c);
                let a1 = load(ra + c + 1);
                let b0 = load(rb + c);
                let b1 = load(rb + c + 1);
                let v = _mm256_add_ps(
                    _mm256_add_ps(
                        _mm256_add_ps(_mm256_mul_ps(w0, a0), _mm256_mul_ps(w1, a1)),
                        _mm256_mul_ps(w2, b0),
                    ),
                    _mm256_mul_ps(w3, b1),
                );
                let m = _mm256_loadu_ps(mask.as_ptr().add(c));
                let vm = _mm256_mul_ps(v, m);
                s0 = _mm256_add_ps(s0, vm);
                s1 = _mm256_add_ps(s1, _mm256_mul_ps(vm, vm));
                let g0 = _mm256_loadu_ps(gx.as_ptr().add(r * pw + c));
                let g1 = _mm256_loadu_ps(gy.as_ptr().add(r * pw + c));
                s2 = _mm256_add_ps(s2, _mm256_mul_ps(g0, v));
                s3 = _mm256_add_ps(s3, _mm256_mul_ps(g1, v));
            }
        }
    }
    let mut out = [[0f32; LANES]; 4];
    // SAFETY: each destination holds eight f32.
    unsafe {
        _mm256_storeu_ps(out[0].as_mut_ptr(), s0);
        _mm256_storeu_ps(out[1].as_mut_ptr(), s1);
        _mm256_storeu_ps(out[2].as_mut_ptr(), s2);
        _mm256_storeu_ps(out[3].as_mut_ptr(), s3);
    }
    out
}

/// Tests force the portable path to compare it with the vectorized one.
#[cfg(test)]
fn portable_only() -> bool {
    PORTABLE.with(|p| p.get())
}

#[cfg(not(test))]
#[inline(always)]
fn portable_only() -> bool {
    false
}

#[cfg(test)]
thread_local! {
    static PORTABLE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Makes this thread's kernels take the portable path (`true`) or the vectorized one where the
/// CPU has it (`false`), for tests that compare the two.
#[cfg(test)]
pub(super) fn force_portable(on: bool) {
    PORTABLE.with(|p| p.set(on));
}

/// The eight values of `s` from its start.
#[inline(always)]
fn lane(s: &[f32]) -> [f32; LANES] {
    s[..LANES].try_into().expect("eight values")
}

/// The first eight grey levels of `s` as `f32` (exact).
#[inline(always)]
fn byte_lane(s: &[u8]) -> [f32; LANES] {
    std::array::from_fn(|i| s[i] as f32)
}

/// Accumulates eight bilinear samples (corners `a0 a1 / b0 b1`, weights `w`) into
/// `[Σ I, Σ I², Σ gx·I, Σ gy·I]` lanes; `m` masks the padding out of the first two.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn bilinear_lane(
    a0: [f32; LANES],
    a1: [f32; LANES],
    b0: [f32; LANES],
    b1: [f32; LANES],
    m: [f32; LANES],
    g0: [f32; LANES],
    g1: [f32; LANES],
    w: [f32; 4],
    acc: &mut [[f32; LANES]; 4],
) {
    let mut v = [0f32; LANES];
    for k in 0..LANES {
        v[k] = w[0] * a0[k] + w[1] * a1[k] + w[2] * b0[k] + w[3] * b1[k];
    }
    value_lane(v, m, g0, g1, acc);
}

/// Accumulates eight sampled values (see [`bilinear_lane`]).
#[inline(always)]
fn value_lane(
    v: [f32; LANES],
    m: [f32; LANES],
    g0: [f32; LANES],
    g1: [f32; LANES],
    acc: &mut [[f32; LANES]; 4],
) {
    for k in 0..LANES {
        let vm = v[k] * m[k];
        acc[0][k] += vm;
        acc[1][k] += vm * vm;
        acc[2][k] += g0[k] * v[k];
        acc[3][k] += g1[k] * v[k];
    }
}

/// Σ x_i over eight fixed lanes (as [`lane_dot`] with ones: multiplying by one is exact).
#[inline(always)]
pub(super) fn lane_sum(x: &[f32]) -> f32 {
    static ONES: [f32; 64 * 64] = [1.0; 64 * 64];
    lane_dot(x, &ONES[..x.len()])
}

/// Σ x_i·y_i over eight fixed lanes (`acc[i mod 8] += x_i·y_i`, then [`reduce`]); AVX when
/// present, with the same operations per lane.
#[inline(always)]
pub(super) fn lane_dot(x: &[f32], y: &[f32]) -> f32 {
    assert_eq!(x.len(), y.len());
    #[cfg(target_arch = "x86_64")]
    if x.len().is_multiple_of(LANES)
        && std::arch::is_x86_feature_detected!("avx")
        && !portable_only()
    {
        // SAFETY: AVX is present (checked) and both slices hold a multiple of eight values.
        return reduce(unsafe { lane_dot_avx(x, y) });
    }
    let mut acc = [0f32; LANES];
    let (xc, yc) = (x.chunks_exact(LANES), y.chunks_exact(LANES));
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for k in 0..LANES {
            acc[k] += a[k] * b[k];
        }
    }
    let mut tail = 0f32;
    for (a, b) in xr.iter().zip(yr) {
        tail += a * b;
    }
    reduce(acc) + tail
}

/// The lanes of [`lane_dot`] with AVX registers (`x.len() == y.len()`, a multiple of eight).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn lane_dot_avx(x: &[f32], y: &[f32]) -> [f32; LANES] {
    use std::arch::x86_64::*;
    let mut acc = _mm256_setzero_ps();
    for c in (0..x.len()).step_by(LANES) {
        // SAFETY: `c + 8 ≤ len` for both slices (the caller's contract).
        unsafe {
            let a = _mm256_loadu_ps(x.as_ptr().add(c));
            let b = _mm256_loadu_ps(y.as_ptr().add(c));
            acc = _mm256_add_ps(acc, _mm256_mul_ps(a, b));
        }
    }
    let mut out = [0f32; LANES];
    // SAFETY: `out` holds eight f32.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), acc) };
    out
}

#[inline(always)]
fn reduce(a: [f32; LANES]) -> f32 {
    ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]))
}

/// Samples a `cols × rows` grid of unit spacing whose top-left sample is at `(x, y)` (level
/// pixels) by bilinear interpolation; outside the image the border is replicated.
#[inline(always)]
pub(crate) fn sample_grid(
    img: &Plane<'_>,
    x: f64,
    y: f64,
    cols: usize,
    rows: usize,
    out: &mut [f32],
) {
    let (ix, iy) = (x.floor(), y.floor());
    let (fx, fy) = ((x - ix) as f32, (y - iy) as f32);
    let (w00, w01, w10, w11) = (
        (1.0 - fx) * (1.0 - fy),
        fx * (1.0 - fy),
        (1.0 - fx) * fy,
        fx * fy,
    );
    let (w, h) = (img.width as i64, img.height as i64);
    let (ix, iy) = (ix as i64, iy as i64);
    let data = &img.data;
    let bd = PLANE_BORDER as i64;
    let stride = img.stride;
    if ix >= -bd && iy >= -bd && ix + (cols as i64) < w + bd && iy + (rows as i64) < h + bd {
        let origin = img.index(ix as isize, iy as isize);
        #[cfg(target_arch = "x86_64")]
        if cols.is_multiple_of(LANES)
            && std::arch::is_x86_feature_detected!("avx2")
            && !portable_only()
        {
            // The last eight-byte load ends at byte `cols` of row `rows` (as the portable loop).
            assert!(origin + rows * stride + cols < data.len() && out.len() >= rows * cols);
            // SAFETY: AVX2 is present (checked); every access is in bounds (asserted).
            unsafe {
                bilinear_rows_avx2(data, stride, origin, cols, rows, [w00, w01, w10, w11], out)
            };
            return;
        }
        for (r, o) in out.chunks_exact_mut(cols).take(rows).enumerate() {
            let a = &data[origin + r * stride..origin + r * stride + cols + 1];
            let b = &data[origin + (r + 1) * stride..origin + (r + 1) * stride + cols + 1];
            for j in 0..cols {
                o[j] = w00 * a[j] as f32
                    + w01 * a[j + 1] as f32
                    + w10 * b[j] as f32
                    + w11 * b[j + 1] as f32;
            }
        }
    } else {
        // Far outside: clamped column indices computed once, then the same arithmetic per row
        // (the replicated border holds the same values).
        let mut xs = [0usize; 80];
        let xs = &mut xs[..cols + 1];
        for (j, x) in xs.iter_mut().enumerate() {
            *x = img.index((ix + j as i64).clamp(0, w - 1) as isize, 0) - img.index(0, 0);
        }
        let row0 = img.index(0, 0);
        for r in 0..rows {
            let y0 = row0 + (iy + r as i64).clamp(0, h - 1) as usize * stride;
            let y1 = row0 + (iy + r as i64 + 1).clamp(0, h - 1) as usize * stride;
            let o = &mut out[r * cols..(r + 1) * cols];
            for j in 0..cols {
                o[j] = w00 * data[y0 + xs[j]] as f32
                    + w01 * data[y0 + xs[j + 1]] as f32
                    + w10 * data[y1 + xs[j]] as f32
                    + w11 * data[y1 + xs[j + 1]] as f32;
            }
        }
    }
}
