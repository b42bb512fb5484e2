//! Feature-level cameras: a rig of N cameras observing the scene's landmarks.
//!
//! # Frame timing
//! Frame `i` is captured at true time `t_i = i·period` and stamped in the camera clock as
//! `t_i − td_ns` (VINS-Fusion's convention `t_imu = t_cam + td`). All cameras of the rig are
//! synchronized and produce one [`FeatureFrame`].
//!
//! A rolling-shutter camera (`CameraConfig::rolling_shutter`) reads its rows out one after
//! another from `t_i` on, as a driver stamps them (the stamp is the first row's time): which
//! landmarks a frame sees is decided at `t_i`, and each is then reported where the camera saw
//! it when its own row was exposed — the exact solution of "pixel = projection at the pose of
//! the pixel's row time" (`RigSim::rolling_shutter_projection`).
//!
//! # Visibility
//! A landmark is visible in camera `c` when it faces the camera (its surface normal points
//! towards it), its depth lies in `[min_depth, max_depth]`, the model projects it
//! ([`CameraModel::project`]) to a pixel inside the image and the model's valid region
//! ([`CameraModel::is_valid`]), and the segment to it crosses no scene box (occlusion).
//!
//! # Tracks
//! Like a tracker's output, each camera keeps a set of tracked landmarks from frame to frame:
//! tracked landmarks that stay visible are kept (until `max_track_length` frames, after which
//! the landmark rests for as many frames in that camera), camera `c > 0` first adopts landmarks
//! that cameras `0..c` report in the same frame (stereo association by landmark id), and free
//! slots up to `max_features` are filled with new visible landmarks spread over an 8 × 6 image
//! grid, in an order drawn from the camera's own stream `<name>/select`. A camera's output
//! depends only on itself and the cameras before it, so appending a camera never changes the
//! others.
//!
//! # Feature ids
//! [`TrackIds::Realistic`] (the default) gives ids as a tracker would: a track that a camera
//! starts gets a new id, kept while the camera tracks it and taken over by later cameras that
//! adopt it (stereo association); a landmark lost and later re-acquired is a new track with a
//! new id, and an observation whose noisy pixel falls outside the image is dropped and ends its
//! track. The id is `key | camera << 40 | episode << 48`: the landmark (its scene index, or
//! for a seeded landmark `1 << 39 | seeder << 32 | k`), the camera that started the track, and
//! how many tracks of that landmark the camera started before (modulo 2¹⁶), so
//! [`RigSim::landmark`] still resolves it and a camera's ids never depend on later cameras.
//! [`TrackIds::Landmark`] reports the landmark ids themselves, stable across cameras and time:
//! ideal association, where a landmark seen again after a gap is re-associated for free (for
//! studies that want it).
//!
//! # Re-seeding
//! Where a view runs short — fewer than `max_features` after the steps above — the camera seeds
//! new landmarks (`RigConfig::reseed`): for each empty grid cell it casts a ray through a pixel
//! drawn from its stream `<name>/reseed` and puts a landmark where the ray first meets a scene
//! surface within the depth range. Seeded landmarks get ids `SEEDED_ID_BASE + (camera << 32) + k` and stay in
//! the world; camera `c` sees those seeded by cameras `0..=c` only, so appending a camera still
//! never changes the others.
//!
//! # Noise
//! Each observation is the true distorted pixel plus isotropic Gaussian noise `pixel_sigma`
//! drawn from the stream `<name>` in feature-id order; or, under a tracker error model
//! (`CameraConfig::tracker_error`), the error a tracker makes in motion, drawn per track from
//! the stream `<name>/tracker` ([`crate::tracker_error`]).

use crate::motion::TruthBuffer;
use crate::rng::sensor_rng;
use crate::scene::{Landmark, Scene};
use crate::tracker_error::{TrackErrors, TrackerErrorModel};
use estimator::camera::{CameraModel, RollingShutter, in_image};
use estimator::frontend::{CameraFeatures, FeatureFrame, FeatureObservation};
use estimator::geometry::Pose;
use nalgebra::{Vector2, Vector3};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::sync::Arc;

