//! Pyramidal Lucas–Kanade tracking of one point (inverse compositional, translation only).
//!
//! A [`Template`] holds, per pyramid level, the patch around a point of the *reference* image:
//! its zero-mean grey levels, their gradients and the inverse of the 2×2 Gauss–Newton matrix.
//! Because the warp is a pure translation, every sample of a patch shares the same bilinear
//! weights, so a patch is four multiply–adds per pixel. [`track`] moves the point through the
//! *target* pyramid from the coarsest level down, iterating `q ← q − H⁻¹ Σ ∇T (I(x + q) − T(x))`
//! at each level. With `normalize` the target patch is matched up to gain and offset (the
//! residual is `σ_T/σ_I · (I − Ī) − (T − T̄)`), so an exposure change does not break tracks.
//!
//! Coordinates: level-0 pixels in the OpenCV convention (pixel centres at integers). Pyramid
//! level `l` keeps every `2^l`-th filtered pixel, so level-0 `u` is `u / 2^l` on level `l`.
//!
//! Sums are accumulated in eight explicit lanes: the order of every floating-point operation is
//! fixed by the source, whatever the compiler vectorizes, so tracks are bit-identical run to run.

use nalgebra::Vector2;

use super::image::{PLANE_BORDER, Plane, Pyramid};

/// Lucas–Kanade settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KltParams {
    /// Half the window side: the window is `(2h+1)²` pixels (10 → 21×21); at most 31.
    pub half_window: usize,
    /// Iteration cap per level.
    pub max_iterations: usize,
    /// Stop a level when the update is shorter than this (px of that level).
    pub epsilon_px: f64,
    /// Smallest accepted mean minimum eigenvalue of the window's structure tensor
    /// (grey levels² per px², per pixel); weaker windows are not trackable.
    pub min_eigen: f64,
    /// Match up to gain and offset (zero-mean, variance-scaled residual).
    pub normalize: bool,
}

impl Default for KltParams {
    fn default() -> Self {
        Self {
            half_window: 10,
            max_iterations: 30,
            epsilon_px: 0.01,
            min_eigen: 1.0,
            normalize: true,
        }
    }
}

const LANES: usize = 8;

/// Per-level constants of a template.
#[derive(Clone, Copy, Debug, Default)]
struct LevelInfo {
    /// Inverse Gauss–Newton matrix `[a, b, c]` of `[[a, b], [b, c]]`.
    h_inv: [f32; 3],
    /// `Σ ∇T`.
    sum_g: [f32; 2],
    /// `Σ ∇T (T − T̄)`.
    sum_g_t: [f32; 2],
    /// Standard deviation of the template's grey levels.
    sigma: f32,
    /// Mean of the template's grey levels.
    mean: f32,
    /// Trackable (enough structure) at this level.
    valid: bool,
}

/// The patches around one point of a reference pyramid, at levels `0..levels`.
#[derive(Clone, Debug)]
pub struct Template {
    half_window: usize,
    /// Per level `[T − T̄ | ∂T/∂x | ∂T/∂y]`, each `side` rows of `padded(side)` values (the
    /// padding is zero, so every row is a whole number of eight-value lanes).
    data: Vec<f32>,
    info: Vec<LevelInfo>,
    /// Scratch: the sampled grid of the level being built.
    grid: Vec<f32>,
}

impl Template {
    /// Samples the template around level-0 point `uv` of `pyramid` at levels
    /// `0..min(levels, pyramid.len())`.
    pub fn new(pyramid: &Pyramid, uv: Vector2<f64>, levels: usize, params: &KltParams) -> Self {
        let mut template = Self {
            half_window: params.half_window,
            data: Vec::new(),
            info: Vec::new(),
            grid: Vec::new(),
        };
        template.resample(pyramid, uv, levels, params);
        template
    }

