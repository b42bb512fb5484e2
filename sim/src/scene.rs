//! Procedural scenes: axis-aligned geometry with landmarks on its surfaces, and occlusion queries.
//!
//! A scene is a set of textured rectangles (the surfaces landmarks live on) and a set of
//! axis-aligned solid boxes (the occluders). Landmarks are scattered uniformly on every surface at
//! a configured density from the stream `scene` of the seed; points that fall inside a solid box
//! are discarded. Landmark ids are their indices (stable for a given seed and config).

use crate::rng::sensor_rng;
use nalgebra::Vector3;
use rand::RngExt;

/// Scene presets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ScenePreset {
    /// A Vicon room like EuRoC's V1/V2 (8 × 8 × 4 m, centred at (−0.5, 0.5)) with a few boxes
    /// along the walls and a pillar in a corner; the EuRoC V1/V2 flights stay clear of them.
    #[default]
    Room,
    /// A machine hall like EuRoC's MH sequences (30 × 26 × 12 m, floor at z = −2) with large
    /// machines along the walls.
    MachineHall,
    /// Outdoors: a 200 × 200 m ground plane at z = 0 with box buildings around the origin.
    Outdoor,
}

impl ScenePreset {
    /// The space a body may move in: the room's or hall's interior; outdoors the ground plane's
    /// extent, up to 1 km. Solid boxes inside it are excluded separately ([`Scene::boxes`]).
    pub fn free_space(self) -> Aabb {
        let v = Vector3::new;
        match self {
            ScenePreset::Room => Aabb::new(v(-4.5, -3.5, 0.0), v(3.5, 4.5, 4.0)),
            ScenePreset::MachineHall => Aabb::new(v(-12.0, -9.0, -2.0), v(18.0, 17.0, 10.0)),
            ScenePreset::Outdoor => Aabb::new(v(-100.0, -100.0, 0.0), v(100.0, 100.0, 1000.0)),
        }
    }
}

/// Scene configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneConfig {
    /// Which world.
    pub preset: ScenePreset,
    /// Landmarks per square metre of surface.
    pub landmark_density: f64,
}

impl Default for SceneConfig {
    fn default() -> Self {
        Self {
            preset: ScenePreset::Room,
            landmark_density: 8.0,
        }
    }
}

/// An axis-aligned solid box (occludes, and its faces carry landmarks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner (m).
    pub min: Vector3<f64>,
    /// Upper corner (m).
    pub max: Vector3<f64>,
}

impl Aabb {
    /// Box from its corners.
    pub fn new(min: Vector3<f64>, max: Vector3<f64>) -> Self {
        Self { min, max }
    }

    /// True if `p` is strictly inside, deeper than `margin`.
    pub fn contains(&self, p: &Vector3<f64>, margin: f64) -> bool {
        (0..3).all(|i| p[i] > self.min[i] + margin && p[i] < self.max[i] - margin)
    }

    /// Slab test: the entry parameter `t` of the ray `o + t·d` into the box, if it enters within
    /// `[0, t_max]`.
    pub fn ray_entry(&self, o: &Vector3<f64>, d: &Vector3<f64>, t_max: f64) -> Option<f64> {
        let mut t0: f64 = 0.0;
        let mut t1 = t_max;
        for i in 0..3 {
            if d[i].abs() < 1e-300 {
                if o[i] < self.min[i] || o[i] > self.max[i] {
                    return None;
                }
            } else {
                let inv = 1.0 / d[i];
                let (mut a, mut b) = ((self.min[i] - o[i]) * inv, (self.max[i] - o[i]) * inv);
                if a > b {
                    std::mem::swap(&mut a, &mut b);
                }
                t0 = t0.max(a);
                t1 = t1.min(b);
                if t0 > t1 {
                    return None;
                }
            }
        }
        Some(t0)
    }
}

/// How a surface looks to the renderer ([`crate::render`]); feature-level cameras ignore it.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum SurfaceTexture {
    /// Rich multi-scale texture (the renderer picks one of its textured materials by the seed).
    #[default]
    Rich,
    /// A texture-poor surface (a plain painted wall: faint low-frequency shading only).
    Poor,
    /// A uniform albedo in `[0, 1]` (test scenes, calibration walls).
    Plain(f64),
}