/// One camera of the rig.
#[derive(Clone, Debug)]
pub struct CameraConfig {
    /// Sensor name (selects its random streams).
    pub name: String,
    /// Projection model (resolution included).
    pub model: Arc<dyn CameraModel>,
    /// Extrinsic `T_b_c` (camera to body).
    pub t_b_c: Pose,
    /// Pixel noise standard deviation (px).
    pub pixel_sigma: f64,
    /// The pixel error drawn as a tracker's in motion (drift, sliding tracks, stereo
    /// matches following their leader) in place of the Gaussian of `pixel_sigma`.
    pub tracker_error: Option<TrackerErrorModel>,
    /// Nearest visible depth (m).
    pub min_depth: f64,
    /// Farthest visible depth (m).
    pub max_depth: f64,
    /// Most features reported per frame.
    pub max_features: usize,
    /// Longest track (frames) before the landmark is dropped; `None` for unlimited.
    pub max_track_length: Option<u32>,
    /// The readout: each row is exposed at its own time after the frame's capture time
    /// ([`RollingShutter::GLOBAL`]: every row at the capture time).
    pub rolling_shutter: RollingShutter,
}

impl CameraConfig {
    /// A camera with the usual front-end settings: σ = 0.5 px, depth 0.1–40 m, 150 features,
    /// unlimited track length.
    pub fn new(name: &str, model: Arc<dyn CameraModel>, t_b_c: Pose) -> Self {
        Self {
            name: name.into(),
            model,
            t_b_c,
            pixel_sigma: 0.5,
            tracker_error: None,
            min_depth: 0.1,
            max_depth: 40.0,
            max_features: 150,
            max_track_length: None,
            rolling_shutter: RollingShutter::GLOBAL,
        }
    }
}

/// Most fixed-point steps of a rolling-shutter projection (see
/// `RigSim::rolling_shutter_projection`).
const MAX_ROW_ITERATIONS: usize = 20;

/// How feature ids are assigned (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TrackIds {
    /// A new id for every track, as a tracker outputs.
    #[default]
    Realistic,
    /// The landmark's id, stable over time (ideal re-association).
    Landmark,
}

/// Bits of a realistic feature id that name the landmark (see the module docs).
const KEY_BITS: u64 = 40;
/// The key bit that marks a seeded landmark.
const SEEDED_KEY_BIT: u64 = 1 << (KEY_BITS - 1);

/// The key of landmark id `id` in a realistic feature id (a scene id as is; a seeded id
/// `SEEDED_ID_BASE + (seeder << 32) + k` as `SEEDED_KEY_BIT | seeder << 32 | k`).
fn landmark_key(id: u64) -> u64 {
    if id < SEEDED_ID_BASE {
        id
    } else {
        (id - SEEDED_ID_BASE) | SEEDED_KEY_BIT
    }
}

/// The landmark id a realistic feature id names (the inverse of [`landmark_key`]).
fn key_landmark_id(feature_id: u64) -> u64 {
    let key = feature_id & ((1 << KEY_BITS) - 1);
    if key & SEEDED_KEY_BIT == 0 {
        key
    } else {
        SEEDED_ID_BASE + (key & !SEEDED_KEY_BIT)
    }
}
/// Bits of a realistic feature id that hold the camera that started the track; the episode
/// takes the remaining 16.
const CAMERA_BITS: u64 = 8;

