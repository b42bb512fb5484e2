//! Shi–Tomasi corners: the minimum eigenvalue of the 3×3-summed structure tensor of Sobel
//! gradients, local maxima above a quality level, taken strongest first under a minimum
//! distance to every existing and already accepted feature, optionally capped per grid cell.
//!
//! The structure tensor is summed in exact integer arithmetic; ties between equal responses are
//! broken by pixel index, so the selection is deterministic.

use nalgebra::Vector2;

use super::image::ImageView;

/// Detection settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerParams {
    /// Keep corners whose response is at least this fraction of the image's strongest one.
    pub quality_level: f64,
    /// Smallest accepted response: mean minimum eigenvalue per pixel of the 3×3 block, in
    /// (grey level / px)² of the Sobel gradient divided by 8 (a flat or noise-only area stays
    /// below it).
    pub min_response: f64,
    /// Minimum distance between features (px).
    pub min_distance_px: f64,
    /// Pixels this close to the image border are not taken.
    pub border_px: u32,
    /// Grid `[columns, rows]`; each cell holds at most its share of the feature budget
    /// (`[1, 1]`: no bucketing).
    pub grid: [usize; 2],
}

impl Default for CornerParams {
    fn default() -> Self {
        Self {
            quality_level: 0.01,
            min_response: 4.0,
            min_distance_px: 30.0,
            border_px: 8,
            grid: [1, 1],
        }
    }
}

/// Reusable buffers for [`detect`].
#[derive(Clone, Debug, Default)]
pub struct CornerScratch {
    response: Vec<f32>,
    candidates: Vec<(f32, u32)>,
    ring: Vec<i32>,
    vsum: Vec<i32>,
    hmax: Vec<u32>,
}

/// The Shi–Tomasi response (minimum eigenvalue per pixel of the 3×3 block, Sobel gradients
/// scaled by 1/8) of every pixel; 0 on the two-pixel border.
pub fn shi_tomasi_response(img: &ImageView<'_>, out: &mut Vec<f32>) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    out.clear();
    out.resize(w * h, 0.0);
    let (mut ring, mut vsum) = (Vec::new(), Vec::new());
    response_band(img, [0, w, 0, h], out, &mut ring, &mut vsum);
}

/// Block side (px) of the detection mask: blocks wholly inside an existing feature's
/// minimum-distance disk are not evaluated.
const MASK_BLOCK: usize = 8;

/// Writes the response of pixels `[x0, x1) × [y0, y1)` (clipped to the two-pixel border) into
/// `out` (`w × h`). On x86-64 with AVX2 the same code runs on 256-bit registers: every value
/// is computed element by element, so the results are identical.
fn response_band(
    img: &ImageView<'_>,
    region: [usize; 4],
    out: &mut [f32],
    ring: &mut Vec<i32>,
    vsum: &mut Vec<i32>,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        return unsafe { response_band_avx2(img, region, out, ring, vsum) };
    }
    response_band_portable(img, region, out, ring, vsum)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn response_band_avx2(
    img: &ImageView<'_>,
    region: [usize; 4],
    out: &mut [f32],
    ring: &mut Vec<i32>,
    vsum: &mut Vec<i32>,
) {
    response_band_portable(img, region, out, ring, vsum)
}

