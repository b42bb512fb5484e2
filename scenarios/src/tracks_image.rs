//! `vio render --tracks`: the image front end's tracks drawn over a stereo pair.
//!
//! The scenario's captures over the [`HISTORY_S`] seconds before the requested time are rendered
//! at the rig's capture times (ground-truth poses, no faults) and fed to a
//! [`FeatureTracker`], with the true body rotation between captures as its gyro prediction.
//! The picture is the last capture's left and right images side by side (RGB): each track's
//! trail over its last [`TRAIL_FRAMES`] positions in a colour by age (red = new, through yellow
//! and green, to azure = seen over the whole history), a circle at its position, and its stereo
//! match circled in the same colour on the right image with its disparity: a line from the match
//! to the left image's position (same pixel coordinates, drawn on the right image).

use std::collections::{BTreeMap, VecDeque};
use std::time::Instant;

use estimator::frontend::FeatureTracker;
use image::{Rgb, RgbImage};

use crate::track_drawing::{CIRCLE_PX, age_colour, circle, line};
use nalgebra::Vector2;
use sim::render::ImageFrame;

use crate::run::RunError;
use crate::spec::Scenario;

/// Seconds of captures tracked before the requested time.
pub const HISTORY_S: f64 = 2.0;
/// Positions drawn per trail (the newest included).
pub const TRAIL_FRAMES: usize = 20;
/// Opacity of the disparity lines on the right image.
const DISPARITY_LINE_ALPHA: f32 = 0.7;

/// What `vio render --tracks` drew.
#[derive(Clone, Debug)]
pub struct TracksImage {
    /// Left and right images side by side with the tracks drawn.
    pub image: RgbImage,
    /// Live tracks in the last capture.
    pub tracks: usize,
    /// Of those, tracks with a stereo match.
    pub stereo_matches: usize,
    /// Captures tracked.
    pub frames: usize,
    /// Capture time of the first tracked capture (ns).
    pub first_ns: i64,
    /// Capture time of the last tracked capture, the one drawn (ns).
    pub last_ns: i64,
    /// Adapter that rendered the images.
    pub adapter: String,
    /// Wall time spent rendering (s).
    pub render_s: f64,
    /// Wall time spent in the tracker (s).
    pub track_s: f64,
}

/// Renders and tracks the captures of `scenario` from [`HISTORY_S`] before `at_s` up to `at_s`
/// (the rig's capture times; the last one at or before `at_s`) and draws the tracks of the last.
/// The tracker settings are the scenario's `[camera.tracker]` when it runs the KLT front end,
/// else the defaults.
pub fn render_tracks(
    scenario: &Scenario,
    at_s: f64,
    seed: Option<u64>,
) -> Result<TracksImage, RunError> {
    let (world, mut renderer, rig) = crate::images::renderer_at(scenario, at_s, seed, false)?;
    let world_seed = world.config().seed;
    let tracker_cfg = scenario.tracker_config(world_seed)?.unwrap_or_else(|| {
        estimator::frontend::TrackerConfig {
            seed: world_seed,
            ..Default::default()
        }
    });
    let cameras = crate::frontend::tracker_cameras(&scenario.estimator_config()?);
    let frontend_err = |e: &dyn std::fmt::Display| RunError::Frontend {
        file: scenario.file_label(),
        message: e.to_string(),
    };
    let mut tracker = FeatureTracker::new(tracker_cfg, cameras).map_err(|e| frontend_err(&e))?;
    let at_ns = (at_s * 1e9).round() as i64;
    let from_ns = (at_ns - (HISTORY_S * 1e9).round() as i64).max(0);
    // The frames captured in [from_ns, at_ns].
    let first_k = rig.frame_at_or_before(from_ns - 1) + u64::from(from_ns > 0);
    let last_k = rig.frame_at_or_before(at_ns);
    let offsets = renderer.exposure_offsets_ns();
    let live: Vec<usize> = (0..rig.cameras.len()).collect();
    let mut stream = world.stream();
    let mut trails: BTreeMap<u64, VecDeque<Vector2<f64>>> = BTreeMap::new();
    let (mut render_s, mut track_s) = (0.0, 0.0);
    let mut prev_q = None;
    let mut last: Option<ImageFrame> = None;
    for k in first_k..=last_k {
        let t_cap = rig.capture_ns(k);
        let mut truth = |t: i64| {
            stream
                .truth(t.clamp(0, world.end_ns()))
                .map(|g| g.pose)
                .ok_or(RunError::NoTruth { t_ns: t })
        };
        let q = truth(t_cap)?.q;
        let poses = offsets
            .iter()
            .map(|o| truth(t_cap + o))
            .collect::<Result<Vec<_>, _>>()?;
        let start = Instant::now();
        let frame = renderer
            .render(t_cap, t_cap - rig.td_ns, k, &poses, &live)
            .map_err(|e| RunError::sim(scenario, e))?;
        render_s += start.elapsed().as_secs_f64();
        let views = crate::frontend::image_views(&frame).map_err(|e| frontend_err(&e))?;
        // The true body rotation since the last capture stands in for the gyroscope.
        let rotation = prev_q.map(|p: nalgebra::UnitQuaternion<f64>| p.inverse() * q);
        let start = Instant::now();
        tracker
            .track(&views, frame.t_ns, rotation)
            .map_err(|e| frontend_err(&e))?;
        track_s += start.elapsed().as_secs_f64();
        prev_q = Some(q);
        let mut seen = BTreeMap::new();
        for t in tracker.tracks() {
            let trail = trails.remove(&t.id).unwrap_or_default();
            seen.insert(t.id, trail);
            let trail = seen.get_mut(&t.id).expect("just inserted");
            trail.push_back(t.uv);
            if trail.len() > TRAIL_FRAMES {
                trail.pop_front();
            }
        }
        trails = seen;
        last = Some(frame);
    }
    let frame = last.ok_or_else(|| RunError::sim(scenario, "no capture before --at"))?;
    let (image, tracks, stereo_matches) = draw(&frame, &tracker, &trails);
    Ok(TracksImage {
        image,
        tracks,
        stereo_matches,
        frames: (last_k - first_k + 1) as usize,
        first_ns: rig.capture_ns(first_k),
        last_ns: rig.capture_ns(last_k),
        adapter: renderer.adapter().to_string(),
        render_s,
        track_s,
    })
}

