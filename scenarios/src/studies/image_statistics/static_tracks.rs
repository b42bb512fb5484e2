//! The KLT front end on a static scene: with nothing moving, every pixel a track travels from
//! where it was first detected is the tracker's own error (noise, drift, jumps to a
//! neighbouring corner), measurable on real frames without ground truth.
//!
//! A camera "at rest" on real hardware still sways: the EuRoC MAV's image moves by up to 1.7 px
//! over the first 4.7 s of V1_01, with parallax between the floor a few decimetres away and the
//! far walls. That motion is taken out before the error is measured, locally: a track's
//! displacement since its first frame is compared with the median displacement, over the same
//! frames, of its nearest tracks (up to [`NEIGHBOURS`] within [`NEIGHBOUR_RADIUS_PX`]). Any
//! motion that is smooth across the image (rotation, translation with smoothly varying depth)
//! cancels; what remains is each track's own error, enlarged by about 12 % by the noise of the
//! neighbours' median, on real and rendered frames alike.

use std::collections::HashMap;
use std::sync::Arc;

use estimator::frontend::{
    CameraImageView, FeatureTracker, ImageView, TrackerCamera, TrackerConfig,
};
use estimator::geometry::Pose;
use nalgebra::Vector2;
use serde::Serialize;

use super::sequence::StaticSequence;
use crate::frontend::percentile;

/// Most neighbours whose motion predicts a track's.
pub const NEIGHBOURS: usize = 6;
/// Fewest neighbours for a track's observation to be scored.
pub const MIN_NEIGHBOURS: usize = 3;
/// Neighbours lie within this distance (px) at the track's first frame.
pub const NEIGHBOUR_RADIUS_PX: f64 = 100.0;

/// What [`static_tracks`] measures.
#[derive(Clone, Debug, Serialize)]
pub struct StaticTracks {
    /// Observations after a track's first that were scored.
    pub observations: usize,
    /// Observations not scored: fewer than [`MIN_NEIGHBOURS`] neighbours over the same frames.
    pub unscored: usize,
    /// A track's displacement less its neighbours' (px), median.
    pub error_median_px: f64,
    /// … 95th percentile.
    pub error_p95_px: f64,
    /// … largest.
    pub error_max_px: f64,
    /// Distance from the track's first position with the scene's motion left in (px), median
    /// and 95th percentile: how static the "static" frames were.
    pub raw_drift_px: [f64; 2],
    /// Tracks started.
    pub tracks: usize,
    /// Features per frame, mean.
    pub features_per_frame: f64,
    /// Tracks lost per frame (ended before the last frame), mean over the frames after the
    /// first: on a static scene each is a failure.
    pub lost_per_frame: f64,
}

/// Tracks camera `seq.camera` alone (no gyroscope, no stereo) with `config` and measures
/// each track's error (see the module's documentation).
pub fn static_tracks(seq: &StaticSequence, config: &TrackerConfig) -> Result<StaticTracks, String> {
    let camera = TrackerCamera {
        model: Arc::new(seq.model.clone()),
        T_b_c: Pose::identity(),
    };
    let config = TrackerConfig {
        stereo: false,
        ..*config
    };
    let mut tracker = FeatureTracker::new(config, vec![camera]).map_err(|e| e.to_string())?;
    // Per frame: track id → pixel.
    let mut frames: Vec<HashMap<u64, Vector2<f64>>> = Vec::new();
    let mut order: Vec<Vec<u64>> = Vec::new();
    for (f, &t) in seq.frames.iter().zip(&seq.stamps_ns) {
        let image = ImageView::packed(seq.size[0], seq.size[1], f).map_err(|e| e.to_string())?;
        let frame = tracker
            .track(&[CameraImageView { cam_id: 0, image }], t, None)
            .map_err(|e| e.to_string())?;
        let obs = frame.cameras.first().map_or(&[][..], |c| &c.features[..]);
        order.push(obs.iter().map(|o| o.feature_id).collect());
        frames.push(obs.iter().map(|o| (o.feature_id, o.uv)).collect());
    }
    let mut start: HashMap<u64, usize> = HashMap::new();
    let (mut errors, mut raw) = (Vec::new(), Vec::new());
    let (mut unscored, mut features, mut lost) = (0usize, 0usize, 0usize);
    for t in 0..frames.len() {
        features += order[t].len();
        if t > 0 {
            lost += order[t - 1]
                .iter()
                .filter(|id| !frames[t].contains_key(id))
                .count();
        }
        for &id in &order[t] {
            let Some(&s) = start.get(&id) else {
                start.insert(id, t);
                continue;
            };
            let (p0, p) = (frames[s][&id], frames[t][&id]);
            raw.push((p - p0).norm());
            match neighbours_motion(&frames[s], &frames[t], id, p0) {
                Some(m) => errors.push((p - p0 - m).norm()),
                None => unscored += 1,
            }
        }
    }
    let n = frames.len() as f64;
    Ok(StaticTracks {
        observations: errors.len(),
        unscored,
        error_median_px: percentile(&errors, 0.5),
        error_p95_px: percentile(&errors, 0.95),
        error_max_px: errors.iter().copied().fold(0.0, f64::max),
        raw_drift_px: [percentile(&raw, 0.5), percentile(&raw, 0.95)],
        tracks: start.len(),
        features_per_frame: features as f64 / n,
        lost_per_frame: lost as f64 / (n - 1.0),
    })
}