/// A synchronized camera rig.
#[derive(Clone, Debug)]
pub struct RigConfig {
    /// The cameras; index = `cam_id`.
    pub cameras: Vec<CameraConfig>,
    /// Frame rate (Hz). Frame `i` is captured at `i / rate_hz` rounded to the nanosecond
    /// ([`RigConfig::capture_ns`]), so a rate whose period is not a whole number of nanoseconds
    /// (30 Hz, 15 Hz) keeps its average rate; its periods differ by at most 1 ns.
    pub rate_hz: f64,
    /// Camera-IMU time offset (ns): frames captured at `t` are stamped `t − td_ns`.
    pub td_ns: i64,
    /// Seed new landmarks where a view runs short (see the module docs). Off by default: the
    /// presets' landmark density already fills most views, and seeding changes the stream.
    pub reseed: bool,
    /// How feature ids are assigned (default [`TrackIds::Realistic`]).
    pub track_ids: TrackIds,
}

impl RigConfig {
    /// A rig of `cameras` at 20 Hz without time offset.
    pub fn new(cameras: Vec<CameraConfig>) -> Self {
        Self {
            cameras,
            rate_hz: 20.0,
            td_ns: 0,
            reseed: false,
            track_ids: TrackIds::Realistic,
        }
    }

    /// A stereo pair of `model` looking along body +x (camera x = body −y, camera y = body −z;
    /// the generators' body frame has z up), `baseline_m` apart along body y, named `cam0`
    /// (left, +y) and `cam1`; 20 Hz.
    pub fn stereo_forward(model: Arc<dyn CameraModel>, baseline_m: f64) -> Self {
        let r = nalgebra::Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
        let q = nalgebra::UnitQuaternion::from_matrix(&r);
        let b = 0.5 * baseline_m;
        Self::new(vec![
            CameraConfig::new(
                "cam0",
                model.clone(),
                Pose::new(q, Vector3::new(0.0, b, 0.0)),
            ),
            CameraConfig::new("cam1", model, Pose::new(q, Vector3::new(0.0, -b, 0.0))),
        ])
    }

    /// The EuRoC-like stereo rig of DESIGN.md: two EuRoC `cam0` pinhole-radtan models
    /// (752×480) 0.11 m apart, looking along body +x ([`RigConfig::stereo_forward`]), 20 Hz.
    pub fn euroc_like() -> Self {
        let model: Arc<dyn CameraModel> = Arc::new(estimator::camera::Camera::PinholeRadtan(
            estimator::camera::PinholeRadtan::euroc_cam0(),
        ));
        Self::stereo_forward(model, 0.11)
    }

    /// Nominal frame period (ns, rounded): for magnitudes such as timestamp jitter; frame times
    /// come from [`RigConfig::capture_ns`].
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round() as i64
    }

    /// True capture time of frame `i` (ns): `i · 10⁹ / rate_hz`, rounded. Exact multiples of
    /// the period when it is a whole number of nanoseconds (the product and quotient are exact
    /// in `f64` for any frame count below 2⁵³ / 10⁹, some 285 years at 1 kHz).
    pub fn capture_ns(&self, i: u64) -> i64 {
        (i as f64 * 1e9 / self.rate_hz).round() as i64
    }

    /// The index of the last frame captured at or before `t_ns` (0 for `t_ns` before frame 1).
    pub fn frame_at_or_before(&self, t_ns: i64) -> u64 {
        let mut k = (t_ns.max(0) as f64 * self.rate_hz / 1e9).floor() as u64;
        while k > 0 && self.capture_ns(k) > t_ns {
            k -= 1;
        }
        while self.capture_ns(k + 1) <= t_ns {
            k += 1;
        }
        k
    }
}

/// Per-camera tracking state.
#[derive(Debug)]
struct CamState {
    noise: ChaCha8Rng,
    select: ChaCha8Rng,
    reseed: ChaCha8Rng,
    /// Currently tracked landmark ids, sorted.
    tracked: Vec<u64>,
    /// Frame index at which each landmark's current track started (u32::MAX: not tracked).
    track_start: Vec<u32>,
    /// Frame index before which each landmark may not be re-tracked.
    rest_until: Vec<u32>,
    /// Feature id of each landmark's current track (meaningful while it is tracked).
    track_id: Vec<u64>,
    /// Tracks of each landmark this camera has started (realistic ids).
    episodes: Vec<u32>,
    /// The tracks' errors under a tracker error model (`None`: independent Gaussian noise).
    tracker: Option<TrackErrors>,
}

