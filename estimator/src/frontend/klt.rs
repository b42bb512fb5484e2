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
//! Sums are accumulated in eight explicit lanes (`lanes.rs`): the order of every
//! floating-point operation is fixed by the source, whatever the compiler vectorizes, so tracks
//! are bit-identical run to run.

use nalgebra::Vector2;

use super::image::Pyramid;
use super::lanes::{LANES, lane_dot, lane_sum, padded, sample_grid, template_rows, window_sums};

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frontend::ImageView;
    use crate::frontend::lanes::force_portable;

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
            force_portable(true);
            let slow = window_sums(&pyr.plane(0), x, y, side, gx, gy);
            let slow_dot = lane_dot(gx, gy);
            force_portable(false);
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
            force_portable(true);
            let slow = Template::new(&pyr, uv, 3, &params);
            force_portable(false);
            assert_eq!(bits(&fast), bits(&slow), "at ({x}, {y})");
            reused.resample(&pyr, uv, 3, &params);
            assert_eq!(bits(&fast), bits(&reused), "resampled at ({x}, {y})");
        }
    }
}