/// A rectangle `origin + s·u + t·v`, `s, t ∈ [0, 1]`, visible from the side of `normal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// A corner (m).
    pub origin: Vector3<f64>,
    /// First edge (m).
    pub u: Vector3<f64>,
    /// Second edge (m).
    pub v: Vector3<f64>,
    /// Unit normal on the visible side.
    pub normal: Vector3<f64>,
    /// Appearance in rendered images.
    pub texture: SurfaceTexture,
}

impl Surface {
    /// A richly textured rectangle.
    pub fn new(
        origin: Vector3<f64>,
        u: Vector3<f64>,
        v: Vector3<f64>,
        normal: Vector3<f64>,
    ) -> Self {
        Self {
            origin,
            u,
            v,
            normal,
            texture: SurfaceTexture::Rich,
        }
    }

    /// Area (m²).
    pub fn area(&self) -> f64 {
        self.u.cross(&self.v).norm()
    }
}

/// A 3-D point on a surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Landmark {
    /// Id (= index in [`Scene::landmarks`]; the feature id cameras report).
    pub id: u64,
    /// Position in the world (m).
    pub p: Vector3<f64>,
    /// Normal of the surface it lies on (visible only from this side).
    pub normal: Vector3<f64>,
}

/// A small flat disk for geometry checks in rendered images: drawn `MARKER_LIFT_M` in front of
/// the surface it sits on, facing along `normal`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Marker {
    /// Centre of the disk (m), on its surface.
    pub center: Vector3<f64>,
    /// Unit normal the disk faces.
    pub normal: Vector3<f64>,
    /// Radius (m).
    pub radius: f64,
    /// Albedo in `[0, 1]`.
    pub albedo: f64,
}

/// How far in front of its surface a [`Marker`] is drawn (m), so the depth test keeps it.
pub const MARKER_LIFT_M: f64 = 1e-4;

impl Marker {
    /// The centre of the disk as drawn: `center + MARKER_LIFT_M · normal`.
    pub fn drawn_center(&self) -> Vector3<f64> {
        self.center + self.normal * MARKER_LIFT_M
    }
}

/// Landmarks of one surface tile, with a bounding sphere for culling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tile {
    /// First landmark index.
    pub start: usize,
    /// One past the last landmark index.
    pub end: usize,
    /// Bounding sphere centre (m).
    pub center: Vector3<f64>,
    /// Bounding sphere radius (m).
    pub radius: f64,
    /// Normal of the tile's surface.
    pub normal: Vector3<f64>,
}

/// A built scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Textured surfaces (landmarks lie on them).
    pub surfaces: Vec<Surface>,
    /// Solid occluders.
    pub boxes: Vec<Aabb>,
    /// Landmarks, id = index.
    pub landmarks: Vec<Landmark>,
    /// Landmark tiles (contiguous id ranges) for view culling.
    pub tiles: Vec<Tile>,
    /// Markers drawn by the renderer (none in the presets).
    pub markers: Vec<Marker>,
    /// Grey level in [0, 1] the renderer shows where no surface is (the sky outdoors; indoor
    /// presets are closed).
    pub background: f64,
}

/// The six outward faces of a box as surfaces (normals pointing out).
fn box_faces(b: &Aabb, skip_bottom: bool) -> Vec<Surface> {
    let (lo, hi) = (b.min, b.max);
    let d = hi - lo;
    let ex = Vector3::new(d.x, 0.0, 0.0);
    let ey = Vector3::new(0.0, d.y, 0.0);
    let ez = Vector3::new(0.0, 0.0, d.z);
    let mut f = vec![
        Surface {
            origin: lo,
            u: ey,
            v: ez,
            normal: -Vector3::x(),
            texture: SurfaceTexture::Rich,
        },
        Surface {
            origin: lo + ex,
            u: ey,
            v: ez,
            normal: Vector3::x(),
            texture: SurfaceTexture::Rich,
        },
        Surface {
            origin: lo,
            u: ex,
            v: ez,
            normal: -Vector3::y(),
            texture: SurfaceTexture::Rich,
        },
        Surface {
            origin: lo + ey,
            u: ex,
            v: ez,
            normal: Vector3::y(),
            texture: SurfaceTexture::Rich,
        },
        Surface {
            origin: lo + ez,
            u: ex,
            v: ey,
            normal: Vector3::z(),
            texture: SurfaceTexture::Rich,
        },
    ];
    if !skip_bottom {
        f.push(Surface {
            origin: lo,
            u: ex,
            v: ey,
            normal: -Vector3::z(),
            texture: SurfaceTexture::Rich,
        });
    }
    f
}

