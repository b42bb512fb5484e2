//! The sliding window: the states it holds (frames with pose, velocity and biases, feature
//! tracks with their anchors' inverse depths, extrinsics, time offset, the marginalization
//! prior), how they become one nonlinear least-squares problem ([`Window::build`]), how the
//! solved values return ([`Window::write_back`]), and how frames leave it
//! ([`Window::remove_oldest`], [`Window::remove_second_newest`]). What goes into the prior when a
//! frame leaves is decided in [`super::marginalization_policy`].

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use nalgebra::Vector3;

use super::aiding_fusion::Aiding;
use super::bias_mean::{self, BiasMean};
use super::calibration_gates::CalibrationGates;
use super::config::EstimatorConfig;
use super::features::{FeatureManager, Track};
use super::frame::{BlockRef, Prior, WindowFrame};
use super::persistent_point::PersistentPoint;
use super::point_selection;
use super::stationary::Rest;
use super::window_problem::{ProblemSettings, WindowProblem};
use crate::factors::{
    AnchorBearing, ImuFactor, LANDMARK_SIZE, PointForm, ProjectionOneFrameTwoCam,
    ProjectionTwoFrameOneCam, ProjectionTwoFrameTwoCam, WorldPointProjection,
};
use crate::geometry::Pose;
use crate::problem::{BlockId, BlockKind, Euclidean, Factor, PoseManifold, Problem};

impl Window {
    /// Observations of the solved landmarks and points in the newest frame.
    pub fn newest_observations(&self, built: &WindowProblem) -> usize {
        let Some(seq) = self.frames.back().map(|f| f.seq) else {
            return 0;
        };
        let tracks = built
            .landmarks
            .iter()
            .filter_map(|(id, _)| self.features.tracks.get(id))
            .filter(|t| t.obs.last().is_some_and(|o| o.seq == seq))
            .count();
        let points = built.point_obs.iter().filter(|(_, _, s)| *s == seq).count();
        tracks + points
    }
}

/// The states of the sliding window (one owner: everything the solver estimates lives here).
#[derive(Clone)]
pub(super) struct Window {
    /// Frames, oldest first (seq increasing).
    pub frames: VecDeque<WindowFrame>,
    /// Feature tracks over the window's frames.
    pub features: FeatureManager,
    /// The marginalization prior.
    pub prior: Option<Prior>,
    /// `T_b_c` of each camera.
    pub extrinsics: Vec<Pose>,
    /// Camera-IMU time offset (s).
    pub td: f64,
    /// Persistent landmarks: points of tracks that outlived their anchor keyframe (see
    /// [`Window::promote_to_points`]), by key. They are states carried through
    /// marginalization, so a long track keeps contributing without any observation being
    /// counted twice; a point leaves (into the prior) with its last observing keyframe.
    pub points: BTreeMap<u64, PersistentPoint>,
    next_point: u64,
    /// Frames detected at rest (by seq) and what the IMU read there: each gets a
    /// [`ZeroVelocityFactor`](crate::factors::ZeroVelocityFactor).
    pub rest: BTreeMap<u64, Rest>,
    /// How the extrinsics and the time offset enter the next solves (fixed, held at their
    /// configured values, or free; see [`super::calibration`]).
    pub calibration: CalibrationGates,
    /// GNSS fixes, wheel readings and the GNSS alignment.
    pub aiding: Aiding,
    /// The biases' mean when the IMU model has a bias process (see [`super::bias_mean`]).
    pub bias_mean: Option<BiasMean>,
}

impl Window {
    /// An empty window with the given extrinsics and time offset.
    pub fn new(extrinsics: Vec<Pose>, td: f64) -> Self {
        Self {
            frames: VecDeque::new(),
            features: FeatureManager::default(),
            prior: None,
            extrinsics,
            td,
            points: BTreeMap::new(),
            next_point: 0,
            rest: BTreeMap::new(),
            calibration: CalibrationGates::default(),
            aiding: Aiding::default(),
            bias_mean: None,
        }
    }

    /// Index in the window of frame `seq`.
    pub fn frame_index(&self, seq: u64) -> Option<usize> {
        self.frames.iter().position(|f| f.seq == seq)
    }

    /// What persistent point `key`'s coordinates are (world coordinates for a key not held).
    pub fn point_form(&self, key: u64) -> PointForm {
        self.points.get(&key).map_or(PointForm::World, |p| p.form)
    }

