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

use super::image::{Plane, Pyramid};

/// Lucas–Kanade settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KltParams {
    /// Half the window side: the window is `(2h+1)²` pixels (10 → 21×21).
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
    /// Per level `[T − T̄ | ∂T/∂x | ∂T/∂y]`, `n` values each.
    data: Vec<f32>,
    info: Vec<LevelInfo>,
}

impl Template {
    /// Samples the template around level-0 point `uv` of `pyramid` at levels
    /// `0..min(levels, pyramid.len())`.
    pub fn new(pyramid: &Pyramid, uv: Vector2<f64>, levels: usize, params: &KltParams) -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above). Same results either way
            // (see `window_sums`).
            return unsafe { Self::new_avx2(pyramid, uv, levels, params) };
        }
        Self::new_lanes(pyramid, uv, levels, params)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn new_avx2(pyramid: &Pyramid, uv: Vector2<f64>, levels: usize, params: &KltParams) -> Self {
        Self::new_lanes(pyramid, uv, levels, params)
    }

    #[inline(always)]
    fn new_lanes(pyramid: &Pyramid, uv: Vector2<f64>, levels: usize, params: &KltParams) -> Self {
        let h = params.half_window;
        let side = 2 * h + 1;
        let n = side * side;
        let levels = levels.min(pyramid.len()).max(1);
        let mut data = vec![0f32; 3 * n * levels];
        let mut info = Vec::with_capacity(levels);
        let ext = side + 2;
        let mut s = vec![0f32; ext * ext];
        for l in 0..levels {
            let p = to_level(uv, l);
            let img = pyramid.plane(l);
            sample_grid(
                &img,
                p.x - (h + 1) as f64,
                p.y - (h + 1) as f64,
                ext,
                ext,
                &mut s,
            );
            let block = &mut data[3 * n * l..3 * n * (l + 1)];
            let (t, g) = block.split_at_mut(n);
            let (gx, gy) = g.split_at_mut(n);
            for i in 0..side {
                let up = &s[i * ext + 1..i * ext + 1 + side];
                let mid = &s[(i + 1) * ext..(i + 1) * ext + side + 2];
                let down = &s[(i + 2) * ext + 1..(i + 2) * ext + 1 + side];
                let (tr, gxr, gyr) = (
                    &mut t[i * side..(i + 1) * side],
                    &mut gx[i * side..(i + 1) * side],
                    &mut gy[i * side..(i + 1) * side],
                );
                for j in 0..side {
                    tr[j] = mid[j + 1];
                    gxr[j] = 0.5 * (mid[j + 2] - mid[j]);
                    gyr[j] = 0.5 * (down[j] - up[j]);
                }
            }
            let sum_t = lane_sum(t, |_| 1.0);
            let mean = sum_t / n as f32;
            for v in t.iter_mut() {
                *v -= mean;
            }
            let var = lane_dot(t, t) / n as f32;
            let (a, b, c) = (lane_dot(gx, gx), lane_dot(gx, gy), lane_dot(gy, gy));
            let sum_g = [lane_sum(gx, |_| 1.0), lane_sum(gy, |_| 1.0)];
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
        Self {
            half_window: h,
            data,
            info,
        }
    }

    /// A template of the finest level only (for refinement against a fixed reference).
    pub fn finest(&self) -> Template {
        let n = (2 * self.half_window + 1).pow(2);
        Template {
            half_window: self.half_window,
            data: self.data[..3 * n].to_vec(),
            info: self.info[..1].to_vec(),
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

/// Level `l` coordinates → level 0.
pub fn from_level(uv: Vector2<f64>, l: usize) -> Vector2<f64> {
    uv * (1u32 << l) as f64
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
    let top = top_level.min(template.levels() - 1).min(target.len() - 1);
    let mut q = to_level(guess, top);
    for l in (0..=top).rev() {
        let info = template.info[l];
        let img = target.plane(l);
        if info.valid {
            let block = &template.data[3 * n * l..3 * n * (l + 1)];
            let (gx, gy) = (&block[n..2 * n], &block[2 * n..]);
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
        && q.x <= (img.width - 1) as f64 - m
        && q.y <= (img.height - 1) as f64 - m)
    {
        return Err(TrackFailure::OutOfImage);
    }
    Ok(q)
}

/// Normalized cross-correlation of the template's finest patch with the window of `target`'s
/// level 0 centred at `uv` (1 = identical up to gain and offset).
pub fn ncc(template: &Template, target: &Pyramid, uv: Vector2<f64>) -> f32 {
    let h = template.half_window;
    let side = 2 * h + 1;
    let n = side * side;
    let info = template.info[0];
    let t = &template.data[..n];
    let mut s = vec![0f32; n];
    sample_grid(
        &target.plane(0),
        uv.x - h as f64,
        uv.y - h as f64,
        side,
        side,
        &mut s,
    );
    let mean = lane_sum(&s, |_| 1.0) / n as f32;
    let var = lane_dot(&s, &s) / n as f32 - mean * mean;
    if var <= 1e-6 || info.sigma <= 1e-6 {
        return 0.0;
    }
    // Σ (T − T̄)(I − Ī) = Σ (T − T̄) I, since Σ (T − T̄) = 0.
    lane_dot(t, &s) / (n as f32 * info.sigma * var.sqrt())
}

/// `[Σ I, Σ I², Σ gx·I, Σ gy·I]` over the `side × side` window with top-left sample at `(x, y)`.
///
/// On x86-64 with AVX2 the same source is compiled for 256-bit registers. Both builds perform
/// the same IEEE operations in the same order per lane (no fused multiply–adds), so the results
/// are bit-identical whichever runs.
fn window_sums(img: &Plane<'_>, x: f64, y: f64, side: usize, gx: &[f32], gy: &[f32]) -> [f32; 4] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        return unsafe { window_sums_avx2(img, x, y, side, gx, gy) };
    }
    window_sums_lanes(img, x, y, side, gx, gy)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn window_sums_avx2(
    img: &Plane<'_>,
    x: f64,
    y: f64,
    side: usize,
    gx: &[f32],
    gy: &[f32],
) -> [f32; 4] {
    window_sums_lanes(img, x, y, side, gx, gy)
}

/// The portable body of [`window_sums`]: bilinear, one pass, eight lanes per row; replicated
/// border near the edges.
#[inline(always)]
fn window_sums_lanes(
    img: &Plane<'_>,
    x: f64,
    y: f64,
    side: usize,
    gx: &[f32],
    gy: &[f32],
) -> [f32; 4] {
    let (fx0, fy0) = (x.floor(), y.floor());
    let (ix, iy) = (fx0 as i64, fy0 as i64);
    let (w, h) = (img.width as i64, img.height as i64);
    if !(ix >= 0 && iy >= 0 && ix + (side as i64) < w && iy + (side as i64) < h) {
        let mut s = vec![0f32; side * side];
        sample_grid(img, x, y, side, side, &mut s);
        return [
            lane_sum(&s, |_| 1.0),
            lane_dot(&s, &s),
            lane_dot(gx, &s),
            lane_dot(gy, &s),
        ];
    }
    let (fx, fy) = ((x - fx0) as f32, (y - fy0) as f32);
    let (w00, w01, w10, w11) = (
        (1.0 - fx) * (1.0 - fy),
        fx * (1.0 - fy),
        (1.0 - fx) * fy,
        fx * fy,
    );
    let (ix, iy, wu) = (ix as usize, iy as usize, w as usize);
    let data = &img.data;
    let mut acc = [[0f32; LANES]; 4];
    let mut tail = [0f32; 4];
    let full = side / LANES * LANES;
    for r in 0..side {
        let a = &data[(iy + r) * wu + ix..(iy + r) * wu + ix + side + 1];
        let b = &data[(iy + r + 1) * wu + ix..(iy + r + 1) * wu + ix + side + 1];
        let (gxr, gyr) = (&gx[r * side..(r + 1) * side], &gy[r * side..(r + 1) * side]);
        let (a0, a1, b0, b1) = (&a[..full], &a[1..full + 1], &b[..full], &b[1..full + 1]);
        let rows = a0
            .chunks_exact(LANES)
            .zip(a1.chunks_exact(LANES))
            .zip(b0.chunks_exact(LANES).zip(b1.chunks_exact(LANES)))
            .zip(
                gxr[..full]
                    .chunks_exact(LANES)
                    .zip(gyr[..full].chunks_exact(LANES)),
            );
        for (((a0, a1), (b0, b1)), (g0, g1)) in rows {
            for k in 0..LANES {
                let v = w00 * a0[k] + w01 * a1[k] + w10 * b0[k] + w11 * b1[k];
                acc[0][k] += v;
                acc[1][k] += v * v;
                acc[2][k] += g0[k] * v;
                acc[3][k] += g1[k] * v;
            }
        }
        for j in full..side {
            let v = w00 * a[j] + w01 * a[j + 1] + w10 * b[j] + w11 * b[j + 1];
            tail[0] += v;
            tail[1] += v * v;
            tail[2] += gxr[j] * v;
            tail[3] += gyr[j] * v;
        }
    }
    [
        reduce(acc[0]) + tail[0],
        reduce(acc[1]) + tail[1],
        reduce(acc[2]) + tail[2],
        reduce(acc[3]) + tail[3],
    ]
}

/// Σ f(i)·x_i over eight fixed lanes (f is a per-element weight, usually 1).
#[inline(always)]
fn lane_sum(x: &[f32], f: impl Fn(usize) -> f32) -> f32 {
    let mut acc = [0f32; LANES];
    let chunks = x.len() / LANES;
    for c in 0..chunks {
        for k in 0..LANES {
            acc[k] += x[c * LANES + k] * f(c * LANES + k);
        }
    }
    let mut tail = 0f32;
    for (i, v) in x.iter().enumerate().skip(chunks * LANES) {
        tail += v * f(i);
    }
    reduce(acc) + tail
}

/// Σ x_i·y_i over eight fixed lanes.
#[inline(always)]
fn lane_dot(x: &[f32], y: &[f32]) -> f32 {
    debug_assert_eq!(x.len(), y.len());
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
    let wu = w as usize;
    if ix >= 0 && iy >= 0 && ix + (cols as i64) < w && iy + (rows as i64) < h {
        let (ix, iy) = (ix as usize, iy as usize);
        for (r, o) in out.chunks_exact_mut(cols).take(rows).enumerate() {
            let a = &data[(iy + r) * wu + ix..(iy + r) * wu + ix + cols + 1];
            let b = &data[(iy + r + 1) * wu + ix..(iy + r + 1) * wu + ix + cols + 1];
            for j in 0..cols {
                o[j] = w00 * a[j] + w01 * a[j + 1] + w10 * b[j] + w11 * b[j + 1];
            }
        }
    } else {
        let px = |xx: i64, yy: i64| data[(yy.clamp(0, h - 1) * w + xx.clamp(0, w - 1)) as usize];
        for r in 0..rows {
            let yy = iy + r as i64;
            for j in 0..cols {
                let xx = ix + j as i64;
                out[r * cols + j] = w00 * px(xx, yy)
                    + w01 * px(xx + 1, yy)
                    + w10 * px(xx, yy + 1)
                    + w11 * px(xx + 1, yy + 1);
            }
        }
    }
}