/// A landmark's true projection in one camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Projection {
    /// Landmark id.
    pub id: u64,
    /// True distorted pixel.
    pub uv: Vector2<f64>,
    /// Depth along the optical axis (m).
    pub depth: f64,
}

/// Generates feature frames for a rig.
#[derive(Debug)]
pub struct RigSim {
    cfg: RigConfig,
    scene: Arc<Scene>,
    next_i: u32,
    cams: Vec<CamState>,
    /// Landmarks seeded by the cameras, with their seeder, in seeding order (internal index =
    /// scene landmark count + position here).
    seeded: Vec<(Landmark, usize)>,
    /// Feature id of a seeded landmark → its internal index.
    seeded_index: std::collections::BTreeMap<u64, usize>,
    /// Landmarks seeded so far by each camera.
    seeded_by: Vec<u64>,
}

/// Feature ids of seeded landmarks: `SEEDED_ID_BASE + (camera << 32) + k` for the camera's k-th
/// seed, so a camera's ids do not depend on what other cameras seeded.
pub const SEEDED_ID_BASE: u64 = 1 << 48;

/// Grid used to spread new features over the image.
const GRID: (usize, usize) = (8, 6);

impl RigSim {
    /// A rig observing `scene`, first frame captured at `t = 0`.
    pub fn new(cfg: RigConfig, scene: Arc<Scene>, seed: u64) -> Self {
        let n = scene.landmarks.len();
        let cams: Vec<CamState> = cfg
            .cameras
            .iter()
            .map(|c| CamState {
                noise: sensor_rng(seed, &c.name),
                select: sensor_rng(seed, &format!("{}/select", c.name)),
                reseed: sensor_rng(seed, &format!("{}/reseed", c.name)),
                tracked: Vec::new(),
                track_start: vec![u32::MAX; n],
                rest_until: vec![0; n],
                track_id: vec![0; n],
                episodes: vec![0; n],
                tracker: c
                    .tracker_error
                    .map(|m| TrackErrors::new(m, sensor_rng(seed, &format!("{}/tracker", c.name)))),
            })
            .collect();
        Self {
            cfg,
            scene,
            next_i: 0,
            seeded_by: vec![0; cams.len()],
            cams,
            seeded: Vec::new(),
            seeded_index: std::collections::BTreeMap::new(),
        }
    }

    /// Number of scene landmarks (seeded ids start here).
    pub fn scene_landmark_count(&self) -> usize {
        self.scene.landmarks.len()
    }

    /// Landmarks seeded so far, with the index of the camera that seeded each.
    pub fn seeded_landmarks(&self) -> &[(Landmark, usize)] {
        &self.seeded
    }

    /// Internal index of landmark id `id`, which must exist.
    fn index_of(&self, id: u64) -> usize {
        self.landmark_index(id).expect("a landmark the rig knows")
    }

    /// Internal index (into the per-camera track arrays) of landmark id `id`, if it exists.
    fn landmark_index(&self, id: u64) -> Option<usize> {
        if id < SEEDED_ID_BASE {
            ((id as usize) < self.scene.landmarks.len()).then_some(id as usize)
        } else {
            self.seeded_index.get(&id).copied()
        }
    }

    /// Internal index of the landmark a reported feature id belongs to, if it exists.
    fn feature_index(&self, feature_id: u64) -> Option<usize> {
        match self.cfg.track_ids {
            TrackIds::Landmark => self.landmark_index(feature_id),
            TrackIds::Realistic => self.landmark_index(key_landmark_id(feature_id)),
        }
    }