/// The body of [`response_band`]: structure-tensor sums in exact integers, summed separably;
/// rows kept as separate `xx`, `xy`, `yy` arrays so the loops vectorize.
#[inline(always)]
fn response_band_portable(
    img: &ImageView<'_>,
    [x0, x1, y0, y1]: [usize; 4],
    out: &mut [f32],
    ring: &mut Vec<i32>,
    vsum: &mut Vec<i32>,
) {
    let (w, h) = (img.width() as usize, img.height() as usize);
    if w < 5 || h < 5 {
        return;
    }
    let (x0, x1) = (x0.max(2), x1.min(w - 2));
    let (y0, y1) = (y0.max(2), y1.min(h - 2));
    if x0 >= x1 || y0 >= y1 {
        return;
    }
    // Products on columns [c0, c0 + n) = [x0 − 1, x1 + 1) for three rows (a ring of slots,
    // each slot `[xx | xy | yy]`), then their vertical sums.
    let c0 = x0 - 1;
    let n = x1 + 1 - c0;
    ring.clear();
    ring.resize(9 * n, 0);
    vsum.clear();
    vsum.resize(3 * n, 0);
    let products = |y: usize, slot: &mut [i32]| {
        let (r0, r1, r2) = (img.row(y - 1), img.row(y), img.row(y + 1));
        let (xx, rest) = slot.split_at_mut(n);
        let (xy, yy) = rest.split_at_mut(n);
        for i in 0..n {
            let (gx, gy) = sobel(r0, r1, r2, c0 + i);
            xx[i] = gx * gx;
            xy[i] = gx * gy;
            yy[i] = gy * gy;
        }
    };
    products(y0 - 1, &mut ring[0..3 * n]);
    products(y0, &mut ring[3 * n..6 * n]);
    for y in y0..y1 {
        let slot = (y + 1 - (y0 - 1)) % 3;
        products(y + 1, &mut ring[slot * 3 * n..(slot + 1) * 3 * n]);
        let (a, rest) = ring.split_at(3 * n);
        let (b, c) = rest.split_at(3 * n);
        for ((v, (p, q)), r) in vsum.iter_mut().zip(a.iter().zip(b)).zip(c) {
            *v = p + q + r;
        }
        let (sxx, rest) = vsum.split_at(n);
        let (sxy, syy) = rest.split_at(n);
        let row = &mut out[y * w + x0..y * w + x1];
        for (k, o) in row.iter_mut().enumerate() {
            // Column x = x0 + k sits at index k + 1 of the products.
            let xx = (sxx[k] + sxx[k + 1] + sxx[k + 2]) as f32;
            let xy = (sxy[k] + sxy[k + 1] + sxy[k + 2]) as f32;
            let yy = (syy[k] + syy[k + 1] + syy[k + 2]) as f32;
            *o = min_eigen_response(xx, xy, yy);
        }
    }
}

/// Detects up to `count` new corners in `img`, at least `min_distance_px` from each other and
/// from every point of `existing`; strongest first. Only blocks not wholly claimed by an
/// existing feature are evaluated, and the quality level is relative to the strongest response
/// among them (as OpenCV's `goodFeaturesToTrack` with a mask).
pub fn detect(
    img: &ImageView<'_>,
    existing: &[Vector2<f64>],
    count: usize,
    params: &CornerParams,
    scratch: &mut CornerScratch,
) -> Vec<Vector2<f64>> {
    let mut found = Vec::new();
    if count == 0 {
        return found;
    }
    let (w, h) = (img.width() as usize, img.height() as usize);
    // Mask blocks wholly inside an existing feature's disk.
    let (bw, bh) = (w.div_ceil(MASK_BLOCK), h.div_ceil(MASK_BLOCK));
    let mut masked = vec![false; bw * bh];
    let r = params.min_distance_px;
    for p in existing {
        let bx0 = ((p.x - r).max(0.0) / MASK_BLOCK as f64) as usize;
        let by0 = ((p.y - r).max(0.0) / MASK_BLOCK as f64) as usize;
        let bx1 = (((p.x + r).max(0.0) / MASK_BLOCK as f64) as usize).min(bw - 1);
        let by1 = (((p.y + r).max(0.0) / MASK_BLOCK as f64) as usize).min(bh - 1);
        for by in by0..=by1 {
            for bx in bx0..=bx1 {
                let (xa, ya) = (
                    (bx * MASK_BLOCK) as f64 - 1.0,
                    (by * MASK_BLOCK) as f64 - 1.0,
                );
                let (xb, yb) = (xa + MASK_BLOCK as f64 + 1.0, ya + MASK_BLOCK as f64 + 1.0);
                let far_x = (p.x - xa).abs().max((p.x - xb).abs());
                let far_y = (p.y - ya).abs().max((p.y - yb).abs());
                if far_x * far_x + far_y * far_y < r * r {
                    masked[by * bw + bx] = true;
                }
            }
        }
    }
    scratch.response.clear();
    scratch.response.resize(w * h, 0.0);
    for by in 0..bh {
        let mut bx = 0;
        while bx < bw {
            if masked[by * bw + bx] {
                bx += 1;
                continue;
            }
            let start = bx;
            while bx < bw && !masked[by * bw + bx] {
                bx += 1;
            }
            let (x0, x1) = (start * MASK_BLOCK, (bx * MASK_BLOCK).min(w));
            let (y0, y1) = (by * MASK_BLOCK, ((by + 1) * MASK_BLOCK).min(h));
            response_band(
                img,
                [x0, x1, y0, y1],
                &mut scratch.response,
                &mut scratch.ring,
                &mut scratch.vsum,
            );
        }
    }
    let b = (params.border_px as usize).max(2);
    local_maxima(
        &scratch.response,
        w,
        h,
        b,
        params,
        &mut scratch.hmax,
        &mut scratch.candidates,
    );
    scratch
        .candidates
        .sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut occupancy = Occupancy::new(w, h, params.min_distance_px);
    let [gc, gr] = [params.grid[0].max(1), params.grid[1].max(1)];
    let total_budget = existing.len() + count;
    let cell_cap = total_budget.div_ceil(gc * gr);
    let mut cell_count = vec![0usize; gc * gr];
    let cell_of = |p: &Vector2<f64>| {
        let cx = ((p.x.max(0.0) / w as f64 * gc as f64) as usize).min(gc - 1);
        let cy = ((p.y.max(0.0) / h as f64 * gr as f64) as usize).min(gr - 1);
        cy * gc + cx
    };
    for p in existing {
        occupancy.insert(*p);
        cell_count[cell_of(p)] += 1;
    }
    for &(_, idx) in &scratch.candidates {
        if found.len() >= count {
            break;
        }
        let p = Vector2::new((idx as usize % w) as f64, (idx as usize / w) as f64);
        let cell = cell_of(&p);
        if cell_count[cell] >= cell_cap || occupancy.is_near(&p) {
            continue;
        }
        occupancy.insert(p);
        cell_count[cell] += 1;
        found.push(p);
    }
    found
}

