//! A static sequence's photometry: temporal noise as a function of intensity (shot and read
//! noise, the curve `[camera.photometric] read_noise` and `electrons_per_level` model), the
//! spatial residual of flat areas (an upper bound on fixed-pattern noise), the radial fall-off
//! of brightness (vignetting and the scene together) and the intensity distribution.

use serde::Serialize;

use super::sequence::StaticSequence;
use crate::frontend::percentile;

/// Width of an intensity bin (grey levels).
pub const BIN_LEVELS: usize = 16;
/// A pixel is flat when the gradient of the mean image is under this (levels/px): sub-pixel
/// motion or aliasing on an edge would count as noise.
pub const FLAT_GRADIENT: f64 = 2.0;
/// Frame-to-frame differences beyond this (levels) are a flicker, not noise: left out, counted.
pub const FLICKER_LEVELS: f64 = 12.0;
/// Mean intensities from here up are near saturation and left out.
pub const SATURATION_LEVEL: f64 = 235.0;
/// Fewest flat pixels a bin needs.
pub const MIN_BIN_PIXELS: usize = 300;
/// The noise curve is fitted over bins whose centre lies in this range (levels).
pub const FIT_RANGE: [f64; 2] = [32.0, 216.0];

/// Temporal noise of the flat pixels of one intensity bin.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct NoiseBin {
    /// Bin centre (grey levels).
    pub intensity: f64,
    /// Flat pixels in the bin.
    pub pixels: usize,
    /// Temporal σ (levels): `sqrt(E[d²] / 2)` of the frame-to-frame differences `d`.
    pub sigma: f64,
    /// Fraction of differences left out as flicker.
    pub flicker_fraction: f64,
}

/// What [`photometry`] measures.
#[derive(Clone, Debug, Serialize)]
pub struct Photometry {
    /// Temporal noise per intensity bin.
    pub noise: Vec<NoiseBin>,
    /// Least-squares fit `σ² = a + I / g` over [`FIT_RANGE`]: `[a, g]` (level², levels⁻¹·e⁻).
    pub noise_fit: Option<[f64; 2]>,
    /// The renderer's `read_noise` that gives the fitted curve (σ² less the 1/12 level² of
    /// rounding to 8 bits; 0 when the fit leaves none).
    pub read_noise: Option<f64>,
    /// The renderer's `electrons_per_level`: the fit's `g`.
    pub electrons_per_level: Option<f64>,
    /// σ of the flat pixels' mean image about its 3×3 box average, less what temporal noise
    /// leaves in the mean (levels): fixed-pattern noise plus any fine texture, an upper bound.
    pub spatial_residual_sigma: f64,
    /// Mean brightness of the rings `[0.2 k, 0.2 (k + 1))` of the radius from the image centre
    /// (1 at a corner), relative to the centre disk's: vignetting and the scene's own layout.
    pub radial_profile: [f64; 5],
    /// The mean image's intensity at the 1st, 50th and 99th percentiles (levels).
    pub intensity_percentiles: [f64; 3],
    /// Fraction of the mean image at 250 levels or more (saturated).
    pub saturated_fraction: f64,
}