    /// The landmark at internal index `ix`.
    fn landmark_at(&self, ix: usize) -> &Landmark {
        let n = self.scene.landmarks.len();
        if ix < n {
            &self.scene.landmarks[ix]
        } else {
            &self.seeded[ix - n].0
        }
    }

    /// The landmark that feature id `id` (as the rig reported it) observes, if it exists.
    pub fn landmark(&self, id: u64) -> Option<&Landmark> {
        Some(self.landmark_at(self.feature_index(id)?))
    }

    /// Gives the track of the landmark at index `ix` that camera `ci` starts its feature id.
    fn start_track_id(&mut self, ci: usize, ix: usize) {
        let lm_id = self.landmark_at(ix).id;
        let st = &mut self.cams[ci];
        st.track_id[ix] = match self.cfg.track_ids {
            TrackIds::Landmark => lm_id,
            TrackIds::Realistic => {
                let e = u64::from(st.episodes[ix] & 0xffff);
                st.episodes[ix] = st.episodes[ix].wrapping_add(1);
                landmark_key(lm_id) | (ci as u64) << KEY_BITS | e << (KEY_BITS + CAMERA_BITS)
            }
        };
    }

    /// The configuration.
    pub fn config(&self) -> &RigConfig {
        &self.cfg
    }

    /// Index of the next frame (frame `i` is captured at [`RigConfig::capture_ns`]`(i)`).
    pub fn next_index(&self) -> u64 {
        u64::from(self.next_i)
    }

    /// True capture time of the next frame (ns).
    pub fn next_capture_ns(&self) -> i64 {
        self.cfg.capture_ns(self.next_index())
    }

    /// Stamp of the next frame in the camera clock (ns).
    pub fn next_stamp_ns(&self) -> i64 {
        self.next_capture_ns() - self.cfg.td_ns
    }

    /// Every landmark visible in camera `cam` from body pose `t_w_b` (sorted by id), with its
    /// true projection: the visibility rules of the module docs.
    pub fn visible(&self, cam: usize, t_w_b: &Pose) -> Vec<Projection> {
        let c = &self.cfg.cameras[cam];
        let t_w_c = t_w_b.compose(&c.t_b_c);
        let t_c_w = t_w_c.inverse();
        let o = t_w_c.p;
        let mut out = Vec::new();
        for tile in &self.scene.tiles {
            let to_cam = o - tile.center;
            let dist = to_cam.norm();
            if tile.normal.dot(&to_cam) < -tile.radius
                || dist - tile.radius > c.max_depth
                || (t_c_w.transform(&tile.center).z < -tile.radius)
            {
                continue;
            }
            for lm in &self.scene.landmarks[tile.start..tile.end] {
                if let Some(p) = self.project_one(c, &t_c_w, &o, lm.id) {
                    out.push(p);
                }
            }
        }
        for (lm, seeder) in &self.seeded {
            if *seeder <= cam
                && let Some(p) = self.project_one(c, &t_c_w, &o, lm.id)
            {
                out.push(p);
            }
        }
        out
    }

    /// The true projection of landmark `id`, if visible (without the occlusion test).
    fn project_one(
        &self,
        c: &CameraConfig,
        t_c_w: &Pose,
        o: &Vector3<f64>,
        id: u64,
    ) -> Option<Projection> {
        let lm = self.landmark_at(self.landmark_index(id)?);
        if lm.normal.dot(&(o - lm.p)) <= 0.0 {
            return None;
        }
        let p_c = t_c_w.transform(&lm.p);
        if p_c.z < c.min_depth || p_c.z > c.max_depth {
            return None;
        }
        let uv = c.model.project(&p_c)?;
        if !c.model.is_valid(&uv) || self.scene.occluded(o, &lm.p) {
            return None;
        }
        Some(Projection {
            id,
            uv,
            depth: p_c.z,
        })
    }

