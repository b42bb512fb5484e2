//! The lens and sensor's point spread: a separable Gaussian blur of the camera image (in
//! grey levels, before the noise), its kernel truncated at 3σ and the image's edge pixels
//! repeated beyond the border.

/// Blurs `levels` (rows of `width` pixels) in place by a Gaussian of σ `sigma_px`.
pub(crate) fn gaussian_blur(levels: &mut [f32], width: usize, sigma_px: f64) {
    if width == 0 || levels.is_empty() {
        return;
    }
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
                .map(|(k, &w)| w * tmp[clamp(y as isize + k as isize - radius, height) * width + x])
                .sum();
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
}
