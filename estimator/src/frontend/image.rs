//! Grey images for the front end: a borrowed view (no copy for the caller), owned pyramid
//! levels, and histogram equalization.

use thiserror::Error;

/// Why an image view could not be made.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ImageError {
    /// Width or height is zero.
    #[error("image size {width}×{height}: both must be positive")]
    Empty {
        /// Width (px).
        width: u32,
        /// Height (px).
        height: u32,
    },
    /// The stride is smaller than the width or the buffer is too short.
    #[error("image {width}×{height} with stride {stride} needs {needed} bytes, got {len}")]
    Buffer {
        /// Width (px).
        width: u32,
        /// Height (px).
        height: u32,
        /// Row stride (bytes).
        stride: usize,
        /// Bytes needed.
        needed: usize,
        /// Bytes given.
        len: usize,
    },
}

/// A borrowed 8-bit grey image: `height` rows of `width` pixels, rows `stride` bytes apart.
#[derive(Clone, Copy, Debug)]
pub struct ImageView<'a> {
    width: u32,
    height: u32,
    stride: usize,
    data: &'a [u8],
}

impl<'a> ImageView<'a> {
    /// A view of `data` (row-major, `stride ≥ width` bytes per row).
    pub fn new(width: u32, height: u32, stride: usize, data: &'a [u8]) -> Result<Self, ImageError> {
        if width == 0 || height == 0 {
            return Err(ImageError::Empty { width, height });
        }
        let needed = stride * (height as usize - 1) + width as usize;
        if stride < width as usize || data.len() < needed {
            return Err(ImageError::Buffer {
                width,
                height,
                stride,
                needed,
                len: data.len(),
            });
        }
        Ok(Self {
            width,
            height,
            stride,
            data,
        })
    }

    /// A view of a tightly packed image (`stride = width`).
    pub fn packed(width: u32, height: u32, data: &'a [u8]) -> Result<Self, ImageError> {
        Self::new(width, height, width as usize, data)
    }

    /// Width (px).
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height (px).
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Row `y` (exactly `width` bytes).
    pub fn row(&self, y: usize) -> &'a [u8] {
        let s = y * self.stride;
        &self.data[s..s + self.width as usize]
    }

    /// A tightly packed copy.
    pub fn to_owned_image(&self) -> OwnedImage {
        let mut data = Vec::with_capacity(self.width as usize * self.height as usize);
        for y in 0..self.height as usize {
            data.extend_from_slice(self.row(y));
        }
        OwnedImage {
            width: self.width,
            height: self.height,
            data,
        }
    }
}

/// A tightly packed 8-bit grey image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OwnedImage {
    /// Width (px).
    pub width: u32,
    /// Height (px).
    pub height: u32,
    /// `width × height` grey levels, row-major.
    pub data: Vec<u8>,
}

impl OwnedImage {
    /// The image as a view.
    pub fn view(&self) -> ImageView<'_> {
        ImageView {
            width: self.width,
            height: self.height,
            stride: self.width as usize,
            data: &self.data,
        }
    }

    /// Half-size image (`⌈w/2⌉ × ⌈h/2⌉`) by the 5-tap binomial filter `[1 4 6 4 1]/16` in both
    /// directions, then every second pixel (OpenCV's `pyrDown`: level-0 pixel `2x` becomes
    /// pixel `x`); the border is replicated. Exact integer arithmetic.
    pub fn half_of(src: &ImageView<'_>) -> OwnedImage {
        let mut out = OwnedImage {
            width: 0,
            height: 0,
            data: Vec::new(),
        };
        Self::half_into(src, &mut out);
        out
    }

    /// [`OwnedImage::half_of`] into an existing buffer.
    pub fn half_into(src: &ImageView<'_>, out: &mut OwnedImage) {
        Self::half_into_inline(src, out)
    }

    #[inline(always)]
    fn half_into_inline(src: &ImageView<'_>, out: &mut OwnedImage) {
        let (w, h) = (src.width.div_ceil(2), src.height.div_ceil(2));
        out.data.clear();
        out.data.resize(w as usize * h as usize, 0);
        half_rows(src, &mut out.data, w as usize, 0);
        out.width = w;
        out.height = h;
    }

    /// Global histogram equalization (for exposure changes): grey levels remapped through the
    /// normalized cumulative histogram.
    pub fn equalized(src: &ImageView<'_>) -> OwnedImage {
        let mut hist = [0u32; 256];
        for y in 0..src.height as usize {
            for &p in src.row(y) {
                hist[p as usize] += 1;
            }
        }
        let total = src.width as u64 * src.height as u64;
        let first = hist.iter().position(|&c| c > 0).unwrap_or(0);
        let c0 = hist[first] as u64;
        let mut lut = [0u8; 256];
        let mut cum = 0u64;
        for (i, &c) in hist.iter().enumerate() {
            cum += c as u64;
            lut[i] = if total > c0 {
                (((cum.saturating_sub(c0)) * 255 + (total - c0) / 2) / (total - c0)).min(255) as u8
            } else {
                i as u8
            };
        }
        let mut data = Vec::with_capacity(total as usize);
        for y in 0..src.height as usize {
            data.extend(src.row(y).iter().map(|&p| lut[p as usize]));
        }
        OwnedImage {
            width: src.width,
            height: src.height,
            data,
        }
    }
}