/// [`detect`] on a coarser pyramid level (`coarse`, `2^level` times smaller than `fine`, the
/// level-0 image): distances and border scale down, and each corner found is then placed on the
/// strongest level-0 response among the `2^level × 2^level` pixels it covers (±1 px). A
/// quarter of the work per level for the same features at the scale KLT tracks them.
pub fn detect_on_level(
    coarse: &ImageView<'_>,
    level: usize,
    fine: &ImageView<'_>,
    existing: &[Vector2<f64>],
    count: usize,
    params: &CornerParams,
    scratch: &mut CornerScratch,
) -> Vec<Vector2<f64>> {
    if level == 0 {
        return detect(fine, existing, count, params, scratch);
    }
    let s = (1u32 << level) as f64;
    let scaled: Vec<Vector2<f64>> = existing.iter().map(|p| p / s).collect();
    let coarse_params = CornerParams {
        min_distance_px: params.min_distance_px / s,
        border_px: params.border_px.div_ceil(1 << level),
        ..*params
    };
    let found = detect(coarse, &scaled, count, &coarse_params, scratch);
    let (w, h) = (fine.width() as i64, fine.height() as i64);
    let b = params.border_px.max(2) as i64;
    found
        .into_iter()
        .map(|p| {
            let (cx, cy) = ((p.x * s) as i64, (p.y * s) as i64);
            let r = (1i64 << level) / 2 + 1;
            let mut best = (f32::MIN, cx, cy);
            for y in (cy - r).max(b)..=(cy + r).min(h - 1 - b) {
                for x in (cx - r).max(b)..=(cx + r).min(w - 1 - b) {
                    let v = response_at(fine, x as usize, y as usize);
                    if v > best.0 {
                        best = (v, x, y);
                    }
                }
            }
            Vector2::new(best.1 as f64, best.2 as f64)
        })
        .collect()
}

/// The Shi–Tomasi response of one pixel (same formula as [`shi_tomasi_response`]); the pixel
/// must be at least two pixels from the border.
fn response_at(img: &ImageView<'_>, x: usize, y: usize) -> f32 {
    let mut s = [0i32; 3];
    for yy in y - 1..=y + 1 {
        let (r0, r1, r2) = (img.row(yy - 1), img.row(yy), img.row(yy + 1));
        for xx in x - 1..=x + 1 {
            let (gx, gy) = sobel(r0, r1, r2, xx);
            s[0] += gx * gx;
            s[1] += gx * gy;
            s[2] += gy * gy;
        }
    }
    min_eigen_response(s[0] as f32, s[1] as f32, s[2] as f32)
}

/// Sobel gradients `(gx, gy)` at column `x` of the middle row of three.
#[inline(always)]
fn sobel(r0: &[u8], r1: &[u8], r2: &[u8], x: usize) -> (i32, i32) {
    let gx = (r0[x + 1] as i32 - r0[x - 1] as i32)
        + 2 * (r1[x + 1] as i32 - r1[x - 1] as i32)
        + (r2[x + 1] as i32 - r2[x - 1] as i32);
    let gy = (r2[x - 1] as i32 + 2 * r2[x] as i32 + r2[x + 1] as i32)
        - (r0[x - 1] as i32 + 2 * r0[x] as i32 + r0[x + 1] as i32);
    (gx, gy)
}

