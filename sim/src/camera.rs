//! Feature-level cameras: a rig of N cameras observing the scene's landmarks.
//!
//! # Frame timing
//! Frame `i` is captured at true time `t_i = i·period` and stamped in the camera clock as
//! `t_i − td_ns` (VINS-Fusion's convention `t_imu = t_cam + td`). All cameras of the rig are
//! synchronized and produce one [`FeatureFrame`].
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
//! grid, in an order drawn from the camera's own stream `<name>/select`. Feature ids are the
//! landmark ids, stable across cameras and time. A camera's output depends only on itself and
//! the cameras before it, so appending a camera never changes the others.
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
//! drawn from the stream `<name>` in feature-id order.

use crate::motion::TruthBuffer;
use crate::rng::sensor_rng;
use crate::scene::{Landmark, Scene};
use estimator::camera::CameraModel;
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
    /// Nearest visible depth (m).
    pub min_depth: f64,
    /// Farthest visible depth (m).
    pub max_depth: f64,
    /// Most features reported per frame.
    pub max_features: usize,
    /// Longest track (frames) before the landmark is dropped; `None` for unlimited.
    pub max_track_length: Option<u32>,
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
            min_depth: 0.1,
            max_depth: 40.0,
            max_features: 150,
            max_track_length: None,
        }
    }
}

/// A synchronized camera rig.
#[derive(Clone, Debug)]
pub struct RigConfig {
    /// The cameras; index = `cam_id`.
    pub cameras: Vec<CameraConfig>,
    /// Frame rate (Hz); `1e9 / rate_hz` must be a whole number of nanoseconds.
    pub rate_hz: f64,
    /// Camera-IMU time offset (ns): frames captured at `t` are stamped `t − td_ns`.
    pub td_ns: i64,
    /// Seed new landmarks where a view runs short (see the module docs). Off by default: the
    /// presets' landmark density already fills most views, and seeding changes the stream.
    pub reseed: bool,
}

impl RigConfig {
    /// A rig of `cameras` at 20 Hz without time offset.
    pub fn new(cameras: Vec<CameraConfig>) -> Self {
        Self {
            cameras,
            rate_hz: 20.0,
            td_ns: 0,
            reseed: false,
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

    /// Frame period (ns).
    pub fn period_ns(&self) -> i64 {
        (1e9 / self.rate_hz).round() as i64
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
    period_ns: i64,
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
            })
            .collect();
        Self {
            period_ns: cfg.period_ns(),
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

    /// Internal index (into the per-camera track arrays) of feature id `id`.
    fn index_of(&self, id: u64) -> usize {
        if id < SEEDED_ID_BASE {
            id as usize
        } else {
            self.seeded_index[&id]
        }
    }

    /// The landmark with feature id `id` (scene or seeded), if it exists.
    pub fn landmark(&self, id: u64) -> Option<&Landmark> {
        let n = self.scene.landmarks.len();
        if id < SEEDED_ID_BASE {
            self.scene.landmarks.get(id as usize)
        } else {
            let i = *self.seeded_index.get(&id)?;
            Some(&self.seeded[i - n].0)
        }
    }

    /// The configuration.
    pub fn config(&self) -> &RigConfig {
        &self.cfg
    }

    /// True capture time of the next frame (ns).
    pub fn next_capture_ns(&self) -> i64 {
        i64::from(self.next_i) * self.period_ns
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
        let lm = self.landmark(id)?;
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
            let feats = self.track_camera(ci, frame_idx, &t_w_b, &cameras);
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

    fn track_camera(
        &mut self,
        ci: usize,
        frame: u32,
        t_w_b: &Pose,
        earlier: &[CameraFeatures],
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
                // Seeded landmarks of later cameras do not exist for this one.
                if self
                    .seeded_index
                    .get(&f.feature_id)
                    .is_some_and(|&i| self.seeded[i - self.scene.landmarks.len()].1 > ci)
                {
                    continue;
                }
                let i = self.index_of(f.feature_id);
                let st = &self.cams[ci];
                if st.rest_until[i] > frame || st.track_start[i] != u32::MAX {
                    continue;
                }
                if let Some(p) = self.project_one(c, &t_c_w, &o, f.feature_id) {
                    occupancy[cell(&p.uv)] += 1;
                    self.cams[ci].track_start[i] = frame;
                    kept.push(p);
                }
            }
        }
        // 3. New features, spread over the grid.
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
                    }
                    if let Some(p) = self.project_one(&c, &t_c_w, &o, id) {
                        occupancy[k] += 1;
                        self.cams[ci].track_start[ix] = frame;
                        kept.push(p);
                    }
                }
            }
        }
        kept.sort_by_key(|p| p.id);
        let st = &mut self.cams[ci];
        st.tracked = kept.iter().map(|p| p.id).collect();
        let sigma = c.pixel_sigma;
        kept.iter()
            .map(|p| {
                let nx: f64 = StandardNormal.sample(&mut st.noise);
                let ny: f64 = StandardNormal.sample(&mut st.noise);
                FeatureObservation {
                    feature_id: p.id,
                    uv: p.uv + Vector2::new(nx, ny) * sigma,
                }
            })
            .collect()
    }
}