    /// Generates the next frame: `(capture time, frame stamped in the camera clock)`.
    pub fn next_frame(&mut self, truth: &mut TruthBuffer) -> (i64, FeatureFrame) {
        let t_cap = self.next_capture_ns();
        let frame_idx = self.next_i;
        let t_w_b = truth
            .kinematics(t_cap)
            .expect("frame time precedes the buffered ground truth")
            .pose;
        let mut cameras: Vec<CameraFeatures> = Vec::with_capacity(self.cfg.cameras.len());
        for ci in 0..self.cfg.cameras.len() {
            let feats = self.track_camera(ci, frame_idx, &t_w_b, &cameras, (t_cap, truth));
            cameras.push(CameraFeatures {
                cam_id: ci,
                features: feats,
            });
        }
        self.next_i += 1;
        (
            t_cap,
            FeatureFrame {
                t_ns: t_cap - self.cfg.td_ns,
                cameras,
            },
        )
    }

    /// Where a rolling-shutter camera `ci` sees the landmark of `p` (its projection at the
    /// capture time `t_cap`): at the pose of the time its own row is exposed. The row depends
    /// on the projection and the projection on the row's time, so the two are iterated to a
    /// fixed point (the map contracts by `readout / height × image speed`, a few percent; it
    /// converges to 1e-9 px in a handful of steps). `None` when the point leaves the valid image
    /// or the depth range at its row's time.
    fn rolling_shutter_projection(
        &self,
        ci: usize,
        p: &Projection,
        t_cap: i64,
        truth: &mut TruthBuffer,
    ) -> Option<Projection> {
        let c = &self.cfg.cameras[ci];
        let lm = self.landmark_at(self.landmark_index(p.id)?).p;
        let height = c.model.height();
        let mut uv = p.uv;
        let mut depth = p.depth;
        for _ in 0..MAX_ROW_ITERATIONS {
            let dt_ns = (c.rolling_shutter.row_time_s(&uv, height) * 1e9).round() as i64;
            let t_w_b = truth.kinematics(t_cap + dt_ns)?.pose;
            let p_c = t_w_b.compose(&c.t_b_c).inverse().transform(&lm);
            if p_c.z < c.min_depth || p_c.z > c.max_depth {
                return None;
            }
            let next = c.model.project(&p_c)?;
            let step = (next - uv).norm();
            (uv, depth) = (next, p_c.z);
            if step < 1e-9 {
                break;
            }
        }
        c.model.is_valid(&uv).then_some(Projection {
            id: p.id,
            uv,
            depth,
        })
    }