    /// `T_w_c` of camera `cam` at window frame `idx`.
    pub fn camera_pose(&self, idx: usize, cam: usize) -> Pose {
        self.frames[idx].pose.compose(&self.extrinsics[cam])
    }

    /// World position of a track's landmark.
    pub fn track_world_point(&self, id: u64) -> Option<Vector3<f64>> {
        let t = self.features.tracks.get(&id)?;
        if let Some(k) = t.point {
            return self.points.get(&k).map(PersistentPoint::world);
        }
        let d = t.inv_depth?;
        let m = t.anchor_measurement()?.point + t.bearing;
        let fi = self.frame_index(t.obs[0].seq)?;
        let p_c = Vector3::new(m.x, m.y, 1.0) / d;
        Some(self.camera_pose(fi, t.anchor_cam).transform(&p_c))
    }

    /// Builds the window problem at the current estimates: poses (and speed-biases when
    /// `imu_active`), extrinsics, time offset, the prior, IMU factors and the reprojection
    /// factors of every triangulated track (landmarks as inverse-depth blocks).
    pub fn build(&self, settings: &ProblemSettings<'_>, imu_active: bool) -> WindowProblem {
        let config = settings.config;
        let mut problem = Problem::new();
        let mut refs = Vec::new();
        let pose_m: Arc<PoseManifold> = Arc::new(PoseManifold);
        let sb_m = Arc::new(Euclidean::new(9));
        let one = Arc::new(Euclidean::new(1));
        for f in &self.frames {
            let b = problem
                .add_block(&f.pose.to_array(), pose_m.clone(), BlockKind::State)
                .expect("finite pose");
            refs.push((BlockRef::Pose(f.seq), b));
            if imu_active {
                let sb: Vec<f64> =
                    f.v.iter()
                        .chain(f.ba.iter())
                        .chain(f.bg.iter())
                        .copied()
                        .collect();
                let b = problem
                    .add_block(&sb, sb_m.clone(), BlockKind::State)
                    .expect("finite");
                refs.push((BlockRef::SpeedBias(f.seq), b));
            }
        }
        for (i, e) in self.extrinsics.iter().enumerate() {
            let b = problem
                .add_block(&e.to_array(), pose_m.clone(), BlockKind::State)
                .expect("finite");
            problem.set_constant(b, !(self.calibration.extrinsics_variable() && imu_active));
            refs.push((BlockRef::Extrinsic(i), b));
        }
        let td_block = problem
            .add_block(&[self.td], one.clone(), BlockKind::State)
            .expect("finite");
        let point_m = Arc::new(Euclidean::new(3));
        let mut points = Vec::with_capacity(self.points.len());
        for (k, x) in &self.points {
            // States, not eliminated landmarks: the prior couples them to the frames.
            let b = problem
                .add_block(x.coords.as_slice(), point_m.clone(), BlockKind::State)
                .expect("finite");
            refs.push((BlockRef::Point(*k), b));
            points.push((*k, b));
        }
        // Vision alone cannot tell a time offset from motion: td is estimated only against
        // the IMU.
        problem.set_constant(td_block, !(self.calibration.td_variable() && imu_active));
        refs.push((BlockRef::Td, td_block));
        let mut built = WindowProblem::new(problem, refs, points);
        self.calibration.add_priors(&mut built, config);
        if imu_active {
            self.aiding.add_alignment_block(&mut built);
        }
        let process = config.imu_noise_model.bias_process();
        let mean_block = bias_mean::add_block(
            self.bias_mean.as_ref(),
            &self.frames,
            self.prior.as_ref(),
            process.as_ref(),
            imu_active,
            &mut built,
        );
        if !imu_active {
            // Vision only: the oldest pose fixes the gauge.
            let oldest = self.frames.front().map(|f| f.seq);
            if let Some(b) = oldest.and_then(|seq| built.block(BlockRef::Pose(seq))) {
                built.problem.set_constant(b, true);
            }
        }

        // Prior.
        if let Some((factor, blocks)) = &self.prior {
            let ids: Option<Vec<BlockId>> = blocks.iter().map(|r| built.block(*r)).collect();
            if let Some(ids) = ids {
                let f: Arc<dyn Factor> = factor.clone();
                built.prior = built.problem.add_factor(f, None, &ids).ok();
                if built.prior.is_some() && config.first_estimate_jacobians {
                    // Every factor sees a prior state at the prior's linearization point.
                    for ((id, r), x0) in ids.iter().zip(blocks).zip(factor.linearization_points()) {
                        if matches!(r, BlockRef::Point(_)) && !config.first_estimate_points {
                            continue;
                        }
                        built
                            .problem
                            .set_linearization_point(*id, x0)
                            .expect("the prior's own point fits its block");
                    }
                }
            }
        }

        // IMU.
        if imu_active {
            for k in 1..self.frames.len() {
                let (a, b) = (&self.frames[k - 1], &self.frames[k]);
                let sb_a = built.block(BlockRef::SpeedBias(a.seq)).expect("sb");
                let sb_b = built.block(BlockRef::SpeedBias(b.seq)).expect("sb");
                // With a bias process its mean is there too (the IMU is active).
                let with_mean = process.as_ref().zip(mean_block);
                let factor = b.preint.as_ref().and_then(|p| match with_mean {
                    Some((process, _)) => ImuFactor::with_bias_process(p, process).ok(),
                    None => ImuFactor::new(p).ok(),
                });
                let Some(factor) = factor else {
                    // No IMU interval (a dropout): the biases still follow their model.
                    let dt = (b.t_ns - a.t_ns) as f64 * 1e-9;
                    let factor =
                        bias_mean::bias_step(dt, &config.imu_noise, with_mean.map(|(p, _)| p));
                    let mut ids = vec![sb_a, sb_b];
                    ids.extend(with_mean.map(|(_, c)| c));
                    let r = built
                        .problem
                        .add_factor(Arc::new(factor), None, &ids)
                        .expect("sizes match");
                    built.imu.push((r, k));
                    continue;
                };
                let mut ids = vec![
                    built.block(BlockRef::Pose(a.seq)).expect("pose"),
                    sb_a,
                    built.block(BlockRef::Pose(b.seq)).expect("pose"),
                    sb_b,
                ];
                ids.extend(with_mean.map(|(_, c)| c));
                let r = built
                    .problem
                    .add_factor(Arc::new(factor), None, &ids)
                    .expect("sizes match");
                built.imu.push((r, k));
            }
        }
        if imu_active {
            self.add_zero_velocity_factors(&mut built, config);
            self.aiding.add_factors(&self.frames, &mut built, config);
        }
        self.add_visual_factors(&mut built, settings, td_block);
        built
    }

