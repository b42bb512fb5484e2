//! The image tracker's error in motion, measured against the truth and fitted to the model a
//! feature-level camera draws from (`sim::tracker_error`).
//!
//! Measured on rendered flights, a track's error (against its first observation's scene
//! point) is a white jitter on a drift that grows with the track's age, and it is
//! heavy-tailed *per track*, not per observation: a track more than 0.5 px off is off again
//! the next frame three times in four (V1_01 preset, seed 1). So the model is a mixture of
//! tracks: most drift slowly, a few slide (on an edge, a depth boundary, a changing patch)
//! and drift fast. A track is counted sliding when its error passes [`SLIDE_PX`] within the
//! fitted ages; each class's per-axis variance by age `k` is fitted to `var(k) = σ_w² +
//! k·σ_d²` (a random walk of `σ_d` per frame under a white `σ_w` shared by both classes),
//! by least squares with each age weighted by its count.

use std::collections::BTreeMap;

use serde::Serialize;
use sim::tracker_error::TrackerErrorModel;

/// Ages (frames since the first observation) the fit reads.
const FIT_AGES: std::ops::RangeInclusive<usize> = 1..=30;
/// Fewest samples an age needs to enter a class's line.
const MIN_SAMPLES_PER_AGE: usize = 20;
/// A track whose error passes this (px) within [`FIT_AGES`] slides: about 5σ of the slow
/// tracks' per-axis error at age 30 on the rendered flights (0.15 px), where a Rayleigh tail
/// passes it once in 10⁵ observations.
pub const SLIDE_PX: f64 = 0.75;

/// The fitted tracker error model (`report.json` → `frontend.tracker_error`): the model a
/// feature-level camera draws, and what the fit saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TrackerErrorFit {
    /// The model (a stereo match's σ within the outlier line; the sliding fraction as counted
    /// by [`SLIDE_PX`]).
    #[serde(flatten)]
    pub model: TrackerErrorModel,
    /// Fraction of kept tracks' observations past the outlier line.
    pub outlier_rate: f64,
    /// Tracks the fit read.
    pub tracks: usize,
}

/// One tracked observation's error: its track, its age (frames) and the error vector (px).
#[derive(Clone, Copy, Debug)]
pub(crate) struct AgedError {
    pub track: u64,
    pub age: usize,
    pub dx: f64,
    pub dy: f64,
}

