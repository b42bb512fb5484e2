//! A stationary Gaussian noise stream with a given one-sided power spectral density, drawn
//! sample by sample: the IMU's vibration band noise.
//!
//! # Synthesis
//! Blocks of `L` samples (a power of two) are drawn in the frequency domain: bin `k` (frequency
//! `k·fs/L`, DC and Nyquist left empty) gets a complex Gaussian of variance `fs·L·S(f_k)/2`, so
//! the inverse FFT is a real, circularly stationary sequence whose variance is `Σ S(f_k)·fs/L`,
//! the integral of the one-sided density `S` over the bins. Consecutive blocks overlap by half
//! and are weighted by `sin(π(m + ½)/L)`: where two blocks overlap their weights are `sin` and
//! `cos` of the same angle, so the variance stays exactly the blocks' and no seam shows. The
//! density is kept exactly at the bin frequencies; the block length sets the resolution
//! (`fs/L`), and the smooth cross-fade widens each bin by about that much.

use std::sync::Arc;

use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

/// Shortest block the resolution needs: `fs/L` at most this (Hz).
pub const RESOLUTION_HZ: f64 = 0.05;

/// A noise stream with a one-sided density given at the FFT bins.
#[derive(Clone)]
pub struct ShapedNoise {
    /// Standard deviation of each bin's real and imaginary parts (`√(fs·L·S/4)`), bins `0..=L/2`.
    bin_sigma: Vec<f64>,
    fft: Arc<dyn Fft<f64>>,
    current: Vec<f64>,
    next: Vec<f64>,
    /// Index into the second half of `current` / the first half of `next`.
    pos: usize,
}

impl std::fmt::Debug for ShapedNoise {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShapedNoise")
            .field("block", &self.current.len())
            .field("pos", &self.pos)
            .finish()
    }
}

/// The block length for sample rate `fs_hz`: the smallest power of two with `fs/L ≤`
/// [`RESOLUTION_HZ`].
pub fn block_length(fs_hz: f64) -> usize {
    ((fs_hz / RESOLUTION_HZ).ceil() as usize).next_power_of_two()
}

impl ShapedNoise {
    /// A stream at `fs_hz` whose one-sided density at frequency `f` is `density(f)` (units²/Hz),
    /// drawing from `rng` (two blocks now, one more every `L/2` samples).
    pub fn new(fs_hz: f64, density: impl Fn(f64) -> f64, rng: &mut ChaCha8Rng) -> Self {
        let len = block_length(fs_hz);
        let df = fs_hz / len as f64;
        let bin_sigma = (0..=len / 2)
            .map(|k| {
                if k == 0 || k == len / 2 {
                    0.0
                } else {
                    (fs_hz * len as f64 * density(k as f64 * df).max(0.0) / 4.0).sqrt()
                }
            })
            .collect();
        let fft = FftPlanner::new().plan_fft_inverse(len);
        let mut noise = Self {
            bin_sigma,
            fft,
            current: Vec::new(),
            next: Vec::new(),
            pos: 0,
        };
        noise.current = noise.block(rng);
        noise.next = noise.block(rng);
        noise
    }

    /// Whether every bin is empty (the stream is all zeros).
    pub fn is_silent(&self) -> bool {
        self.bin_sigma.iter().all(|s| *s == 0.0)
    }

    fn block(&self, rng: &mut ChaCha8Rng) -> Vec<f64> {
        let len = self.fft.len();
        let mut spectrum = vec![Complex::new(0.0, 0.0); len];
        for k in 1..len / 2 {
            let s = self.bin_sigma[k];
            let re: f64 = rng.sample(StandardNormal);
            let im: f64 = rng.sample(StandardNormal);
            spectrum[k] = Complex::new(s * re, s * im);
            spectrum[len - k] = spectrum[k].conj();
        }
        self.fft.process(&mut spectrum);
        let inv = 1.0 / len as f64;
        (0..len)
            .map(|m| {
                let w = (std::f64::consts::PI * (m as f64 + 0.5) / len as f64).sin();
                spectrum[m].re * inv * w
            })
            .collect()
    }

    /// The next sample.
    pub fn next_sample(&mut self, rng: &mut ChaCha8Rng) -> f64 {
        let half = self.current.len() / 2;
        let x = self.current[half + self.pos] + self.next[self.pos];
        self.pos += 1;
        if self.pos == half {
            self.current = std::mem::take(&mut self.next);
            self.next = self.block(rng);
            self.pos = 0;
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn variance(x: &[f64]) -> f64 {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / x.len() as f64
    }

    #[test]
    fn a_band_holds_its_power_and_nothing_leaks_far_outside() {
        // 0.5 (units)² in 20–40 Hz at 200 Hz: the variance is the band's power, and a
        // one-pole split at 10 Hz (far below the band) keeps well under 1 % of it.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let s = 0.5 / 20.0;
        let mut n = ShapedNoise::new(
            200.0,
            |f| if (20.0..40.0).contains(&f) { s } else { 0.0 },
            &mut rng,
        );
        let x: Vec<f64> = (0..200_000).map(|_| n.next_sample(&mut rng)).collect();
        let v = variance(&x);
        assert!((v / 0.5 - 1.0).abs() < 0.03, "variance {v}");
        // Slow part: a 0.5 s moving average passes < 2 Hz; the band is 20–40 Hz.
        let w = 100;
        let slow: Vec<f64> = x
            .windows(w)
            .step_by(w)
            .map(|c| c.iter().sum::<f64>() / w as f64)
            .collect();
        assert!(variance(&slow) < 0.005 * 0.5, "slow {}", variance(&slow));
    }

    #[test]
    fn an_empty_density_is_silent_and_a_seed_repeats_its_bytes() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut n = ShapedNoise::new(200.0, |_| 0.0, &mut rng);
        assert!(n.is_silent());
        assert!((0..5000).all(|_| n.next_sample(&mut rng) == 0.0));
        let draw = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut n = ShapedNoise::new(100.0, |f| 1e-3 / (1.0 + f), &mut rng);
            (0..7000)
                .map(|_| n.next_sample(&mut rng).to_bits())
                .collect::<Vec<_>>()
        };
        assert_eq!(draw(5), draw(5));
        assert_ne!(draw(5), draw(6));
    }
}