    /// A [`ZeroVelocityFactor`](crate::factors::ZeroVelocityFactor) on the speed-bias of every window frame detected at rest.
    fn add_zero_velocity_factors(&self, built: &mut WindowProblem, config: &EstimatorConfig) {
        for (seq, rest) in &self.rest {
            let Some(sb) = built.block(BlockRef::SpeedBias(*seq)) else {
                continue;
            };
            let f = rest.factor(config.zero_velocity.velocity_sigma_m_s);
            let r = built
                .problem
                .add_factor(Arc::new(f), None, &[sb])
                .expect("sizes match");
            built.frame_factors.push((r, *seq));
        }
    }

    /// The reprojection factors of every triangulated track seen long enough.
    fn add_visual_factors(
        &self,
        built: &mut WindowProblem,
        settings: &ProblemSettings<'_>,
        td_block: BlockId,
    ) {
        let config = settings.config;
        let landmark_m = Arc::new(Euclidean::new(LANDMARK_SIZE));
        // A track must span `min_track_frames` frames, or every frame of a window that is still
        // shorter: otherwise a (re)starting window has no visual factor at all for its first
        // frames, which then come out of nothing and poison the first triangulations
        // (`min_track_frames = 4` gave 2 m errors over the first 3 s of the figure-eight).
        let min_frames = config.min_track_frames.min(self.frames.len());
        let ex: Vec<BlockId> = (0..self.extrinsics.len())
            .map(|c| built.block(BlockRef::Extrinsic(c)).expect("extrinsic"))
            .collect();
        // Pose block of each window frame, by seq (frames are in seq order).
        let pose_ids: Vec<(u64, BlockId)> = self
            .frames
            .iter()
            .filter_map(|f| built.block(BlockRef::Pose(f.seq)).map(|b| (f.seq, b)))
            .collect();
        let pose_block = |seq: u64| {
            pose_ids
                .binary_search_by_key(&seq, |(s, _)| *s)
                .ok()
                .map(|i| pose_ids[i].1)
        };
        for (id, track) in &self.features.tracks {
            if let Some(k) = track.point {
                self.add_point_factors(built, settings, k, track, &ex, td_block);
                continue;
            }
            let Some(inv_depth) = track.inv_depth else {
                continue;
            };
            if track.obs.len() < min_frames || track.measurement_count() < 2 {
                continue;
            }
            let anchor = &track.obs[0];
            let a = track.anchor_cam;
            let Some(obs_i) = anchor.meas[a] else {
                continue;
            };
            let Some(pose_i) = pose_block(anchor.seq) else {
                continue;
            };
            let (bx, by) = (track.bearing.x, track.bearing.y);
            let lm = built
                .problem
                .add_block(
                    &[inv_depth, bx, by],
                    landmark_m.clone(),
                    BlockKind::Landmark,
                )
                .expect("finite");
            built.landmarks.push((*id, lm));
            let loss = Some(settings.huber.clone());
            // The anchor observation: its noise is estimated, not taken as exact.
            let bearing = AnchorBearing {
                weight: anchor.weight[a],
            };
            let r = built
                .problem
                .add_factor(Arc::new(bearing), loss.clone(), &[lm])
                .expect("sizes");
            built.visual.push((r, *id));
            // The other cameras in the anchor frame.
            for c in (0..2).filter(|&c| c != a) {
                let Some(obs_b) = anchor.meas[c] else {
                    continue;
                };
                let f = ProjectionOneFrameTwoCam {
                    obs_a: obs_i,
                    obs_b,
                    weight: anchor.weight[c],
                };
                let r = built
                    .problem
                    .add_factor(Arc::new(f), loss.clone(), &[ex[a], ex[c], lm, td_block])
                    .expect("sizes");
                built.visual.push((r, *id));
            }
            for o in &track.obs[1..] {
                let Some(pose_j) = pose_block(o.seq) else {
                    continue;
                };
                for (c, obs_j) in o.meas.iter().enumerate() {
                    let Some(obs_j) = *obs_j else {
                        continue;
                    };
                    let r = if c == a {
                        let f = ProjectionTwoFrameOneCam {
                            obs_i,
                            obs_j,
                            weight: o.weight[c],
                        };
                        built.problem.add_factor(
                            Arc::new(f),
                            loss.clone(),
                            &[pose_i, pose_j, ex[a], lm, td_block],
                        )
                    } else {
                        let f = ProjectionTwoFrameTwoCam {
                            obs_i,
                            obs_j,
                            weight: o.weight[c],
                        };
                        built.problem.add_factor(
                            Arc::new(f),
                            loss.clone(),
                            &[pose_i, pose_j, ex[a], ex[c], lm, td_block],
                        )
                    };
                    built.visual.push((r.expect("sizes"), *id));
                }
            }
        }
    }

