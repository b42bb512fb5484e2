//! A feature-level camera's pixel error drawn as an image tracker errs in motion, in place of
//! an independent Gaussian per observation.
//!
//! Measured on rendered flights against the truth (the run summary's `tracker error` line,
//! `scenarios::frontend::TrackerErrorFit`), a KLT track's error is a white jitter on a drift
//! that grows with the track's age, heavy-tailed per track: most tracks drift slowly, a few
//! slide (an edge, a depth boundary, a patch that changes) and drift fast. So each track, when
//! it starts, is drawn sliding with probability `sliding_fraction`; from then on its pixel
//! carries a random walk of `drift_px` (`sliding_drift_px` when sliding) per axis per frame,
//! and every observation a white `white_px` per axis. A later camera that adopts a track (a
//! stereo match) sees the track's error where its leader sees it — a stereo matcher follows
//! the left pixel, drifted or not — plus its own white `stereo_px` per axis.

use std::collections::BTreeMap;

use nalgebra::Vector2;
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// The tracker error model of one camera (all σ per axis, px): the table a scenario's
/// `tracker_error` gives, and the fields of the fit a rendered run reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct TrackerErrorModel {
    /// White jitter on every observation.
    pub white_px: f64,
    /// A slow track's random-walk drift per frame (px/√frame).
    pub drift_px: f64,
    /// Probability that a track slides.
    pub sliding_fraction: f64,
    /// A sliding track's drift per frame (px/√frame).
    pub sliding_drift_px: f64,
    /// A stereo match's own error on top of its leader's.
    pub stereo_px: f64,
}

impl TrackerErrorModel {
    /// The first key out of its range, with the range (every σ finite and at least zero, at
    /// most [`MAX_PX`]; the fraction in [0, 1]).
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        for (key, v) in [
            ("white_px", self.white_px),
            ("drift_px", self.drift_px),
            ("sliding_drift_px", self.sliding_drift_px),
            ("stereo_px", self.stereo_px),
        ] {
            if !(v.is_finite() && (0.0..=MAX_PX).contains(&v)) {
                return Err((key, format!("{v}: expected a σ in [0, {MAX_PX}] px")));
            }
        }
        let f = self.sliding_fraction;
        if !(f.is_finite() && (0.0..=1.0).contains(&f)) {
            return Err((
                "sliding_fraction",
                format!("{f}: expected a fraction in [0, 1]"),
            ));
        }
        Ok(())
    }
}

/// Largest σ a tracker error model takes (px): past it the tracker has lost the feature.
pub const MAX_PX: f64 = 5.0;

/// One track's drift so far and its per-frame σ.
#[derive(Clone, Copy, Debug)]
struct Track {
    drift: Vector2<f64>,
    sigma: f64,
}

/// One camera's tracks under a [`TrackerErrorModel`], drawn from its own stream.
#[derive(Clone, Debug)]
pub(crate) struct TrackErrors {
    model: TrackerErrorModel,
    rng: ChaCha8Rng,
    tracks: BTreeMap<u64, Track>,
    /// The error of each track this camera reported in the current frame (what a later camera
    /// adopting it follows).
    reported: BTreeMap<u64, Vector2<f64>>,
}

impl TrackErrors {
    pub(crate) fn new(model: TrackerErrorModel, rng: ChaCha8Rng) -> Self {
        Self {
            model,
            rng,
            tracks: BTreeMap::new(),
            reported: BTreeMap::new(),
        }
    }

    fn gauss2(&mut self, sigma: f64) -> Vector2<f64> {
        let x: f64 = StandardNormal.sample(&mut self.rng);
        let y: f64 = StandardNormal.sample(&mut self.rng);
        Vector2::new(x, y) * sigma
    }

    /// Starts a frame: the errors reported in the last one are forgotten.
    pub(crate) fn begin_frame(&mut self) {
        self.reported.clear();
    }