/// Draws the tracks of `tracker` (trails from `trails`) over the left and right images of
/// `frame`; returns the picture, the number of tracks and of stereo matches.
fn draw(
    frame: &ImageFrame,
    tracker: &FeatureTracker,
    trails: &BTreeMap<u64, VecDeque<Vector2<f64>>>,
) -> (RgbImage, usize, usize) {
    let width = frame.cameras.iter().map(|c| c.image.width).sum();
    let height = frame
        .cameras
        .iter()
        .map(|c| c.image.height)
        .max()
        .unwrap_or(0);
    let mut img = RgbImage::new(width, height);
    // Left edge of each camera's image in the picture, by camera id.
    let mut x0 = BTreeMap::new();
    let mut left = 0;
    for c in &frame.cameras {
        for y in 0..c.image.height {
            for x in 0..c.image.width {
                let g = c.image.at(x, y);
                img.put_pixel(left + x, y, Rgb([g, g, g]));
            }
        }
        x0.insert(c.cam_id, i64::from(left));
        left += c.image.width;
    }
    let primary = frame.cameras.first().map_or(0, |c| c.cam_id);
    let at = |cam: usize, uv: &Vector2<f64>| {
        let x = x0.get(&cam).copied().unwrap_or(0);
        (x + uv.x.round() as i64, uv.y.round() as i64)
    };
    let (mut tracks, mut stereo) = (0, 0);
    // Oldest last, so that the long trails stay on top.
    let mut live: Vec<_> = tracker.tracks().collect();
    live.sort_by_key(|t| (t.age, t.id));
    for t in &live {
        tracks += 1;
        let colour = age_colour(t.age);
        if let Some(trail) = trails.get(&t.id) {
            for w in trail.iter().collect::<Vec<_>>().windows(2) {
                line(&mut img, at(primary, w[0]), at(primary, w[1]), colour, 1.0);
            }
        }
        let p = at(primary, &t.uv);
        circle(&mut img, p, CIRCLE_PX, colour);
        let mut matched = false;
        for (cam, uv) in &t.matches {
            if *cam == primary || !x0.contains_key(cam) {
                continue;
            }
            matched = true;
            let q = at(*cam, uv);
            let left_there = at(*cam, &t.uv);
            line(&mut img, left_there, q, colour, DISPARITY_LINE_ALPHA);
            circle(&mut img, q, CIRCLE_PX, colour);
        }
        stereo += usize::from(matched);
    }
    (img, tracks, stereo)
}