/// The median displacement from frame `a` to frame `b` of the tracks nearest to `at` in `a`
/// (other than `id`, seen in both), or `None` with fewer than [`MIN_NEIGHBOURS`].
fn neighbours_motion(
    a: &HashMap<u64, Vector2<f64>>,
    b: &HashMap<u64, Vector2<f64>>,
    id: u64,
    at: Vector2<f64>,
) -> Option<Vector2<f64>> {
    let mut near: Vec<(f64, u64, Vector2<f64>)> = a
        .iter()
        .filter(|&(&j, _)| j != id)
        .filter_map(|(&j, &pa)| {
            let d = (pa - at).norm();
            let pb = b.get(&j)?;
            (d <= NEIGHBOUR_RADIUS_PX).then(|| (d, j, pb - pa))
        })
        .collect();
    if near.len() < MIN_NEIGHBOURS {
        return None;
    }
    // Nearest first; equal distances by id, so the choice does not depend on hashing.
    near.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    near.truncate(NEIGHBOURS);
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let k = v.len();
        if k % 2 == 1 {
            v[k / 2]
        } else {
            0.5 * (v[k / 2 - 1] + v[k / 2])
        }
    };
    Some(Vector2::new(
        median(near.iter().map(|n| n.2.x).collect()),
        median(near.iter().map(|n| n.2.y).collect()),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tracks sharing a smooth motion: the neighbours' median predicts it exactly; a track that
    /// slips by half a pixel keeps that half pixel as its error.
    #[test]
    fn motion_shared_with_the_neighbours_cancels_and_a_slip_does_not() {
        let shift = |p: Vector2<f64>| p + Vector2::new(0.3 + 0.001 * p.x, -0.2 + 0.002 * p.y);
        let a: HashMap<u64, Vector2<f64>> = (0..20)
            .map(|k| {
                (
                    k,
                    Vector2::new(100.0 + 15.0 * (k % 5) as f64, 200.0 + 15.0 * (k / 5) as f64),
                )
            })
            .collect();
        let mut b: HashMap<u64, Vector2<f64>> = a.iter().map(|(&k, &p)| (k, shift(p))).collect();
        *b.get_mut(&7).unwrap() += Vector2::new(0.5, 0.0);
        for id in [3u64, 7, 12] {
            let m = neighbours_motion(&a, &b, id, a[&id]).unwrap();
            let err = (b[&id] - a[&id] - m).norm();
            let expected = if id == 7 { 0.5 } else { 0.0 };
            // The motion varies by 0.03 px across 15 px: the median of the nearest is that close.
            assert!((err - expected).abs() < 0.04, "track {id}: error {err}");
        }
        // Alone in its corner of the image: not scored.
        let mut lonely = a.clone();
        lonely.insert(99, Vector2::new(700.0, 20.0));
        let mut lonely_b = b.clone();
        lonely_b.insert(99, Vector2::new(700.0, 20.0));
        assert!(neighbours_motion(&lonely, &lonely_b, 99, lonely[&99]).is_none());
    }
}
