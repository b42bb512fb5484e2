//! Feature tracks in the window: observations per frame and the anchor's inverse depth, and the
//! estimator's conversion of a feature frame into observations.

use std::collections::BTreeMap;

use nalgebra::{Vector2, Vector3};

use crate::factors::FeatureMeasurement;
use crate::frontend::FeatureFrame;

/// One frame's view of a track: left (0) and right (1) camera observations.
#[derive(Clone, Debug)]
pub(crate) struct Observation {
    /// Frame sequence number.
    pub seq: u64,
    /// Undistorted measurements per camera.
    pub meas: [Option<FeatureMeasurement>; 2],
    /// Distorted pixels per camera (for reprojection-error checks).
    pub uv: [Option<Vector2<f64>>; 2],
    /// Square-root information of each camera's measurement on the normalized plane: the
    /// camera model's local magnification there (px per normalized unit, √|det ∂uv/∂xy|)
    /// over the pixel σ. Distortion compresses the image edges, so the same pixel noise is a
    /// larger error on the normalized plane there than at the centre.
    pub weight: [f64; 2],
}

impl Observation {
    /// The lowest camera with a measurement.
    pub fn first_camera(&self) -> Option<usize> {
        self.meas.iter().position(Option::is_some)
    }
}

/// A feature tracked across frames, anchored at its first observation by camera `anchor_cam`
/// (any camera of the rig: the left one while it works, whichever sees the feature first
/// otherwise).
#[derive(Clone, Debug)]
pub(crate) struct Track {
    /// Observations in frame order; the first has a measurement by `anchor_cam`.
    pub obs: Vec<Observation>,
    /// The camera whose ray through the first observation carries the inverse depth.
    pub anchor_cam: usize,
    /// Inverse depth along the anchor camera's ray, once triangulated.
    pub inv_depth: Option<f64>,
    /// Estimated correction of the anchor measurement's noise (normalized plane): the anchor
    /// ray is `(x + cx, y + cy, 1)`. Zero whenever the depth is (re)set.
    pub bearing: Vector2<f64>,
    /// Key of the window's persistent world point that carries this track once it outlived
    /// its anchor keyframe (`Window::points`); then every observation measures that point and
    /// `inv_depth` is unused.
    pub point: Option<u64>,
}

impl Track {
    /// Sets (or clears) the inverse depth along the raw anchor measurement's ray.
    pub fn set_inv_depth(&mut self, inv_depth: Option<f64>) {
        self.inv_depth = inv_depth;
        self.bearing = Vector2::zeros();
    }

    /// The anchor's measurement.
    pub fn anchor_measurement(&self) -> Option<FeatureMeasurement> {
        self.obs.first()?.meas[self.anchor_cam]
    }

    /// Drops leading observations until one can anchor the track: by the current anchor
    /// camera if any remains, else by the lowest camera of the first observation that has a
    /// measurement. Returns `false` when no observation is left.
    pub fn reanchor(&mut self) -> bool {
        let cam = self.anchor_cam;
        if self.obs.iter().any(|o| o.meas[cam].is_some()) {
            while self.obs.first().is_some_and(|o| o.meas[cam].is_none()) {
                self.obs.remove(0);
            }
        } else {
            while self
                .obs
                .first()
                .is_some_and(|o| o.meas.iter().all(Option::is_none))
            {
                self.obs.remove(0);
            }
            match self.obs.first().and_then(Observation::first_camera) {
                Some(c) => self.anchor_cam = c,
                None => self.obs.clear(),
            }
        }
        !self.obs.is_empty()
    }

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
                    // A track is anchored in the lowest camera that sees it first.
                    if let Some(anchor_cam) = o.first_camera() {
                        self.tracks.insert(
                            id,
                            Track {
                                obs: vec![o],
                                anchor_cam,
                                inv_depth: None,
                                bearing: Vector2::zeros(),
                                point: None,
                            },
                        );
                    }
                }
            }
        }
        continued
    }

    /// The two latest measurements of `id` by camera `cam`, newest first (frame seq, point).
    pub fn last_two_in(&self, id: u64, cam: usize) -> [Option<(u64, Vector2<f64>)>; 2] {
        let mut out = [None, None];
        if let Some(t) = self.tracks.get(&id) {
            let mut it = t
                .obs
                .iter()
                .rev()
                .filter_map(|o| o.meas[cam].map(|m| (o.seq, m.point)));
            out = [it.next(), it.next()];
        }
        out
    }

    /// Average parallax (normalized units) of camera `cam` between frames `a` and `b` over
    /// tracks it sees in both; `None` when no track is.
    pub fn parallax(&self, a: u64, b: u64, cam: usize) -> Option<f64> {
        let (mut sum, mut n) = (0.0, 0usize);
        for t in self.tracks.values() {
            let pa = t.obs.iter().find(|o| o.seq == a).and_then(|o| o.meas[cam]);
            let pb = t.obs.iter().find(|o| o.seq == b).and_then(|o| o.meas[cam]);
            if let (Some(pa), Some(pb)) = (pa, pb) {
                sum += (pa.point - pb.point).norm();
                n += 1;
            }
        }
        (n > 0).then(|| sum / n as f64)
    }
}