    /// The factors of a track carried by persistent world point `key`: one
    /// [`WorldPointProjection`] per observation.
    #[allow(clippy::too_many_arguments)]
    fn add_point_factors(
        &self,
        built: &mut WindowProblem,
        settings: &ProblemSettings<'_>,
        key: u64,
        track: &Track,
        ex: &[BlockId],
        td_block: BlockId,
    ) {
        let (Some(pb), Some(point)) = (
            built
                .points
                .iter()
                .find(|(k, _)| *k == key)
                .map(|(_, b)| *b),
            self.points.get(&key),
        ) else {
            return;
        };
        for o in &track.obs {
            let Some(pose) = built.block(BlockRef::Pose(o.seq)) else {
                continue;
            };
            for (c, m) in o.meas.iter().enumerate() {
                let Some(obs) = *m else { continue };
                let f = WorldPointProjection {
                    obs,
                    weight: o.weight[c],
                    form: point.form,
                };
                let r = built
                    .problem
                    .add_factor(
                        Arc::new(f),
                        Some(settings.huber.clone()),
                        &[pose, ex[c], pb, td_block],
                    )
                    .expect("sizes");
                built.point_obs.push((r, key, o.seq));
            }
        }
    }

    /// Makes the live tracks anchored in the oldest frame persistent world points, before that
    /// frame is marginalized (its inverse-depth landmarks would otherwise leave with it and
    /// their tracks end): those seen in the newest frame, spread over the view (longest, then
    /// oldest, first within a cell; [`point_selection`]), up to `max_persistent_points` in the
    /// window. Exact at the current estimates.
    pub fn promote_to_points(&mut self, config: &EstimatorConfig) {
        let room = config
            .max_persistent_points
            .saturating_sub(self.points.len());
        let (Some(oldest), Some(newest)) = (self.frames.front(), self.frames.back()) else {
            return;
        };
        let (oldest, newest) = (oldest.seq, newest.seq);
        let mut candidates: Vec<(usize, u64)> = self
            .features
            .tracks
            .iter()
            .filter(|(_, t)| {
                t.point.is_none()
                    && t.inv_depth.is_some()
                    && t.obs[0].seq == oldest
                    && t.obs.last().is_some_and(|o| o.seq == newest)
            })
            .map(|(id, t)| (t.obs.len(), *id))
            .collect();
        candidates.sort_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
        // The cell of a track's bearing in the newest frame.
        let seen_cell = |t: &Track| {
            let o = t.obs.last()?;
            let c = o.first_camera()?;
            Some(point_selection::cell(c, &o.meas[c].as_ref()?.point))
        };
        let kept = self
            .features
            .tracks
            .values()
            .filter(|t| t.point.is_some() && t.obs.last().is_some_and(|o| o.seq == newest));
        let occupied: Vec<_> = kept.filter_map(seen_cell).collect();
        let cells: Vec<_> = candidates
            .iter()
            .map(|(_, id)| seen_cell(&self.features.tracks[id]).unwrap_or((0, 0, 0)))
            .collect();
        for i in point_selection::spread(&cells, occupied, room) {
            let id = candidates[i].1;
            let Some(x) = self.track_world_point(id) else {
                continue;
            };
            // Inverse-distance points are anchored at the camera their track was anchored in.
            let t = &self.features.tracks[&id];
            let anchor = self.camera_pose(0, t.anchor_cam);
            let key = self.next_point;
            self.next_point += 1;
            self.points.insert(
                key,
                PersistentPoint::new(config.point_coordinates, x, &anchor),
            );
            self.features.tracks.get_mut(&id).expect("candidate").point = Some(key);
        }
    }