/// Fits the model to the tracked errors `tracks` and the stereo match errors `stereo` (each a
/// vector in px); `limit` is the outlier line.
pub(crate) fn fit(tracks: &[AgedError], stereo: &[(f64, f64)], limit: f64) -> TrackerErrorFit {
    let mut sliding: BTreeMap<u64, bool> = BTreeMap::new();
    for e in tracks.iter().filter(|e| FIT_AGES.contains(&e.age)) {
        *sliding.entry(e.track).or_default() |= e.dx.hypot(e.dy) > SLIDE_PX;
    }
    let n_age = *FIT_AGES.end() + 1;
    let mut by_age = [vec![(0.0f64, 0usize); n_age], vec![(0.0f64, 0usize); n_age]];
    // Past the outlier line a track is the estimator's robust loss's to reject: not fitted.
    for e in tracks
        .iter()
        .filter(|e| FIT_AGES.contains(&e.age) && e.dx.hypot(e.dy) <= limit)
    {
        let class = usize::from(sliding[&e.track]);
        let cell = &mut by_age[class][e.age];
        cell.0 += 0.5 * (e.dx * e.dx + e.dy * e.dy);
        cell.1 += 1;
    }
    let points = |class: usize| -> Vec<(f64, f64, f64)> {
        by_age[class]
            .iter()
            .enumerate()
            .filter(|(_, (_, n))| *n >= MIN_SAMPLES_PER_AGE)
            .map(|(k, (s, n))| (k as f64, s / *n as f64, *n as f64))
            .collect()
    };
    let (white_var, drift_var) = weighted_line(&points(0));
    // The sliding class shares the white jitter: only its slope is its own.
    let sliding_var = slope_above(&points(1), white_var);
    let stereo_in: Vec<f64> = stereo
        .iter()
        .filter(|(dx, dy)| dx.hypot(*dy) <= limit)
        .map(|(dx, dy)| 0.5 * (dx * dx + dy * dy))
        .collect();
    let frac = |n: usize, d: usize| if d == 0 { 0.0 } else { n as f64 / d as f64 };
    let outliers = tracks.iter().filter(|e| e.dx.hypot(e.dy) > limit).count();
    TrackerErrorFit {
        model: TrackerErrorModel {
            white_px: (0.5 * white_var).sqrt(),
            drift_px: drift_var.sqrt(),
            sliding_fraction: frac(sliding.values().filter(|s| **s).count(), sliding.len()),
            sliding_drift_px: sliding_var.sqrt(),
            stereo_px: mean(&stereo_in).sqrt(),
        },
        outlier_rate: frac(outliers, tracks.len()),
        tracks: sliding.len(),
    }
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// The weighted least-squares line `y = a + b·x` through `(x, y, weight)`, both coefficients
/// held at or above zero (variances); `(0, 0)` without points.
fn weighted_line(points: &[(f64, f64, f64)]) -> (f64, f64) {
    let w: f64 = points.iter().map(|p| p.2).sum();
    if w <= 0.0 {
        return (0.0, 0.0);
    }
    let mx = points.iter().map(|p| p.2 * p.0).sum::<f64>() / w;
    let my = points.iter().map(|p| p.2 * p.1).sum::<f64>() / w;
    let sxx: f64 = points.iter().map(|p| p.2 * (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| p.2 * (p.0 - mx) * (p.1 - my)).sum();
    if sxx <= 0.0 {
        return (my.max(0.0), 0.0);
    }
    let b = (sxy / sxx).max(0.0);
    let a = my - b * mx;
    if a < 0.0 {
        return (0.0, slope_above(points, 0.0));
    }
    (a, b)
}

/// The weighted least-squares slope `b` of `y = a + b·x` with `a` given, at or above zero.
fn slope_above(points: &[(f64, f64, f64)], a: f64) -> f64 {
    let sxx: f64 = points.iter().map(|p| p.2 * p.0 * p.0).sum();
    if sxx <= 0.0 {
        return 0.0;
    }
    let sxy: f64 = points.iter().map(|p| p.2 * p.0 * (p.1 - a)).sum();
    (sxy / sxx).max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// Tracks drawn from the model itself give its parameters back.
    #[test]
    fn the_fit_recovers_a_drawn_mixture_of_tracks() {
        let (white, drift, sliding, fraction, stereo) = (0.07, 0.017, 0.13, 0.04, 0.11);
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut g = |s: f64| -> f64 {
            let n: f64 = StandardNormal.sample(&mut rng);
            s * n
        };
        let (mut tracks, mut pairs) = (Vec::new(), Vec::new());
        for track in 0..6000u64 {
            let d = if track % 25 == 0 { sliding } else { drift };
            // The anchor is the first observation, itself off by the white jitter.
            let (mut x, mut y) = (-g(white), -g(white));
            for age in 1..=30 {
                x += g(d);
                y += g(d);
                let (dx, dy) = (x + g(white), y + g(white));
                tracks.push(AgedError { track, age, dx, dy });
                // A stereo error is taken against the left feature's own pixel.
                pairs.push((g(stereo), g(stereo)));
            }
        }
        let fitted = fit(&tracks, &pairs, 2.0);
        let f = fitted.model;
        assert!((f.white_px - white).abs() < 0.01, "{f:?}");
        assert!((f.drift_px - drift).abs() < 0.004, "{f:?}");
        assert!((f.sliding_fraction - fraction).abs() < 0.01, "{f:?}");
        assert!((f.sliding_drift_px - sliding).abs() < 0.05, "{f:?}");
        assert!((f.stereo_px - stereo).abs() < 0.003, "{f:?}");
        assert_eq!(fitted.tracks, 6000);
    }

    #[test]
    fn outliers_are_counted_and_a_lone_class_fits_alone() {
        let e = |track, age, dx| AgedError {
            track,
            age,
            dx,
            dy: 0.0,
        };
        let tracks = [e(1, 1, 0.1), e(1, 2, 5.0), e(2, 1, 0.1), e(2, 2, 0.2)];
        let f = fit(&tracks, &[], 2.0);
        assert_eq!(f.outlier_rate, 0.25);
        let m = f.model;
        assert_eq!(m.sliding_fraction, 0.5);
        // Too few samples per age for either line.
        assert_eq!(
            (m.white_px, m.drift_px, m.sliding_drift_px),
            (0.0, 0.0, 0.0)
        );
    }
}