    /// The features camera `ci` reports in frame `frame`, captured at `t_cap` (body pose
    /// `t_w_b`; rolling-shutter rows at their own times from `truth`).
    fn track_camera(
        &mut self,
        ci: usize,
        frame: u32,
        t_w_b: &Pose,
        earlier: &[CameraFeatures],
        (t_cap, truth): (i64, &mut TruthBuffer),
    ) -> Vec<FeatureObservation> {
        let c = &self.cfg.cameras[ci];
        let t_w_c = t_w_b.compose(&c.t_b_c);
        let t_c_w = t_w_c.inverse();
        let o = t_w_c.p;
        let (w, h) = (f64::from(c.model.width()), f64::from(c.model.height()));
        let cell = |uv: &Vector2<f64>| {
            let gx = ((uv.x + 0.5) / w * GRID.0 as f64).clamp(0.0, GRID.0 as f64 - 1.0) as usize;
            let gy = ((uv.y + 0.5) / h * GRID.1 as f64).clamp(0.0, GRID.1 as f64 - 1.0) as usize;
            gy * GRID.0 + gx
        };
        let max_len = c.max_track_length;
        let mut kept: Vec<Projection> = Vec::new();
        let mut occupancy = [0usize; GRID.0 * GRID.1];
        // 1. Continue tracks that stay visible and are not too long.
        let prev = std::mem::take(&mut self.cams[ci].tracked);
        for &id in &prev {
            let ix = self.index_of(id);
            let start = self.cams[ci].track_start[ix];
            let too_long = max_len.is_some_and(|l| frame - start >= l);
            let proj = if too_long {
                None
            } else {
                self.project_one(c, &t_c_w, &o, id)
            };
            let st = &mut self.cams[ci];
            match proj {
                Some(p) => {
                    occupancy[cell(&p.uv)] += 1;
                    kept.push(p);
                }
                None => {
                    st.track_start[ix] = u32::MAX;
                    if too_long {
                        st.rest_until[ix] = frame + max_len.unwrap_or(0);
                    }
                }
            }
        }
        // From here on a landmark is in `kept` exactly when its `track_start` is set.
        // 2. Stereo association: adopt what earlier cameras report now.
        for other in earlier {
            for f in &other.features {
                if kept.len() >= c.max_features {
                    break;
                }
                let Some(i) = self.feature_index(f.feature_id) else {
                    continue;
                };
                // Seeded landmarks of later cameras do not exist for this one.
                let n_scene = self.scene.landmarks.len();
                if i >= n_scene && self.seeded[i - n_scene].1 > ci {
                    continue;
                }
                let st = &self.cams[ci];
                if st.rest_until[i] > frame || st.track_start[i] != u32::MAX {
                    continue;
                }
                let id = self.landmark_at(i).id;
                if let Some(p) = self.project_one(c, &t_c_w, &o, id) {
                    occupancy[cell(&p.uv)] += 1;
                    let st = &mut self.cams[ci];
                    st.track_start[i] = frame;
                    st.track_id[i] = f.feature_id;
                    kept.push(p);
                }
            }
        }
        // 3. New features, spread over the grid (`started`: tracks this camera begins).
        let mut started: Vec<usize> = Vec::new();
        if kept.len() < c.max_features {
            let cands: Vec<Projection> = self
                .visible(ci, t_w_b)
                .into_iter()
                .filter(|p| self.cams[ci].rest_until[self.index_of(p.id)] <= frame)
                .filter(|p| self.cams[ci].track_start[self.index_of(p.id)] == u32::MAX)
                .collect();
            let cand_ix: Vec<usize> = cands.iter().map(|p| self.index_of(p.id)).collect();
            let mut cands: Vec<(Projection, usize)> = cands.into_iter().zip(cand_ix).collect();
            let st = &mut self.cams[ci];
            // Fisher-Yates with the camera's selection stream.
            for i in (1..cands.len()).rev() {
                let j = st.select.random_range(0..=i);
                cands.swap(i, j);
            }
            let cap = c.max_features.div_ceil(GRID.0 * GRID.1);
            let mut rest = Vec::new();
            for (p, ix) in cands {
                if kept.len() >= c.max_features {
                    break;
                }
                let k = cell(&p.uv);
                if occupancy[k] < cap {
                    occupancy[k] += 1;
                    st.track_start[ix] = frame;
                    started.push(ix);
                    kept.push(p);
                } else {
                    rest.push((p, ix));
                }
            }
            for (p, ix) in rest {
                if kept.len() >= c.max_features {
                    break;
                }
                st.track_start[ix] = frame;
                started.push(ix);
                kept.push(p);
            }
        }
        // 4. Re-seed empty grid cells when the view runs short.
        if self.cfg.reseed && kept.len() < c.max_features {
            let c = c.clone();
            let (w, h) = (f64::from(c.model.width()), f64::from(c.model.height()));
            let n_scene = self.scene.landmarks.len();
            let cap = c.max_features.div_ceil(GRID.0 * GRID.1);
            for k in 0..GRID.0 * GRID.1 {
                // Up to `cap` attempts to fill each short cell (a ray may miss every surface).
                for _ in 0..cap {
                    if kept.len() >= c.max_features || occupancy[k] >= cap {
                        break;
                    }
                    let (gx, gy) = ((k % GRID.0) as f64, (k / GRID.0) as f64);
                    let st = &mut self.cams[ci];
                    let px = Vector2::new(
                        (gx + st.reseed.random::<f64>()) * w / GRID.0 as f64 - 0.5,
                        (gy + st.reseed.random::<f64>()) * h / GRID.1 as f64 - 0.5,
                    );
                    let Some(bearing) = c.model.unproject(&px) else {
                        continue;
                    };
                    let d = t_w_c.q * bearing;
                    let t_max = c.max_depth / bearing.z.max(1e-3);
                    let Some((t, si)) = self.scene.ray_cast(&o, &d, 1e-6, t_max) else {
                        continue;
                    };
                    let id = SEEDED_ID_BASE + ((ci as u64) << 32) + self.seeded_by[ci];
                    self.seeded_by[ci] += 1;
                    let ix = n_scene + self.seeded.len();
                    let lm = Landmark {
                        id,
                        p: o + d * t,
                        normal: self.scene.surfaces[si].normal,
                    };
                    self.seeded.push((lm, ci));
                    self.seeded_index.insert(id, ix);
                    for cs in self.cams.iter_mut() {
                        cs.track_start.push(u32::MAX);
                        cs.rest_until.push(0);
                        cs.track_id.push(0);
                        cs.episodes.push(0);
                    }
                    if let Some(p) = self.project_one(&c, &t_c_w, &o, id) {
                        occupancy[k] += 1;
                        self.cams[ci].track_start[ix] = frame;
                        started.push(ix);
                        kept.push(p);
                    }
                }
            }
        }
        started.sort_unstable();
        for ix in started {
            self.start_track_id(ci, ix);
        }
        kept.sort_by_key(|p| p.id);
        if self.cfg.cameras[ci].rolling_shutter.is_rolling() {
            // Each feature where its row saw it; a track whose row time leaves it outside the
            // image (or behind the camera) ends.
            let mut rolled = Vec::with_capacity(kept.len());
            for p in kept {
                match self.rolling_shutter_projection(ci, &p, t_cap, truth) {
                    Some(q) => rolled.push(q),
                    None => {
                        let ix = self.index_of(p.id);
                        self.cams[ci].track_start[ix] = u32::MAX;
                    }
                }
            }
            kept = rolled;
        }
        let c = &self.cfg.cameras[ci];
        let (sigma, realistic) = (c.pixel_sigma, self.cfg.track_ids == TrackIds::Realistic);
        let kept_ix: Vec<usize> = kept.iter().map(|p| self.index_of(p.id)).collect();
        let (earlier, rest) = self.cams.split_at_mut(ci);
        let st = &mut rest[0];
        st.tracked.clear();
        if let Some(t) = &mut st.tracker {
            t.begin_frame();
        }
        let mut out = Vec::with_capacity(kept.len());
        // Noise is drawn for every tracked landmark, in landmark-id order.
        for (p, ix) in kept.iter().zip(kept_ix) {
            let uv = match &mut st.tracker {
                None => {
                    let nx: f64 = StandardNormal.sample(&mut st.noise);
                    let ny: f64 = StandardNormal.sample(&mut st.noise);
                    p.uv + Vector2::new(nx, ny) * sigma
                }
                Some(t) => {
                    let id = st.track_id[ix];
                    let leader = earlier
                        .iter()
                        .find_map(|c| c.tracker.as_ref().and_then(|t| t.reported(id)));
                    p.uv + t.error(id, leader)
                }
            };
            if realistic && !in_image(c.model.width(), c.model.height(), &uv) {
                // A tracker cannot report a pixel outside the image: the track ends.
                st.track_start[ix] = u32::MAX;
                continue;
            }
            st.tracked.push(p.id);
            out.push(FeatureObservation {
                feature_id: st.track_id[ix],
                uv,
            });
        }
        if let Some(t) = &mut st.tracker {
            t.end_frame();
        }
        out.sort_by_key(|f| f.feature_id);
        out
    }
}