/// Measures the photometry of `seq` (see [`Photometry`]).
pub fn photometry(seq: &StaticSequence) -> Photometry {
    let [w, h] = [seq.size[0] as usize, seq.size[1] as usize];
    let mean = seq.mean_image();
    let n = seq.frames.len();
    // Flat interior pixels: central-difference gradient of the mean image.
    let mut flat = vec![false; w * h];
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let i = y * w + x;
            let gx = 0.5 * (mean[i + 1] - mean[i - 1]);
            let gy = 0.5 * (mean[i + w] - mean[i - w]);
            flat[i] = gx.hypot(gy) < FLAT_GRADIENT && mean[i] < SATURATION_LEVEL;
        }
    }
    // Per pixel: sum of squared frame-to-frame differences within the flicker bound.
    let bins = 256 / BIN_LEVELS;
    let mut sum_d2 = vec![0.0; bins];
    let mut kept = vec![0usize; bins];
    let mut flicker = vec![0usize; bins];
    let mut pixels = vec![0usize; bins];
    let mut pixel_var = vec![0.0; w * h];
    for i in (0..w * h).filter(|&i| flat[i]) {
        let b = (mean[i] as usize / BIN_LEVELS).min(bins - 1);
        pixels[b] += 1;
        let mut s = 0.0;
        let mut k = 0usize;
        for pair in seq.frames.windows(2) {
            let d = f64::from(pair[1][i]) - f64::from(pair[0][i]);
            if d.abs() <= FLICKER_LEVELS {
                s += d * d;
                k += 1;
            } else {
                flicker[b] += 1;
            }
        }
        sum_d2[b] += s;
        kept[b] += k;
        pixel_var[i] = if k > 0 { 0.5 * s / k as f64 } else { 0.0 };
    }
    let noise: Vec<NoiseBin> = (0..bins)
        .filter(|&b| pixels[b] >= MIN_BIN_PIXELS && kept[b] > 0)
        .map(|b| NoiseBin {
            intensity: (b * BIN_LEVELS + BIN_LEVELS / 2) as f64,
            pixels: pixels[b],
            sigma: (0.5 * sum_d2[b] / kept[b] as f64).sqrt(),
            flicker_fraction: flicker[b] as f64 / (kept[b] + flicker[b]) as f64,
        })
        .collect();
    let noise_fit = fit_noise(&noise);
    // Spatial residual of flat pixels whose 3×3 neighbourhood is flat too.
    let (mut r_sum, mut r_sum2, mut var_t, mut m) = (0.0, 0.0, 0.0, 0usize);
    for y in 2..h - 2 {
        for x in 2..w - 2 {
            let i = y * w + x;
            if !(0..9).all(|k| flat[i + (k / 3) * w + k % 3 - w - 1]) {
                continue;
            }
            let box3: f64 = (0..9).map(|k| mean[i + (k / 3) * w + k % 3 - w - 1]).sum();
            let r = mean[i] - box3 / 9.0;
            r_sum += r;
            r_sum2 += r * r;
            var_t += pixel_var[i];
            m += 1;
        }
    }
    let spatial_residual_sigma = if m > 1 {
        let mf = m as f64;
        let var_r = r_sum2 / mf - (r_sum / mf).powi(2);
        // A white pattern σ² shows as 8/9 σ² about its 3×3 average; the mean of n frames keeps
        // a temporal variance of var_t / n.
        (9.0 / 8.0 * var_r - var_t / mf / n as f64).max(0.0).sqrt()
    } else {
        0.0
    };
    // Radial profile of the unsaturated mean image.
    let (cx, cy) = (0.5 * (w as f64 - 1.0), 0.5 * (h as f64 - 1.0));
    let r_max = cx.hypot(cy);
    let mut ring = [(0.0, 0usize); 5];
    for y in 0..h {
        for x in 0..w {
            let v = mean[y * w + x];
            if v >= 250.0 {
                continue;
            }
            let r = (x as f64 - cx).hypot(y as f64 - cy) / r_max;
            let k = ((r * 5.0) as usize).min(4);
            ring[k].0 += v;
            ring[k].1 += 1;
        }
    }
    let centre = ring[0].0 / ring[0].1.max(1) as f64;
    let radial_profile = ring.map(|(s, c)| {
        if c == 0 || centre <= 0.0 {
            0.0
        } else {
            s / c as f64 / centre
        }
    });
    let saturated = mean.iter().filter(|&&v| v >= 250.0).count();
    Photometry {
        read_noise: noise_fit.map(|[a, _]| (a - 1.0 / 12.0).max(0.0).sqrt()),
        electrons_per_level: noise_fit.map(|[_, g]| g),
        noise,
        noise_fit,
        spatial_residual_sigma,
        radial_profile,
        intensity_percentiles: [0.01, 0.5, 0.99].map(|p| percentile(&mean, p)),
        saturated_fraction: saturated as f64 / mean.len() as f64,
    }
}

/// Least squares `σ² = a + b I` over the bins in [`FIT_RANGE`]; `[a, 1 / b]`, or `None` with
/// fewer than two bins or a curve that does not rise with intensity.
fn fit_noise(bins: &[NoiseBin]) -> Option<[f64; 2]> {
    let pts: Vec<(f64, f64)> = bins
        .iter()
        .filter(|b| (FIT_RANGE[0]..=FIT_RANGE[1]).contains(&b.intensity))
        .map(|b| (b.intensity, b.sigma * b.sigma))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let k = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), p| (a + p.0, b + p.1));
    let (mx, my) = (sx / k, sy / k);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    (b > 0.0).then(|| [my - b * mx, 1.0 / b])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    /// A flat grey ramp with known read and shot noise: the fit recovers both.
    #[test]
    fn the_noise_fit_recovers_the_read_and_shot_noise_it_was_given() {
        let (w, h, frames) = (256usize, 64usize, 12usize);
        let (read, electrons) = (0.8f64, 50.0f64);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let truth: Vec<f64> = (0..w * h).map(|i| 24.0 + (i % w) as f64 * 0.8).collect();
        let frames: Vec<Vec<u8>> = (0..frames)
            .map(|_| {
                truth
                    .iter()
                    .map(|&v| {
                        let s = (read * read + v / electrons).sqrt();
                        let n = Normal::new(0.0, s).unwrap().sample(&mut rng);
                        (v + n).round().clamp(0.0, 255.0) as u8
                    })
                    .collect()
            })
            .collect();
        let seq = StaticSequence {
            mav0: Default::default(),
            camera: 0,
            model: estimator::camera::Camera::PinholeRadtan(
                estimator::camera::PinholeRadtan::new(
                    w as u32, h as u32, 100.0, 100.0, 128.0, 32.0, 0.0, 0.0, 0.0, 0.0,
                )
                .unwrap(),
            ),
            size: [w as u32, h as u32],
            stamps_ns: (0..12).collect(),
            frames,
        };
        let p = photometry(&seq);
        let (r, g) = (p.read_noise.unwrap(), p.electrons_per_level.unwrap());
        // Rounding to 8 bits adds 1/12 level², which the fit removes.
        assert!((r - read).abs() < 0.15, "read noise {r}");
        assert!(
            (g / electrons - 1.0).abs() < 0.15,
            "electrons per level {g}"
        );
        // A pattern-free sensor: the spatial residual is what is left of the noise, near 0.
        assert!(
            p.spatial_residual_sigma < 0.15,
            "{}",
            p.spatial_residual_sigma
        );
    }
}