    /// Forgets the persistent points `keys` (sorted) and their tracks, every observation of
    /// which the prior now holds.
    pub fn forget_points(&mut self, keys: &[u64]) {
        if keys.is_empty() {
            return;
        }
        let lost = |k: &u64| keys.binary_search(k).is_ok();
        self.features
            .tracks
            .retain(|_, t| !t.point.as_ref().is_some_and(lost));
        self.points.retain(|k, _| !lost(k));
    }

    /// Forgets persistent points that no track carries and no prior holds.
    pub fn drop_unused_points(&mut self) {
        let carried: Vec<u64> = self
            .features
            .tracks
            .values()
            .filter_map(|t| t.point)
            .collect();
        let prior = self.prior.as_ref().map(|(_, refs)| refs.as_slice());
        self.points.retain(|k, _| {
            carried.contains(k) || prior.is_some_and(|r| r.contains(&BlockRef::Point(*k)))
        });
    }

    /// Copies the solved values back into the window; landmarks outside the configured depth
    /// range lose their depth, and preintegrations are re-linearized when the biases moved.
    pub fn write_back(&mut self, built: &WindowProblem, config: &EstimatorConfig) {
        for f in self.frames.iter_mut() {
            if let Some(b) = built.block(BlockRef::Pose(f.seq)) {
                f.pose = Pose::from_slice(built.problem.values(b));
            }
            if let Some(b) = built.block(BlockRef::SpeedBias(f.seq)) {
                let v = built.problem.values(b);
                f.v = Vector3::new(v[0], v[1], v[2]);
                f.ba = Vector3::new(v[3], v[4], v[5]);
                f.bg = Vector3::new(v[6], v[7], v[8]);
            }
        }
        for (i, e) in self.extrinsics.iter_mut().enumerate() {
            if let Some(b) = built.block(BlockRef::Extrinsic(i)) {
                *e = Pose::from_slice(built.problem.values(b));
            }
        }
        if let Some(b) = built.block(BlockRef::Td) {
            self.td = built.problem.values(b)[0];
        }
        self.aiding.write_back_alignment(built);
        if let Some(mean) = bias_mean::read_back(built) {
            self.bias_mean = Some(mean);
        }
        for (k, b) in &built.points {
            if let Some(x) = self.points.get_mut(k) {
                let v = built.problem.values(*b);
                x.coords = Vector3::new(v[0], v[1], v[2]);
            }
        }
        for (id, b) in &built.landmarks {
            let l = built.problem.values(*b);
            if let Some(t) = self.features.tracks.get_mut(id) {
                let (d, depth) = (l[0], 1.0 / l[0]);
                if d.is_finite() && depth >= config.min_depth_m && depth <= config.max_depth_m {
                    t.inv_depth = Some(d);
                    t.bearing = nalgebra::Vector2::new(l[1], l[2]);
                } else {
                    t.set_inv_depth(None);
                }
            }
        }
        // Keep the preintegrations' linearization points close to the estimates.
        let (tba, tbg) = (config.repropagate_ba, config.repropagate_bg);
        for k in 1..self.frames.len() {
            let (ba, bg) = (self.frames[k - 1].ba, self.frames[k - 1].bg);
            if let Some(p) = &mut self.frames[k].preint {
                p.repropagate_if_needed(ba, bg, tba, tbg);
            }
        }
    }