/// The six inward faces of an enclosing box (walls, floor, ceiling).
fn inner_faces(b: &Aabb) -> Vec<Surface> {
    box_faces(b, false)
        .into_iter()
        .map(|s| Surface {
            normal: -s.normal,
            ..s
        })
        .collect()
}

impl Scene {
    /// Builds the preset with landmarks from the `scene` stream of `seed`.
    pub fn build(cfg: &SceneConfig, seed: u64) -> Self {
        let (surfaces, boxes) = Self::preset_geometry(cfg.preset);
        let mut scene = Self::with_landmarks(surfaces, boxes, cfg.landmark_density, seed);
        if cfg.preset == ScenePreset::Outdoor {
            scene.background = 0.85; // an overcast sky
        }
        scene
    }

    /// The preset's textured surfaces and solid boxes (no landmarks yet).
    pub fn preset_geometry(preset: ScenePreset) -> (Vec<Surface>, Vec<Aabb>) {
        let v = Vector3::new;
        match preset {
            ScenePreset::Room => {
                let room = ScenePreset::Room.free_space();
                let boxes = vec![
                    Aabb::new(v(2.7, -3.5, 0.0), v(3.5, -2.7, 0.8)),
                    Aabb::new(v(-4.5, 3.7, 0.0), v(-3.5, 4.5, 1.0)),
                    Aabb::new(v(2.9, 3.0, 0.0), v(3.5, 4.0, 0.6)),
                    Aabb::new(v(-4.5, -3.5, 0.0), v(-4.1, -3.1, 4.0)),
                ];
                let mut s = inner_faces(&room);
                // A plain painted ceiling: the texture-poor region of this preset.
                s[4].texture = SurfaceTexture::Poor;
                for b in &boxes {
                    s.extend(box_faces(b, true));
                }
                (s, boxes)
            }
            ScenePreset::MachineHall => {
                let hall = ScenePreset::MachineHall.free_space();
                let boxes = vec![
                    Aabb::new(v(-11.0, -8.0, -2.0), v(-7.0, -4.0, 3.0)),
                    Aabb::new(v(12.0, -8.0, -2.0), v(17.0, -3.0, 4.0)),
                    Aabb::new(v(-11.0, 11.0, -2.0), v(-6.0, 16.0, 2.0)),
                    Aabb::new(v(11.0, 12.0, -2.0), v(17.0, 16.0, 5.0)),
                    Aabb::new(v(9.0, 2.0, -2.0), v(11.0, 6.0, 1.0)),
                    Aabb::new(v(-8.0, 3.0, -2.0), v(-6.0, 5.0, 8.0)),
                ];
                let mut s = inner_faces(&hall);
                // Texture-poor: the ceiling and the far (+x) wall.
                s[4].texture = SurfaceTexture::Poor;
                s[1].texture = SurfaceTexture::Poor;
                for b in &boxes {
                    s.extend(box_faces(b, true));
                }
                (s, boxes)
            }
            ScenePreset::Outdoor => {
                let ground = Surface {
                    origin: v(-100.0, -100.0, 0.0),
                    u: v(200.0, 0.0, 0.0),
                    v: v(0.0, 200.0, 0.0),
                    normal: Vector3::z(),
                    texture: SurfaceTexture::Rich,
                };
                let mut boxes = Vec::new();
                for i in -3i32..=3 {
                    for j in -3i32..=3 {
                        if i.abs() <= 1 && j.abs() <= 1 {
                            continue;
                        }
                        let c = v(f64::from(i) * 25.0, f64::from(j) * 25.0, 0.0);
                        let h = 6.0 + f64::from((i * 7 + j * 3).rem_euclid(5)) * 4.0;
                        boxes.push(Aabb::new(c - v(6.0, 6.0, 0.0), c + v(6.0, 6.0, h)));
                    }
                }
                let mut s = vec![ground];
                for b in &boxes {
                    let mut faces = box_faces(b, true);
                    // Flat roofs are texture-poor.
                    faces[4].texture = SurfaceTexture::Poor;
                    s.extend(faces);
                }
                (s, boxes)
            }
        }
    }