/// The smaller eigenvalue of the 3×3-summed structure tensor `[[xx, xy], [xy, yy]]` of Sobel
/// gradients, per pixel and in grey levels (Sobel's gain of 8 removed), never negative.
#[inline(always)]
fn min_eigen_response(xx: f32, xy: f32, yy: f32) -> f32 {
    const SCALE: f32 = 1.0 / (64.0 * 9.0);
    let d = xx - yy;
    (0.5 * ((xx + yy) - (d * d + 4.0 * xy * xy).sqrt()) * SCALE).max(0.0)
}

/// Appends to `out` every pixel (more than `border` from the edge) whose response reaches the
/// threshold (`quality_level` × the strongest response, at least `min_response`) and is the
/// maximum of its 3×3 neighbourhood (ties kept), as `(response, index)`. Responses are
/// non-negative, so their bit patterns order like the values: the maxima are separable integer
/// max filters, which vectorize (AVX2 when present; the same results either way).
fn local_maxima(
    resp: &[f32],
    w: usize,
    h: usize,
    border: usize,
    params: &CornerParams,
    hmax: &mut Vec<u32>,
    out: &mut Vec<(f32, u32)>,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        return unsafe { local_maxima_avx2(resp, w, h, border, params, hmax, out) };
    }
    local_maxima_portable(resp, w, h, border, params, hmax, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn local_maxima_avx2(
    resp: &[f32],
    w: usize,
    h: usize,
    border: usize,
    params: &CornerParams,
    hmax: &mut Vec<u32>,
    out: &mut Vec<(f32, u32)>,
) {
    local_maxima_portable(resp, w, h, border, params, hmax, out)
}

#[inline(always)]
fn local_maxima_portable(
    resp: &[f32],
    w: usize,
    h: usize,
    border: usize,
    params: &CornerParams,
    hmax: &mut Vec<u32>,
    out: &mut Vec<(f32, u32)>,
) {
    out.clear();
    if w < 3 || h < 3 {
        return;
    }
    let max = resp.iter().map(|v| v.to_bits()).fold(0u32, u32::max);
    let threshold = (params.quality_level as f32 * f32::from_bits(max))
        .max(params.min_response as f32)
        .max(f32::MIN_POSITIVE)
        .to_bits();
    hmax.clear();
    hmax.resize(w * h, 0);
    for (src, dst) in resp.chunks_exact(w).zip(hmax.chunks_exact_mut(w)) {
        for x in 1..w - 1 {
            dst[x] = src[x - 1]
                .to_bits()
                .max(src[x].to_bits())
                .max(src[x + 1].to_bits());
        }
    }
    for y in border..h.saturating_sub(border) {
        let (up, mid, down) = (
            &hmax[(y - 1) * w..y * w],
            &hmax[y * w..(y + 1) * w],
            &hmax[(y + 1) * w..(y + 2) * w],
        );
        let row = &resp[y * w..(y + 1) * w];
        for x in border..w.saturating_sub(border) {
            let v = row[x].to_bits();
            if v >= threshold && v >= up[x].max(mid[x]).max(down[x]) {
                out.push((row[x], (y * w + x) as u32));
            }
        }
    }
}

/// Points on a grid of `min_distance`-sized cells, for O(1) minimum-distance queries. Each cell
/// is a linked list through one flat array: no allocation per cell.
#[derive(Debug)]
pub(crate) struct Occupancy {
    cell: f64,
    cols: usize,
    rows: usize,
    r2: f64,
    /// First point of each cell (`u32::MAX`: empty).
    head: Vec<u32>,
    /// Next point in the same cell.
    next: Vec<u32>,
    points: Vec<Vector2<f64>>,
}

impl Occupancy {
    /// An empty grid over a `w × h` image for minimum distance `min_distance`.
    pub(crate) fn new(w: usize, h: usize, min_distance: f64) -> Self {
        let cell = min_distance.max(1.0);
        let cols = ((w as f64 / cell).ceil() as usize).max(1);
        let rows = ((h as f64 / cell).ceil() as usize).max(1);
        Self {
            cell,
            cols,
            rows,
            r2: min_distance * min_distance,
            head: vec![u32::MAX; cols * rows],
            next: Vec::new(),
            points: Vec::new(),
        }
    }

    fn cell_of(&self, p: &Vector2<f64>) -> (usize, usize) {
        let cx = ((p.x / self.cell).floor().max(0.0) as usize).min(self.cols - 1);
        let cy = ((p.y / self.cell).floor().max(0.0) as usize).min(self.rows - 1);
        (cx, cy)
    }

    /// Adds a point.
    pub(crate) fn insert(&mut self, p: Vector2<f64>) {
        let (cx, cy) = self.cell_of(&p);
        let c = cy * self.cols + cx;
        self.next.push(self.head[c]);
        self.head[c] = self.points.len() as u32;
        self.points.push(p);
    }

    /// True if a point lies closer than the minimum distance to `p`.
    pub(crate) fn is_near(&self, p: &Vector2<f64>) -> bool {
        let (cx, cy) = self.cell_of(p);
        for y in cy.saturating_sub(1)..=(cy + 1).min(self.rows - 1) {
            for x in cx.saturating_sub(1)..=(cx + 1).min(self.cols - 1) {
                let mut i = self.head[y * self.cols + x];
                while i != u32::MAX {
                    if (self.points[i as usize] - p).norm_squared() < self.r2 {
                        return true;
                    }
                    i = self.next[i as usize];
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A black image with white squares: corners at the squares' corners.
    fn squares(w: u32, h: u32, squares: &[(u32, u32, u32)]) -> Vec<u8> {
        let mut d = vec![20u8; (w * h) as usize];
        for &(x0, y0, s) in squares {
            for y in y0..y0 + s {
                for x in x0..x0 + s {
                    d[(y * w + x) as usize] = 220;
                }
            }
        }
        d
    }

    #[test]
    fn corners_of_a_square_are_found_and_flat_areas_are_not() {
        let d = squares(120, 100, &[(40, 30, 30)]);
        let img = ImageView::packed(120, 100, &d).unwrap();
        let params = CornerParams {
            min_distance_px: 10.0,
            ..Default::default()
        };
        let found = detect(&img, &[], 10, &params, &mut CornerScratch::default());
        assert_eq!(found.len(), 4, "{found:?}");
        for p in &found {
            // Corners of the square [40, 69] × [30, 59], within a pixel.
            let near_x = (p.x - 39.5).abs() <= 1.0 || (p.x - 69.5).abs() <= 1.0;
            let near_y = (p.y - 29.5).abs() <= 1.0 || (p.y - 59.5).abs() <= 1.0;
            assert!(near_x && near_y, "{p:?}");
        }
        let flat = vec![128u8; 120 * 100];
        let img = ImageView::packed(120, 100, &flat).unwrap();
        assert!(detect(&img, &[], 10, &params, &mut CornerScratch::default()).is_empty());
    }

    #[test]
    fn existing_features_claim_their_neighbourhood() {
        let d = squares(200, 100, &[(20, 30, 30), (120, 30, 30)]);
        let img = ImageView::packed(200, 100, &d).unwrap();
        let params = CornerParams {
            min_distance_px: 45.0,
            ..Default::default()
        };
        // One existing feature in the middle of the left square blocks all its corners.
        let existing = [Vector2::new(35.0, 45.0)];
        let found = detect(&img, &existing, 10, &params, &mut CornerScratch::default());
        assert!(!found.is_empty());
        for p in &found {
            assert!(p.x > 100.0, "{p:?}");
            for q in &found {
                assert!(p == q || (p - q).norm() >= 45.0);
            }
        }
    }

    #[test]
    fn grid_bucketing_spreads_features() {
        // Many squares on the left half only, one on the right.
        let mut sq: Vec<(u32, u32, u32)> = (0..4)
            .flat_map(|i| (0..3).map(move |j| (10 + 22 * i, 10 + 25 * j, 10)))
            .collect();
        sq.push((160, 40, 20));
        let d = squares(200, 100, &sq);
        let img = ImageView::packed(200, 100, &d).unwrap();
        let params = CornerParams {
            min_distance_px: 5.0,
            grid: [2, 1],
            ..Default::default()
        };
        let found = detect(&img, &[], 8, &params, &mut CornerScratch::default());
        let right = found.iter().filter(|p| p.x > 100.0).count();
        assert_eq!(found.len() - right, 4, "{found:?}");
        assert_eq!(right, 4);
    }
}
