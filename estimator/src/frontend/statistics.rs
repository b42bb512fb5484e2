//! Running statistics of the image front end that need no ground truth: features per frame,
//! track lengths, stereo matches and each check's rejections, from the tracker's own
//! [`TrackReport`]s and the frames it produced. They describe a run on real images as well as
//! on rendered ones, so the two can be put side by side.

use std::collections::BTreeMap;

use serde::Serialize;

use super::{FeatureFrame, TrackReport};

/// Accumulates [`TrackReport`]s and [`FeatureFrame`]s into a [`TrackSummary`].
#[derive(Clone, Debug, Default)]
pub struct TrackStatistics {
    frames: usize,
    features: Vec<usize>,
    /// Observations of each track on the primary camera.
    observations: BTreeMap<u64, u32>,
    tracks_in: usize,
    klt_lost: usize,
    flow_back_rejected: usize,
    ransac_rejected: usize,
    detected: usize,
    stereo_tried: usize,
    stereo_matched: usize,
    stereo_rejected: usize,
}

/// What the front end did over a run (`report.json` → `frontend_tracks`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct TrackSummary {
    /// Frames tracked (with an image on the primary camera).
    pub frames: usize,
    /// Features on the primary camera per frame: mean.
    pub features_mean: f64,
    /// Fewest features in a frame.
    pub features_min: usize,
    /// Most features in a frame.
    pub features_max: usize,
    /// Frames a track lasted on the primary camera, averaged over its tracks.
    pub track_length_mean: f64,
    /// The median track length (frames).
    pub track_length_median: f64,
    /// New tracks per frame.
    pub detected_per_frame: f64,
    /// Tracks lost by temporal KLT per frame (out of the image, untrackable, diverged).
    pub klt_lost_per_frame: f64,
    /// Tracks rejected by the temporal flow-back check per frame.
    pub flow_back_rejected_per_frame: f64,
    /// Tracks rejected by RANSAC per frame.
    pub ransac_rejected_per_frame: f64,
    /// RANSAC's rejections among the tracks that reached it.
    pub ransac_rejected_fraction: f64,
    /// Stereo matches made among those tried.
    pub stereo_match_ratio: f64,
    /// Stereo matches rejected by flow-back, epipolar or depth checks per frame.
    pub stereo_rejected_per_frame: f64,
}

impl TrackStatistics {
    /// Adds one tracked frame: the tracker's report of the call and the frame it returned.
    pub fn add(&mut self, report: &TrackReport, frame: &FeatureFrame) {
        let Some(primary) = report.primary else {
            return;
        };
        self.frames += 1;
        let features = frame
            .cameras
            .iter()
            .find(|c| c.cam_id == primary)
            .map_or(&[][..], |c| &c.features[..]);
        self.features.push(features.len());
        for f in features {
            *self.observations.entry(f.feature_id).or_default() += 1;
        }
        self.tracks_in += report.tracks_in;
        self.klt_lost += report.klt_lost;
        self.flow_back_rejected += report.flow_back_rejected;
        self.ransac_rejected += report.ransac_rejected.len();
        self.detected += report.detected;
        self.stereo_tried += report.stereo_tried;
        self.stereo_matched += report.stereo_matched;
        self.stereo_rejected += report.stereo_flow_back_rejected + report.stereo_epipolar_rejected;
    }

    /// The summary so far (zeros before any frame).
    pub fn summary(&self) -> TrackSummary {
        if self.frames == 0 {
            return TrackSummary::default();
        }
        let n = self.frames as f64;
        let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
        let mut lengths: Vec<u32> = self.observations.values().copied().collect();
        lengths.sort_unstable();
        let median = match lengths.len() {
            0 => 0.0,
            k if k % 2 == 1 => f64::from(lengths[k / 2]),
            k => 0.5 * f64::from(lengths[k / 2 - 1] + lengths[k / 2]),
        };
        let reached_ransac = self
            .tracks_in
            .saturating_sub(self.klt_lost + self.flow_back_rejected);
        TrackSummary {
            frames: self.frames,
            features_mean: self.features.iter().sum::<usize>() as f64 / n,
            features_min: self.features.iter().copied().min().unwrap_or(0),
            features_max: self.features.iter().copied().max().unwrap_or(0),
            track_length_mean: ratio(lengths.iter().map(|&l| l as usize).sum(), lengths.len()),
            track_length_median: median,
            detected_per_frame: self.detected as f64 / n,
            klt_lost_per_frame: self.klt_lost as f64 / n,
            flow_back_rejected_per_frame: self.flow_back_rejected as f64 / n,
            ransac_rejected_per_frame: self.ransac_rejected as f64 / n,
            ransac_rejected_fraction: ratio(self.ransac_rejected, reached_ransac),
            stereo_match_ratio: ratio(self.stereo_matched, self.stereo_tried),
            stereo_rejected_per_frame: self.stereo_rejected as f64 / n,
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector2;

    use super::*;
    use crate::frontend::{CameraFeatures, FeatureObservation};

    fn frame(ids: &[u64]) -> FeatureFrame {
        FeatureFrame {
            t_ns: 0,
            cameras: vec![CameraFeatures {
                cam_id: 0,
                features: ids
                    .iter()
                    .map(|&feature_id| FeatureObservation {
                        feature_id,
                        uv: Vector2::zeros(),
                    })
                    .collect(),
            }],
        }
    }

    #[test]
    fn counts_tracks_and_rejections() {
        let mut s = TrackStatistics::default();
        let report = |tracks_in, klt_lost, rejected: usize| TrackReport {
            primary: Some(0),
            tracks_in,
            klt_lost,
            ransac_rejected: vec![(9, Vector2::zeros()); rejected],
            stereo_tried: 4,
            stereo_matched: 3,
            ..Default::default()
        };
        s.add(&report(0, 0, 0), &frame(&[1, 2, 3, 4]));
        s.add(&report(4, 1, 1), &frame(&[1, 2, 5]));
        s.add(&report(3, 0, 0), &frame(&[1, 2, 5]));
        // A frame without an image on the primary camera counts for nothing.
        s.add(&TrackReport::default(), &frame(&[]));
        let t = s.summary();
        assert_eq!(t.frames, 3);
        assert_eq!((t.features_min, t.features_max), (3, 4));
        assert!((t.features_mean - 10.0 / 3.0).abs() < 1e-12);
        // Tracks 1 and 2: 3 frames; 3 and 4: 1; 5: 2.
        assert!((t.track_length_mean - 2.0).abs() < 1e-12);
        assert_eq!(t.track_length_median, 2.0);
        // 7 tracks in, 1 lost by KLT: 6 reached RANSAC, 1 rejected.
        assert!((t.ransac_rejected_fraction - 1.0 / 6.0).abs() < 1e-12);
        assert!((t.stereo_match_ratio - 0.75).abs() < 1e-12);
    }
}
