//! What a tracker finds in the frames: the distribution of gradient magnitudes, of the
//! Shi–Tomasi corner response the detector thresholds, and how densely corners lie.

use estimator::frontend::corners::{CornerParams, CornerScratch, detect, shi_tomasi_response};
use estimator::frontend::{ImageView, TrackerConfig};
use serde::Serialize;

use super::sequence::StaticSequence;
use crate::frontend::percentile;

/// Frames sampled (evenly over the sequence): a static scene's texture does not change.
pub const SAMPLED_FRAMES: usize = 5;
/// A pixel is on an edge when its gradient is at least this (levels/px).
pub const EDGE_GRADIENT: f64 = 8.0;
/// Spacing of the corners counted for the density (px): finer than the tracker's, to count
/// the texture rather than the tracker's budget.
pub const DENSITY_SPACING_PX: f64 = 10.0;

/// What [`texture`] measures (pooled over [`SAMPLED_FRAMES`] frames).
#[derive(Clone, Debug, Serialize)]
pub struct Texture {
    /// Gradient magnitude (central differences, levels/px) at the 50th, 90th and 99th
    /// percentiles.
    pub gradient_percentiles: [f64; 3],
    /// Fraction of pixels on an edge (gradient ≥ [`EDGE_GRADIENT`]).
    pub edge_fraction: f64,
    /// Shi–Tomasi response (the detector's units) at the 50th, 90th and 99th percentiles.
    pub response_percentiles: [f64; 3],
    /// Fraction of pixels whose response passes the tracker's absolute floor
    /// (`min_corner_response`).
    pub above_floor_fraction: f64,
    /// Corners the tracker's detector accepts (its quality level and floor) at
    /// [`DENSITY_SPACING_PX`] spacing, per 10,000 pixels.
    pub corners_per_10k_px: f64,
}

/// Measures the texture of `seq` as the tracker `config` would detect it.
pub fn texture(seq: &StaticSequence, config: &TrackerConfig) -> Texture {
    let [w, h] = [seq.size[0] as usize, seq.size[1] as usize];
    let n = seq.frames.len();
    let picks: Vec<usize> = (0..SAMPLED_FRAMES.min(n))
        .map(|k| k * (n - 1) / (SAMPLED_FRAMES.min(n) - 1).max(1))
        .collect();
    let params = CornerParams {
        quality_level: config.quality_level,
        min_response: config.min_corner_response,
        min_distance_px: DENSITY_SPACING_PX,
        border_px: config.border_px,
        grid: [1, 1],
    };
    let mut gradients = Vec::new();
    let mut responses = Vec::new();
    let mut corners = 0usize;
    let mut scratch = CornerScratch::default();
    let mut response = Vec::new();
    for &k in &picks {
        let f = &seq.frames[k];
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let i = y * w + x;
                let gx = 0.5 * (f64::from(f[i + 1]) - f64::from(f[i - 1]));
                let gy = 0.5 * (f64::from(f[i + w]) - f64::from(f[i - w]));
                gradients.push(gx.hypot(gy));
            }
        }
        let view = ImageView::packed(seq.size[0], seq.size[1], f).expect("sized at reading");
        shi_tomasi_response(&view, &mut response);
        for y in 2..h - 2 {
            responses.extend(
                response[y * w + 2..y * w + w - 2]
                    .iter()
                    .map(|&r| f64::from(r)),
            );
        }
        corners += detect(&view, &[], w * h, &params, &mut scratch).len();
    }
    let frames = picks.len() as f64;
    let frac = |v: &[f64], t: f64| v.iter().filter(|&&g| g >= t).count() as f64 / v.len() as f64;
    Texture {
        gradient_percentiles: [0.5, 0.9, 0.99].map(|p| percentile(&gradients, p)),
        edge_fraction: frac(&gradients, EDGE_GRADIENT),
        response_percentiles: [0.5, 0.9, 0.99].map(|p| percentile(&responses, p)),
        above_floor_fraction: frac(&responses, config.min_corner_response),
        corners_per_10k_px: corners as f64 / frames / (w * h) as f64 * 1e4,
    }
}