/// The binomial half-size kernel of [`OwnedImage::half_of`], writing output row `oy` at
/// `out[origin + oy·stride..][..⌈w/2⌉]`.
#[inline(always)]
fn half_rows(src: &ImageView<'_>, out: &mut [u8], stride: usize, origin: usize) {
    let (sw, sh) = (src.width as usize, src.height as usize);
    let (w, h) = (sw.div_ceil(2), sh.div_ceil(2));
    // Vertical pass on the rows needed, then horizontal, per output row.
    let mut col = vec![0u16; sw];
    let mut hrow = vec![0u32; sw];
    let clamp_row = |y: isize| src.row(y.clamp(0, sh as isize - 1) as usize);
    for oy in 0..h {
        let out = &mut out[origin + oy * stride..][..w];
        let y = 2 * oy as isize;
        let (r0, r1, r2, r3, r4) = (
            clamp_row(y - 2),
            clamp_row(y - 1),
            clamp_row(y),
            clamp_row(y + 1),
            clamp_row(y + 2),
        );
        for x in 0..sw {
            col[x] = r0[x] as u16
                + 4 * r1[x] as u16
                + 6 * r2[x] as u16
                + 4 * r3[x] as u16
                + r4[x] as u16;
        }
        // Horizontal pass at every column (vectorizes), then every second one is kept.
        if sw >= 5 {
            for x in 2..sw - 2 {
                hrow[x] = col[x - 2] as u32
                    + 4 * col[x - 1] as u32
                    + 6 * col[x] as u32
                    + 4 * col[x + 1] as u32
                    + col[x + 2] as u32;
            }
        }
        let at = |x: isize| col[x.clamp(0, sw as isize - 1) as usize] as u32;
        for (ox, o) in out.iter_mut().enumerate() {
            let x = 2 * ox as isize;
            let s = if x >= 2 && x + 2 < sw as isize {
                hrow[x as usize]
            } else {
                at(x - 2) + 4 * at(x - 1) + 6 * at(x) + 4 * at(x + 1) + at(x + 2)
            };
            *o = ((s + 128) >> 8) as u8;
        }
    }
}

/// An image pyramid: level 0 is the full image, each further level half the size of the one
/// before ([`OwnedImage::half_of`]). Every level is stored with a replicated border of
/// [`PLANE_BORDER`] px, so KLT windows near the image edge need no bounds branches.
#[derive(Clone, Debug, Default)]
pub struct Pyramid {
    levels: Vec<BorderedLevel>,
}

/// One level: `width × height` grey levels inside a replicated border.
#[derive(Clone, Debug, Default)]
struct BorderedLevel {
    width: u32,
    height: u32,
    /// `(height + 2·PLANE_BORDER) × (width + 2·PLANE_BORDER)` bytes, row-major.
    data: Vec<u8>,
}

impl BorderedLevel {
    fn stride(&self) -> usize {
        self.width as usize + 2 * PLANE_BORDER
    }