    /// [`Template::new`] into this template's buffers (no allocation once they are large
    /// enough).
    pub fn resample(
        &mut self,
        pyramid: &Pyramid,
        uv: Vector2<f64>,
        levels: usize,
        params: &KltParams,
    ) {
        assert!(
            params.half_window <= 31,
            "KLT windows are at most 63 px (half_window ≤ 31)"
        );
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above). Same results either way
            // (see `window_sums`).
            return unsafe { self.resample_avx2(pyramid, uv, levels, params) };
        }
        self.resample_lanes(pyramid, uv, levels, params)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn resample_avx2(
        &mut self,
        pyramid: &Pyramid,
        uv: Vector2<f64>,
        levels: usize,
        params: &KltParams,
    ) {
        self.resample_lanes(pyramid, uv, levels, params)
    }

    #[inline(always)]
    fn resample_lanes(
        &mut self,
        pyramid: &Pyramid,
        uv: Vector2<f64>,
        levels: usize,
        params: &KltParams,
    ) {
        let h = params.half_window;
        let side = 2 * h + 1;
        let pw = padded(side);
        let n = side * side;
        let np = side * pw;
        let levels = levels.min(pyramid.len()).max(1);
        self.half_window = h;
        // Every value, padding included, is written below: no clearing needed.
        self.data.resize(3 * np * levels, 0.0);
        self.info.clear();
        let (data, info) = (&mut self.data, &mut self.info);
        let mut mask = [0f32; 64];
        mask[..side].fill(1.0);
        // Sampled grid: the window and one more pixel on each side (for the central
        // differences), in whole lanes.
        let (sw, rows) = (pw + LANES, side + 2);
        // Every value is written by `sample_grid`: no clearing needed.
        self.grid.resize(sw * rows, 0.0);
        let s = &mut self.grid[..];
        for l in 0..levels {
            let p = to_level(uv, l);
            let img = pyramid.plane(l);
            sample_grid(
                &img,
                p.x - (h + 1) as f64,
                p.y - (h + 1) as f64,
                sw,
                rows,
                s,
            );
            let block = &mut data[3 * np * l..3 * np * (l + 1)];
            let (t, g) = block.split_at_mut(np);
            let (gx, gy) = g.split_at_mut(np);
            template_rows(s, sw, side, pw, &mask[..pw], t, gx, gy);
            let sum_t = lane_sum(t);
            let mean = sum_t / n as f32;
            for row in t.chunks_exact_mut(pw) {
                for v in &mut row[..side] {
                    *v -= mean;
                }
            }
            let var = lane_dot(t, t) / n as f32;
            let (a, b, c) = (lane_dot(gx, gx), lane_dot(gx, gy), lane_dot(gy, gy));
            let sum_g = [lane_sum(gx), lane_sum(gy)];
            let sum_g_t = [lane_dot(gx, t), lane_dot(gy, t)];
            let det = a * c - b * b;
            let tr = a + c;
            let min_eig = 0.5 * (tr - ((a - c) * (a - c) + 4.0 * b * b).sqrt());
            // The structure threshold applies to the finest level; coarser levels (smoothed,
            // so weaker) only need a well-conditioned system.
            let floor = if l == 0 { params.min_eigen } else { 1e-3 };
            let valid = det > 0.0 && (min_eig as f64) / (n as f64) >= floor;
            let h_inv = if valid {
                [c / det, -b / det, a / det]
            } else {
                [0.0; 3]
            };
            info.push(LevelInfo {
                h_inv,
                sum_g,
                sum_g_t,
                sigma: var.max(0.0).sqrt(),
                mean,
                valid,
            });
        }
    }

    /// Levels held.
    pub fn levels(&self) -> usize {
        self.info.len()
    }

    /// Whether the finest level has enough structure to be tracked.
    pub fn is_trackable(&self) -> bool {
        self.info.first().is_some_and(|i| i.valid)
    }
}

/// Level-0 coordinates → level `l`.
pub fn to_level(uv: Vector2<f64>, l: usize) -> Vector2<f64> {
    uv / (1u32 << l) as f64
}

/// Why a point was not tracked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrackFailure {
    /// The template has too little structure at the finest level.
    Untrackable,
    /// The point left the image, or its final window is not wholly inside it.
    OutOfImage,
    /// The target patch is flat (no contrast to match against).
    FlatTarget,
    /// An iterate became non-finite.
    Diverged,
}

