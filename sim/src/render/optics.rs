//! The lens and sensor's point spread: a separable Gaussian blur of the camera image (in
//! grey levels, before the noise), its kernel truncated at 3σ and the image's edge pixels
//! repeated beyond the border.

/// Blurs `levels` (rows of `width` pixels) in place by a Gaussian of σ `sigma_px`.
///
/// Each output pixel is the kernel's weighted sum of its neighbours taken in kernel order
/// (`w₀a₀ + w₁a₁ + …`, left to right); the loops run over pixels innermost, so the sums of a
/// row are formed side by side (vectorized) without changing any pixel's order of operations.
pub(crate) fn gaussian_blur(levels: &mut [f32], width: usize, sigma_px: f64) {
    if width == 0 || levels.is_empty() {
        return;
    }
    let height = levels.len() / width;
    let radius = (3.0 * sigma_px).ceil() as usize;
    let mut kernel: Vec<f32> = (-(radius as isize)..=radius as isize)
        .map(|k| (-0.5 * (k as f64 / sigma_px).powi(2)).exp() as f32)
        .collect();
    let sum: f32 = kernel.iter().sum();
    kernel.iter_mut().for_each(|w| *w /= sum);
    let mut tmp = vec![0f32; levels.len()];
    // Along rows: each row padded by its edge pixels repeated `radius` times on either side.
    let mut padded = vec![0f32; width + 2 * radius];
    for (row, out) in levels.chunks_exact(width).zip(tmp.chunks_exact_mut(width)) {
        padded[..radius].fill(row[0]);
        padded[radius..radius + width].copy_from_slice(row);
        padded[radius + width..].fill(row[width - 1]);
        weighted_sum(&kernel, |k| &padded[k..k + width], out);
    }
    // Along columns: the rows above and below, the edge rows repeated.
    let source_row = |y: usize, k: usize| {
        let r = (y + k).saturating_sub(radius).min(height - 1);
        &tmp[r * width..(r + 1) * width]
    };
    for (y, out) in levels.chunks_exact_mut(width).enumerate() {
        weighted_sum(&kernel, |k| source_row(y, k), out);
    }
}

/// `out[x] = Σₖ kernel[k] · taps(k)[x]`, summed in kernel order.
fn weighted_sum<'a>(kernel: &[f32], taps: impl Fn(usize) -> &'a [f32], out: &mut [f32]) {
    for (o, &a) in out.iter_mut().zip(taps(0)) {
        *o = kernel[0] * a;
    }
    for (k, &w) in kernel.iter().enumerate().skip(1) {
        for (o, &a) in out.iter_mut().zip(taps(k)) {
            *o += w * a;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A step edge spreads with the given σ: the 16–84 % rise spans 2σ, and grey is kept.
    #[test]
    fn a_step_edge_spreads_by_sigma_and_keeps_its_mean() {
        let (w, h) = (64usize, 4usize);
        let mut img: Vec<f32> = (0..w * h)
            .map(|i| if i % w < 32 { 0.0 } else { 100.0 })
            .collect();
        let before: f32 = img.iter().sum();
        gaussian_blur(&mut img, w, 1.5);
        let after: f32 = img.iter().sum();
        assert!((after - before).abs() < 1e-2 * before);
        let row = &img[w..2 * w];
        // Where the blurred edge crosses 15.9 % and 84.1 %, interpolated.
        let cross = |level: f32| {
            let k = row.iter().position(|&v| v >= level).unwrap();
            (k - 1) as f32 + (level - row[k - 1]) / (row[k] - row[k - 1])
        };
        let width = cross(84.13) - cross(15.87);
        assert!((width - 3.0).abs() < 0.15, "16–84 % width {width} px");
    }

    /// The blur as first written (a clamped index per tap, one pixel at a time): the
    /// reference the vectorized loops must match bit for bit.
    fn blur_one_pixel_at_a_time(levels: &mut [f32], width: usize, sigma_px: f64) {
        let height = levels.len() / width;
        let radius = (3.0 * sigma_px).ceil() as isize;
        let mut kernel: Vec<f32> = (-radius..=radius)
            .map(|k| (-0.5 * (k as f64 / sigma_px).powi(2)).exp() as f32)
            .collect();
        let sum: f32 = kernel.iter().sum();
        kernel.iter_mut().for_each(|w| *w /= sum);
        let clamp = |i: isize, n: usize| i.clamp(0, n as isize - 1) as usize;
        let mut tmp = vec![0f32; levels.len()];
        for y in 0..height {
            let row = &levels[y * width..(y + 1) * width];
            for x in 0..width {
                tmp[y * width + x] = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, &w)| w * row[clamp(x as isize + k as isize - radius, width)])
                    .sum();
            }
        }
        for y in 0..height {
            for x in 0..width {
                levels[y * width + x] = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, &w)| {
                        w * tmp[clamp(y as isize + k as isize - radius, height) * width + x]
                    })
                    .sum();
            }
        }
    }

    /// Rendered images stay byte-identical: the blur equals the one-pixel-at-a-time sums bit for
    /// bit, on images wider and narrower than the kernel, for several σ.
    #[test]
    fn the_blur_equals_its_one_pixel_at_a_time_reference_bit_for_bit() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32 * 255.0
        };
        for (w, h, sigma) in [
            (37, 23, 1.0),
            (5, 4, 1.5),
            (2, 9, 1.0),
            (1, 1, 0.7),
            (64, 3, 2.3),
        ] {
            let img: Vec<f32> = (0..w * h).map(|_| next()).collect();
            let (mut fast, mut reference) = (img.clone(), img);
            gaussian_blur(&mut fast, w, sigma);
            blur_one_pixel_at_a_time(&mut reference, w, sigma);
            let differ = fast
                .iter()
                .zip(&reference)
                .filter(|(a, b)| a.to_bits() != b.to_bits())
                .count();
            assert_eq!(differ, 0, "{w}×{h}, σ {sigma}: {differ} pixels differ");
        }
    }
}