    /// Index of the first interior pixel.
    fn origin(&self) -> usize {
        PLANE_BORDER * self.stride() + PLANE_BORDER
    }

    /// Sizes the buffer for a `width × height` interior.
    fn resize(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        let len = (height as usize + 2 * PLANE_BORDER) * self.stride();
        self.data.resize(len, 0);
    }

    /// Copies the edge pixels of the interior into the border.
    fn fill_border(&mut self) {
        let (w, h, b, stride) = (
            self.width as usize,
            self.height as usize,
            PLANE_BORDER,
            self.stride(),
        );
        for y in b..b + h {
            let row = &mut self.data[y * stride..(y + 1) * stride];
            let (left, right) = (row[b], row[b + w - 1]);
            row[..b].fill(left);
            row[b + w..].fill(right);
        }
        for y in 0..b {
            self.data
                .copy_within(b * stride..(b + 1) * stride, y * stride);
            self.data
                .copy_within((b + h - 1) * stride..(b + h) * stride, (b + h + y) * stride);
        }
    }

    fn view(&self) -> ImageView<'_> {
        ImageView {
            width: self.width,
            height: self.height,
            stride: self.stride(),
            data: &self.data[self.origin()..],
        }
    }
}

/// Replicated border around every pyramid level (px): windows of up to 21 px near the image
/// edge are sampled without bounds branches.
pub const PLANE_BORDER: usize = 16;

/// One pyramid level with its replicated border of [`PLANE_BORDER`] px: what KLT samples.
#[derive(Clone, Copy, Debug)]
pub struct Plane<'a> {
    /// Width (px, without the border).
    pub width: u32,
    /// Height (px, without the border).
    pub height: u32,
    /// Row stride of `data` (`width + 2·PLANE_BORDER`).
    pub stride: usize,
    /// `(height + 2·PLANE_BORDER) × stride` grey levels, row-major, border included.
    pub data: &'a [u8],
}

impl Plane<'_> {
    /// Index in `data` of pixel `(x, y)`, for `x, y ≥ −PLANE_BORDER`.
    #[inline(always)]
    pub fn index(&self, x: isize, y: isize) -> usize {
        (y + PLANE_BORDER as isize) as usize * self.stride + (x + PLANE_BORDER as isize) as usize
    }
}

impl Pyramid {
    /// Builds levels `0..=max_level` of `image` (fewer when the image becomes smaller than
    /// 8 px on a side). Level 0 is copied so the pyramid can outlive the caller's buffer.
    pub fn build(image: &ImageView<'_>, max_level: usize) -> Self {
        let mut p = Pyramid::default();
        p.rebuild(image, max_level);
        p
    }

    /// [`Pyramid::build`] into existing buffers.
    pub fn rebuild(&mut self, image: &ImageView<'_>, max_level: usize) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked). Integer arithmetic: the same values
            // either way.
            return unsafe { self.rebuild_avx2(image, max_level) };
        }
        self.rebuild_inline(image, max_level)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn rebuild_avx2(&mut self, image: &ImageView<'_>, max_level: usize) {
        self.rebuild_inline(image, max_level)
    }

    #[inline(always)]
    fn rebuild_inline(&mut self, image: &ImageView<'_>, max_level: usize) {
        // Buffers are reused frame to frame (no large allocations per frame).
        let mut count = 1;
        let (mut w, mut h) = (image.width(), image.height());
        while count <= max_level && w >= 16 && h >= 16 {
            count += 1;
            (w, h) = (w.div_ceil(2), h.div_ceil(2));
        }
        self.levels.resize_with(count, BorderedLevel::default);
        self.levels.truncate(count);
        let first = &mut self.levels[0];
        first.resize(image.width(), image.height());
        let (stride, origin, w0) = (first.stride(), first.origin(), image.width() as usize);
        for y in 0..image.height() as usize {
            first.data[origin + y * stride..][..w0].copy_from_slice(image.row(y));
        }
        first.fill_border();
        for l in 1..count {
            let (done, rest) = self.levels.split_at_mut(l);
            let src = done[l - 1].view();
            let next = &mut rest[0];
            next.resize(src.width.div_ceil(2), src.height.div_ceil(2));
            let (stride, origin) = (next.stride(), next.origin());
            half_rows(&src, &mut next.data, stride, origin);
            next.fill_border();
        }
    }