/// Tracks the template's point into `target`, starting from the level-0 guess `guess`, from
/// level `min(top_level, levels − 1)` down to 0. Returns the level-0 position.
///
/// Levels above 0 stop at 5× `epsilon_px` (in their own pixels): the next finer level refines
/// the position anyway.
pub fn track(
    template: &Template,
    target: &Pyramid,
    guess: Vector2<f64>,
    top_level: usize,
    params: &KltParams,
) -> Result<Vector2<f64>, TrackFailure> {
    if !template.is_trackable() {
        return Err(TrackFailure::Untrackable);
    }
    let h = template.half_window;
    let side = 2 * h + 1;
    let n = side * side;
    let np = side * padded(side);
    let top = top_level.min(template.levels() - 1).min(target.len() - 1);
    let mut q = to_level(guess, top);
    for l in (0..=top).rev() {
        let info = template.info[l];
        let img = target.plane(l);
        if info.valid {
            let block = &template.data[3 * np * l..3 * np * (l + 1)];
            let (gx, gy) = (&block[np..2 * np], &block[2 * np..]);
            let eps = if l == 0 {
                params.epsilon_px
            } else {
                5.0 * params.epsilon_px
            };
            let eps2 = (eps * eps) as f32;
            for _ in 0..params.max_iterations {
                let (w, hgt) = (img.width as f64, img.height as f64);
                if !(q.x > -1.0 && q.y > -1.0 && q.x < w && q.y < hgt) {
                    return Err(TrackFailure::OutOfImage);
                }
                let [sum_i, sum_ii, sgx, sgy] =
                    window_sums(&img, q.x - h as f64, q.y - h as f64, side, gx, gy);
                let (bx, by) = if params.normalize {
                    let mean_i = sum_i / n as f32;
                    let var_i = sum_ii / n as f32 - mean_i * mean_i;
                    if var_i <= 1e-6 || info.sigma <= 1e-6 {
                        return Err(TrackFailure::FlatTarget);
                    }
                    let gain = info.sigma / var_i.sqrt();
                    (
                        gain * (sgx - mean_i * info.sum_g[0]) - info.sum_g_t[0],
                        gain * (sgy - mean_i * info.sum_g[1]) - info.sum_g_t[1],
                    )
                } else {
                    // r = I − T = I − (T − T̄) − T̄.
                    (
                        sgx - info.sum_g_t[0] - info.mean * info.sum_g[0],
                        sgy - info.sum_g_t[1] - info.mean * info.sum_g[1],
                    )
                };
                let [a, b, c] = info.h_inv;
                let dx = a * bx + b * by;
                let dy = b * bx + c * by;
                if !(dx.is_finite() && dy.is_finite()) {
                    return Err(TrackFailure::Diverged);
                }
                q.x -= dx as f64;
                q.y -= dy as f64;
                if dx * dx + dy * dy < eps2 {
                    break;
                }
            }
        }
        if l > 0 {
            q *= 2.0;
        }
    }
    // The final window must lie inside the image: replicated border pixels bias the match.
    let img = target.level(0);
    let m = h as f64;
    if !(q.x >= m
        && q.y >= m
        && q.x <= (img.width() - 1) as f64 - m
        && q.y <= (img.height() - 1) as f64 - m)
    {
        return Err(TrackFailure::OutOfImage);
    }
    Ok(q)
}

/// Template rows from the sampled grid `s` (`sw` columns, `side + 2` rows): grey levels and
/// central-difference gradients of the `side × side` window, `pw` values per row, the padding
/// columns zero (`mask`).
#[allow(clippy::too_many_arguments)]
fn template_rows(
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
                let load = |i: usize| {
                    _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(
                        p.add(i) as *const __m128i
                    )))
                };
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
fn window_sums(img: &Plane<'_>, x: f64, y: f64, side: usize, gx: &[f32], gy: &[f32]) -> [f32; 4] {
    window_sums_lanes(img, x, y, side, gx, gy)
}