    /// Scatters landmarks on `surfaces` (density per m², stream `scene` of `seed`), tiled in
    /// patches of at most 2 m for culling; points inside any of `boxes` are dropped.
    pub fn with_landmarks(
        surfaces: Vec<Surface>,
        boxes: Vec<Aabb>,
        density: f64,
        seed: u64,
    ) -> Self {
        let mut rng = sensor_rng(seed, "scene");
        let mut landmarks = Vec::new();
        let mut tiles = Vec::new();
        let tile_len = 2.0;
        for s in &surfaces {
            let nu = (s.u.norm() / tile_len).ceil().max(1.0) as usize;
            let nv = (s.v.norm() / tile_len).ceil().max(1.0) as usize;
            let tile_area = s.area() / (nu * nv) as f64;
            for iu in 0..nu {
                for iv in 0..nv {
                    let o =
                        s.origin + s.u * (iu as f64 / nu as f64) + s.v * (iv as f64 / nv as f64);
                    let du = s.u / nu as f64;
                    let dv = s.v / nv as f64;
                    let expected = density * tile_area;
                    // Whole part plus a Bernoulli draw for the fraction keeps the mean exact.
                    let mut n = expected.floor() as usize;
                    if rng.random::<f64>() < expected.fract() {
                        n += 1;
                    }
                    let start = landmarks.len();
                    for _ in 0..n {
                        let a: f64 = rng.random();
                        let b: f64 = rng.random();
                        let p = o + du * a + dv * b;
                        if boxes.iter().any(|bx| bx.contains(&p, 1e-9)) {
                            continue;
                        }
                        landmarks.push(Landmark {
                            id: landmarks.len() as u64,
                            p,
                            normal: s.normal,
                        });
                    }
                    let center = o + (du + dv) * 0.5;
                    tiles.push(Tile {
                        start,
                        end: landmarks.len(),
                        center,
                        radius: 0.5 * (du + dv).norm().max((du - dv).norm()),
                        normal: s.normal,
                    });
                }
            }
        }
        Self {
            surfaces,
            boxes,
            landmarks,
            tiles,
            markers: Vec::new(),
            background: 0.0,
        }
    }

    /// The nearest surface hit by the ray `o + t·d` (d unit) with `t ∈ (t_min, t_max]`, seen from
    /// its visible side: `(t, surface index)`.
    pub fn ray_cast(
        &self,
        o: &Vector3<f64>,
        d: &Vector3<f64>,
        t_min: f64,
        t_max: f64,
    ) -> Option<(f64, usize)> {
        let mut best: Option<(f64, usize)> = None;
        for (i, s) in self.surfaces.iter().enumerate() {
            let denom = d.dot(&s.normal);
            if denom >= -1e-12 {
                continue; // parallel, or seen from behind
            }
            let t = (s.origin - o).dot(&s.normal) / denom;
            if t <= t_min || t > t_max || best.is_some_and(|(bt, _)| t >= bt) {
                continue;
            }
            let rel = o + d * t - s.origin;
            let a = rel.dot(&s.u) / s.u.norm_squared();
            let b = rel.dot(&s.v) / s.v.norm_squared();
            if (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b) {
                best = Some((t, i));
            }
        }
        best
    }

    /// True if the segment from `from` to the landmark point `to` is blocked by a box (the last
    /// millimetre before `to` is not tested, so a box does not occlude its own visible faces).
    pub fn occluded(&self, from: &Vector3<f64>, to: &Vector3<f64>) -> bool {
        let d = to - from;
        let len = d.norm();
        if len < 1e-3 {
            return false;
        }
        let t_max = 1.0 - 1e-3 / len;
        self.boxes
            .iter()
            .any(|b| b.ray_entry(from, &d, t_max).is_some())
    }
}
