//! Feature tracks in the window: observations per frame and the anchor's inverse depth.

use std::collections::BTreeMap;

use nalgebra::Vector2;

use crate::factors::FeatureMeasurement;

/// One frame's view of a track: left (0) and right (1) camera observations.
#[derive(Clone, Debug)]
pub(crate) struct Observation {
    /// Frame sequence number.
    pub seq: u64,
    /// Undistorted measurements per camera.
    pub meas: [Option<FeatureMeasurement>; 2],
    /// Distorted pixels per camera (for reprojection-error checks).
    pub uv: [Option<Vector2<f64>>; 2],
}

/// A feature tracked across frames, anchored at its first observation by the left camera.
#[derive(Clone, Debug)]
pub(crate) struct Track {
    /// Observations in frame order; the first has a left-camera measurement.
    pub obs: Vec<Observation>,
    /// Inverse depth along the anchor's left-camera ray, once triangulated.
    pub inv_depth: Option<f64>,
}

impl Track {
    /// Number of measurements (both cameras) in the window.
    pub fn measurement_count(&self) -> usize {
        self.obs
            .iter()
            .map(|o| o.meas.iter().filter(|m| m.is_some()).count())
            .sum()
    }
}

/// All tracks, keyed by feature id (ordered: iteration order is deterministic).
#[derive(Clone, Debug, Default)]
pub(crate) struct FeatureManager {
    pub tracks: BTreeMap<u64, Track>,
}

impl FeatureManager {
    /// Adds a frame's observations; returns how many of them continue an existing track.
    pub fn add_frame(&mut self, observations: Vec<(u64, Observation)>) -> usize {
        let mut continued = 0;
        for (id, o) in observations {
            match self.tracks.get_mut(&id) {
                Some(t) => {
                    continued += 1;
                    t.obs.push(o);
                }
                None => {
                    // A track starts with a left-camera observation.
                    if o.meas[0].is_some() {
                        self.tracks.insert(
                            id,
                            Track {
                                obs: vec![o],
                                inv_depth: None,
                            },
                        );
                    }
                }
            }
        }
        continued
    }

    /// The previous left-camera measurement of `id` (frame seq, point), if any.
    pub fn last_left(&self, id: u64) -> Option<(u64, Vector2<f64>)> {
        let t = self.tracks.get(&id)?;
        t.obs
            .iter()
            .rev()
            .find_map(|o| o.meas[0].map(|m| (o.seq, m.point)))
    }

    /// Average left-camera parallax (normalized units) between frames `a` and `b` over tracks
    /// seen in both; `None` when no track is.
    pub fn parallax(&self, a: u64, b: u64) -> Option<f64> {
        let (mut sum, mut n) = (0.0, 0usize);
        for t in self.tracks.values() {
            let pa = t.obs.iter().find(|o| o.seq == a).and_then(|o| o.meas[0]);
            let pb = t.obs.iter().find(|o| o.seq == b).and_then(|o| o.meas[0]);
            if let (Some(pa), Some(pb)) = (pa, pb) {
                sum += (pa.point - pb.point).norm();
                n += 1;
            }
        }
        (n > 0).then(|| sum / n as f64)
    }
}