/// Row length of a padded window: the side rounded up to whole eight-value lanes.
fn padded(side: usize) -> usize {
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
                // Eight grey levels → eight exact f32.
                let load = |i: usize| {
                    _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(
                        p.add(i) as *const __m128i
                    )))
                };
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
fn lane_sum(x: &[f32]) -> f32 {
    static ONES: [f32; 64 * 64] = [1.0; 64 * 64];
    lane_dot(x, &ONES[..x.len()])
}

/// Σ x_i·y_i over eight fixed lanes (`acc[i mod 8] += x_i·y_i`, then [`reduce`]); AVX when
/// present, with the same operations per lane.
#[inline(always)]
fn lane_dot(x: &[f32], y: &[f32]) -> f32 {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frontend::ImageView;

    /// The vectorized window sums equal the portable ones bit for bit.
    #[test]
    fn vectorized_and_portable_window_sums_are_identical() {
        let (w, h) = (96u32, 80u32);
        let data: Vec<u8> = (0..w * h)
            .map(|i| ((i * 2_654_435_761u32) >> 24) as u8)
            .collect();
        let pyr = Pyramid::build(&ImageView::packed(w, h, &data).unwrap(), 0);
        let params = KltParams::default();
        let t = Template::new(&pyr, Vector2::new(40.3, 37.6), 1, &params);
        let side = 2 * params.half_window + 1;
        let np = side * padded(side);
        let (gx, gy) = (&t.data[np..2 * np], &t.data[2 * np..3 * np]);
        for (x, y) in [(20.25, 18.5), (31.7, 40.05), (50.0, 30.99)] {
            let fast = window_sums(&pyr.plane(0), x, y, side, gx, gy);
            let fast_dot = lane_dot(gx, gy);
            PORTABLE.with(|p| p.set(true));
            let slow = window_sums(&pyr.plane(0), x, y, side, gx, gy);
            let slow_dot = lane_dot(gx, gy);
            PORTABLE.with(|p| p.set(false));
            assert_eq!(
                fast.map(f32::to_bits),
                slow.map(f32::to_bits),
                "at ({x}, {y})"
            );
            assert_eq!(fast_dot.to_bits(), slow_dot.to_bits());
        }
    }

    /// Templates built by the vectorized sampling and gradients equal the portable ones bit for
    /// bit, at every level, and resampling into used buffers equals building afresh.
    #[test]
    fn vectorized_and_portable_templates_are_identical() {
        let (w, h) = (160u32, 120u32);
        let data: Vec<u8> = (0..w * h)
            .map(|i| ((i * 2_654_435_761u32) >> 24) as u8)
            .collect();
        let pyr = Pyramid::build(&ImageView::packed(w, h, &data).unwrap(), 2);
        let params = KltParams::default();
        let bits = |t: &Template| -> Vec<u32> {
            let info = t.info.iter().flat_map(|i| {
                [
                    i.h_inv[0],
                    i.h_inv[1],
                    i.h_inv[2],
                    i.sum_g[0],
                    i.sum_g_t[1],
                    i.sigma,
                    i.mean,
                ]
            });
            t.data
                .iter()
                .copied()
                .chain(info)
                .map(f32::to_bits)
                .collect()
        };
        let mut reused = Template::new(&pyr, Vector2::new(80.0, 60.0), 3, &params);
        // Inside, and near the edges (the sampling's slow path).
        for (x, y) in [(60.3, 57.6), (81.71, 40.05), (12.5, 110.2), (150.9, 3.3)] {
            let uv = Vector2::new(x, y);
            let fast = Template::new(&pyr, uv, 3, &params);
            PORTABLE.with(|p| p.set(true));
            let slow = Template::new(&pyr, uv, 3, &params);
            PORTABLE.with(|p| p.set(false));
            assert_eq!(bits(&fast), bits(&slow), "at ({x}, {y})");
            reused.resample(&pyr, uv, 3, &params);
            assert_eq!(bits(&fast), bits(&reused), "resampled at ({x}, {y})");
        }
    }
}