    /// The error this frame of track `id`; `leader` is the error the camera it was adopted from
    /// reported for it this frame (`None`: the track is this camera's own). Call once per
    /// track and frame, in a fixed order.
    pub(crate) fn error(&mut self, id: u64, leader: Option<Vector2<f64>>) -> Vector2<f64> {
        let e = match leader {
            Some(l) => l + self.gauss2(self.model.stereo_px),
            None => {
                let track = match self.tracks.get(&id).copied() {
                    Some(mut t) => {
                        t.drift += self.gauss2(t.sigma);
                        t
                    }
                    None => {
                        let sliding = self.rng.random::<f64>() < self.model.sliding_fraction;
                        Track {
                            drift: Vector2::zeros(),
                            sigma: if sliding {
                                self.model.sliding_drift_px
                            } else {
                                self.model.drift_px
                            },
                        }
                    }
                };
                self.tracks.insert(id, track);
                track.drift + self.gauss2(self.model.white_px)
            }
        };
        self.reported.insert(id, e);
        e
    }

    /// The error reported for track `id` this frame.
    pub(crate) fn reported(&self, id: u64) -> Option<Vector2<f64>> {
        self.reported.get(&id).copied()
    }

    /// Ends a frame: tracks not reported in it have ended (a lost track that is found again
    /// is a new track with a new id, its drift drawn afresh).
    pub(crate) fn end_frame(&mut self) {
        let reported = &self.reported;
        self.tracks.retain(|id, _| reported.contains_key(id));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn model() -> TrackerErrorModel {
        TrackerErrorModel {
            white_px: 0.1,
            drift_px: 0.02,
            sliding_fraction: 0.0,
            sliding_drift_px: 0.5,
            stereo_px: 0.05,
        }
    }

    /// The per-axis variance of a track's error at age `k` is `σ_w² + (k−1)·σ_d²` (the first
    /// observation has no drift yet).
    #[test]
    fn a_tracks_error_variance_grows_with_its_age() {
        let mut t = TrackErrors::new(model(), ChaCha8Rng::seed_from_u64(3));
        let (tracks, ages) = (4000u64, 40usize);
        let mut var = vec![0.0; ages];
        for _ in 0..ages {
            t.begin_frame();
        }
        for age in 0..ages {
            t.begin_frame();
            for id in 0..tracks {
                let e = t.error(id, None);
                var[age] += 0.5 * e.norm_squared() / tracks as f64;
            }
            t.end_frame();
        }
        for (k, v) in var.iter().enumerate() {
            let want = 0.01 + k as f64 * 0.0004;
            assert!((v - want).abs() < 0.1 * want, "age {k}: {v} against {want}");
        }
    }

    #[test]
    fn an_adopted_track_follows_its_leader_and_an_ended_one_starts_afresh() {
        let mut left = TrackErrors::new(model(), ChaCha8Rng::seed_from_u64(1));
        let mut right = TrackErrors::new(model(), ChaCha8Rng::seed_from_u64(2));
        let mut off = 0.0;
        for _ in 0..200 {
            left.begin_frame();
            right.begin_frame();
            let l = left.error(7, None);
            let r = right.error(7, left.reported(7));
            off += 0.5 * (r - l).norm_squared() / 200.0;
            left.end_frame();
            right.end_frame();
        }
        assert!((off.sqrt() - 0.05).abs() < 0.01, "{}", off.sqrt());
        // Track 7 not reported in a frame ends; its next observation has no drift.
        left.begin_frame();
        left.end_frame();
        assert!(left.tracks.is_empty());
        let broken = TrackerErrorModel {
            sliding_fraction: 1.5,
            ..model()
        };
        assert_eq!(broken.check().unwrap_err().0, "sliding_fraction");
        let broken = TrackerErrorModel {
            white_px: f64::NAN,
            ..model()
        };
        assert_eq!(broken.check().unwrap_err().0, "white_px");
    }
}