impl super::Estimator {
    /// Undistorts a frame's features and computes their image velocities.
    pub(super) fn observations(&self, frame: &FeatureFrame, seq: u64) -> Vec<(u64, Observation)> {
        let mut by_id: std::collections::BTreeMap<u64, Observation> =
            std::collections::BTreeMap::new();
        for cf in &frame.cameras {
            if cf.cam_id >= self.config.cameras.len() {
                continue;
            }
            let model = &self.config.cameras[cf.cam_id].model;
            for f in &cf.features {
                if !f.uv.iter().all(|v| v.is_finite()) {
                    continue;
                }
                let Some(point) = model.unproject_normalized(&f.uv) else {
                    continue;
                };
                let o = by_id.entry(f.feature_id).or_insert(Observation {
                    seq,
                    meas: [None, None],
                    uv: [None, None],
                    weight: [0.0; 2],
                });
                let magnification = model
                    .project_with_jacobian(&Vector3::new(point.x, point.y, 1.0))
                    .map(|(_, j)| (j[(0, 0)] * j[(1, 1)] - j[(0, 1)] * j[(1, 0)]).abs().sqrt())
                    .filter(|m| m.is_finite() && *m > 0.0)
                    .unwrap_or(self.focal[cf.cam_id]);
                o.weight[cf.cam_id] = magnification / self.config.cameras[cf.cam_id].pixel_sigma;
                // The image velocity the time-offset model shifts the point along: the track's
                // previous displacement, `(z_{k−1} − z_{k−2}) / Δt`, not `(z_k − z_{k−1}) / Δt`,
                // which shares this measurement's noise with its residual and biases `td`
                // (by about σ²/Δt / (v² + σ²/Δt²) per solve; a drift of tens of milliseconds
                // at 1 px). Zero before the track has two earlier measurements. With `td`
                // estimated, the velocity the window's motion predicts replaces it before every
                // solve (`time_offset.rs`).
                let mut velocity = Vector2::zeros();
                let time_of = |seq: u64| {
                    self.window
                        .frames
                        .iter()
                        .find(|w| w.seq == seq)
                        .map(|w| w.t_ns)
                };
                if let [Some((s1, p1)), Some((s0, p0))] =
                    self.window.features.last_two_in(f.feature_id, cf.cam_id)
                    && let (Some(t1), Some(t0)) = (time_of(s1), time_of(s0))
                {
                    let dt = (t1 - t0) as f64 * 1e-9;
                    if dt > 0.0 {
                        velocity = (p1 - p0) / dt;
                    }
                }
                // A rolling-shutter row is exposed after the stamp: the measurement is stamped
                // with an offset earlier by its row's time, so that the time-offset model shifts
                // it to its frame's time along its image velocity.
                let camera = &self.config.cameras[cf.cam_id];
                let row_s = if self.config.model_rolling_shutter {
                    camera.rolling_shutter.row_time_s(&f.uv, model.height())
                } else {
                    0.0
                };
                o.meas[cf.cam_id] = Some(FeatureMeasurement {
                    point,
                    velocity,
                    td: self.window.td - row_s,
                });
                o.uv[cf.cam_id] = Some(f.uv);
            }
        }
        by_id.into_iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn obs(seq: u64, left: bool, right: bool) -> Observation {
        let m = |on: bool| on.then(|| FeatureMeasurement::new(Vector2::new(0.1, -0.2)));
        Observation {
            seq,
            meas: [m(left), m(right)],
            uv: [None, None],
            weight: [300.0, 300.0],
        }
    }

    /// A feature first seen by the right camera only is anchored there (the left camera may
    /// be dead); one seen by both is anchored in the left.
    #[test]
    fn tracks_anchor_in_the_lowest_camera_that_sees_them() {
        let mut fm = FeatureManager::default();
        fm.add_frame(vec![(1, obs(0, false, true)), (2, obs(0, true, true))]);
        assert_eq!(fm.tracks[&1].anchor_cam, 1);
        assert_eq!(fm.tracks[&2].anchor_cam, 0);
        assert_eq!(fm.last_two_in(1, 1)[0].map(|(s, _)| s), Some(0));
        assert_eq!(fm.last_two_in(1, 0), [None, None]);
        // The two latest measurements, newest first.
        fm.add_frame(vec![(1, obs(1, false, true))]);
        let seqs = fm.last_two_in(1, 1).map(|m| m.map(|(s, _)| s));
        assert_eq!(seqs, [Some(1), Some(0)]);
    }

    /// Re-anchoring keeps the anchor camera while it has a view left, and moves to the other
    /// camera only when it has none.
    #[test]
    fn reanchoring_prefers_the_same_camera() {
        let mut t = Track {
            obs: vec![obs(1, false, true), obs(2, true, true), obs(3, false, true)],
            anchor_cam: 0,
            inv_depth: None,
            bearing: Vector2::zeros(),
            point: None,
        };
        assert!(t.reanchor());
        assert_eq!((t.obs[0].seq, t.anchor_cam), (2, 0));
        t.obs.remove(0);
        assert!(t.reanchor());
        assert_eq!((t.obs[0].seq, t.anchor_cam), (3, 1));
        t.obs[0].meas = [None, None];
        assert!(!t.reanchor());
    }
}