    /// Level `l` with its border, for sampling.
    pub fn plane(&self, l: usize) -> Plane<'_> {
        let level = &self.levels[l];
        Plane {
            width: level.width,
            height: level.height,
            stride: level.stride(),
            data: &level.data,
        }
    }

    /// Number of levels (≥ 1 once built).
    pub fn len(&self) -> usize {
        self.levels.len()
    }

    /// True before the first build.
    pub fn is_empty(&self) -> bool {
        self.levels.is_empty()
    }

    /// Level `l` (0 = full size), without its border.
    pub fn level(&self, l: usize) -> ImageView<'_> {
        self.levels[l].view()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn view_rejects_short_buffers_and_zero_sizes() {
        assert!(matches!(
            ImageView::packed(0, 4, &[]),
            Err(ImageError::Empty { .. })
        ));
        assert!(matches!(
            ImageView::new(4, 4, 4, &[0; 15]),
            Err(ImageError::Buffer { needed: 16, .. })
        ));
        assert!(matches!(
            ImageView::new(4, 2, 3, &[0; 16]),
            Err(ImageError::Buffer { .. })
        ));
        // A strided view needs no bytes after the last row's pixels.
        let v = ImageView::new(2, 2, 5, &[1, 2, 0, 0, 0, 3, 4]).unwrap();
        assert_eq!(v.row(1), &[3, 4]);
        assert_eq!(v.to_owned_image().data, vec![1, 2, 3, 4]);
    }

    #[test]
    fn pyramid_halves_by_the_binomial_filter() {
        // A linear ramp stays a ramp (the filter is symmetric and sums to one).
        let data: Vec<u8> = (0..64u32)
            .map(|i| ((i % 8) * 10 + (i / 8) * 3) as u8)
            .collect();
        let img = ImageView::packed(8, 8, &data).unwrap();
        let half = OwnedImage::half_of(&img);
        assert_eq!((half.width, half.height), (4, 4));
        // Interior pixel (1, 1) ← level-0 (2, 2): 2·10 + 2·3 = 26.
        assert_eq!(half.data[4 + 1], 26);
        let big: Vec<u8> = vec![7; 100 * 60];
        let p = Pyramid::build(&ImageView::packed(100, 60, &big).unwrap(), 5);
        // 100×60 → 50×30 → 25×15 (< 16 tall: no further level).
        assert_eq!(p.len(), 3);
        assert_eq!((p.level(2).width(), p.level(2).height()), (25, 15));
        assert!((0..15).all(|y| p.level(2).row(y).iter().all(|&v| v == 7)));
        // The border replicates the edge pixels.
        let ramp = ImageView::packed(8, 8, &data).unwrap();
        let plane = Pyramid::build(&ramp, 0);
        let plane = plane.plane(0);
        let at = |x: isize, y: isize| plane.data[plane.index(x, y)];
        assert_eq!(at(-16, -16), data[0]);
        assert_eq!(at(23, -3), data[7]);
        assert_eq!(at(-5, 20), data[56]);
        assert_eq!(at(3, 9), data[7 * 8 + 3]);
        assert_eq!(at(4, 5), data[5 * 8 + 4]);
    }

    #[test]
    fn equalization_spreads_a_narrow_histogram() {
        let data: Vec<u8> = (0..256u32).map(|i| 100 + (i % 20) as u8).collect();
        let img = ImageView::packed(16, 16, &data).unwrap();
        let eq = OwnedImage::equalized(&img);
        let (lo, hi) = (
            *eq.data.iter().min().unwrap(),
            *eq.data.iter().max().unwrap(),
        );
        assert_eq!(lo, 0);
        assert_eq!(hi, 255);
        // Monotone: order of grey levels is kept.
        for (a, b) in data.iter().zip(&eq.data) {
            for (c, d) in data.iter().zip(&eq.data) {
                if a < c {
                    assert!(b <= d);
                }
            }
        }
    }
}