    /// Removes the oldest frame and returns it. Tracks anchored in it: when `in_prior` (their
    /// landmark and observations went into the prior) the track ends here, so a later sighting
    /// of the same feature starts a new track; otherwise they are re-anchored in their next
    /// view (by the same camera if it has one, see `Track::reanchor`), keeping their world
    /// point when its depth there is in range.
    pub fn remove_oldest(&mut self, in_prior: bool, config: &EstimatorConfig) -> WindowFrame {
        let removed_seq = self.frames[0].seq;
        self.rest.remove(&removed_seq);
        let ids: Vec<u64> = self.features.tracks.keys().copied().collect();
        for id in ids {
            if self.features.tracks[&id].obs[0].seq != removed_seq {
                continue;
            }
            let t = self.features.tracks.get_mut(&id).expect("exists");
            if t.point.is_some() {
                // A persistent point's observation in the removed frame is in the prior.
                t.obs.remove(0);
                if t.obs.is_empty() {
                    self.features.tracks.remove(&id);
                }
                continue;
            }
            if in_prior {
                self.features.tracks.remove(&id);
                continue;
            }
            let world = self.track_world_point(id);
            let t = self.features.tracks.get_mut(&id).expect("exists");
            t.obs.remove(0);
            if !t.reanchor() {
                self.features.tracks.remove(&id);
                continue;
            }
            t.set_inv_depth(None);
            let (new_anchor, cam) = (t.obs[0].seq, t.anchor_cam);
            if let (Some(p_w), Some(fi)) = (world, self.frame_index(new_anchor)) {
                let z = self.camera_pose(fi, cam).inverse().transform(&p_w).z;
                if z >= config.min_depth_m && z <= config.max_depth_m {
                    self.features
                        .tracks
                        .get_mut(&id)
                        .expect("exists")
                        .set_inv_depth(Some(1.0 / z));
                }
            }
        }
        let removed = self.frames.pop_front().expect("non-empty window");
        self.aiding.trim(&self.frames, &removed);
        removed
    }

    /// Removes the second-newest frame and returns it: its IMU interval is merged into the
    /// newest frame's (the returned frame keeps none), its observations leave their tracks (a track that loses its anchor is
    /// re-anchored and re-triangulated).
    pub fn remove_second_newest(&mut self) -> WindowFrame {
        let n = self.frames.len();
        let mut dropped = self.frames.remove(n - 2).expect("exists");
        let drop = dropped.seq;
        self.rest.remove(&drop);
        let newest = self.frames.back_mut().expect("exists");
        if let (Some(mut a), Some(b)) = (dropped.preint.take(), newest.preint.take()) {
            newest.preint = a.merge(&b).is_ok().then_some(a);
        }
        let ids: Vec<u64> = self.features.tracks.keys().copied().collect();
        for id in ids {
            let t = self.features.tracks.get_mut(&id).expect("exists");
            let Some(k) = t.obs.iter().position(|o| o.seq == drop) else {
                continue;
            };
            t.obs.remove(k);
            if k == 0 && t.point.is_none() {
                // The anchor left: re-anchor and re-triangulate from what remains.
                t.reanchor();
                t.set_inv_depth(None);
            }
            if t.obs.is_empty() {
                self.features.tracks.remove(&id);
            }
        }
        dropped
    }
}
