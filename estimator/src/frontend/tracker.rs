//! The feature tracker: images in, [`FeatureFrame`]s out (what `Estimator::push_frame` takes).
//!
//! Per frame, on the primary camera (the lowest camera index delivered, cam0 normally):
//! 1. temporal pyramidal KLT of every track from the previous image, started where the gyro
//!    rotation predicts it (when given), checked by tracking back (flow-back);
//! 2. RANSAC on a fundamental matrix of undistorted normalized coordinates drops tracks that do
//!    not fit one rigid motion;
//! 3. tracks claim a disk of `min_distance_px`, oldest first; a younger track inside an older
//!    one's disk is dropped (so features do not bunch up);
//! 4. Shi–Tomasi corners top the count up to `max_features` in the free area, as new tracks;
//! 5. every track is matched into each other camera by KLT (started at its last disparity),
//!    checked by tracking back and against the epipolar geometry of the calibrated extrinsics.
//!
//! A track's patch templates are sampled once per frame (step 5 uses them, and the next frame's
//! step 1). Ids are the tracker's own and never reused: a feature that is lost and found again is
//! a new track.

use std::time::Instant;

use nalgebra::{UnitQuaternion, Vector2, Vector3};

use super::affine::AffineAnchor;
use super::checks::{StereoGeometry, build_pyramid, median2, predict};
use super::config::{TrackerConfig, TrackerError};
use super::corners::{CornerParams, CornerScratch, Occupancy, detect_on_level};
use super::image::{ImageView, Pyramid};
use super::klt::{Template, track};
use super::ransac::{RansacParams, ransac_fundamental};
use super::types::{CameraFeatures, FeatureFrame, FeatureObservation, TrackerCamera};

/// One camera's image for [`FeatureTracker::track`].
#[derive(Clone, Copy, Debug)]
pub struct CameraImageView<'a> {
    /// Camera index in the rig.
    pub cam_id: usize,
    /// The image.
    pub image: ImageView<'a>,
}

/// A live track, as the tracker reports it.
#[derive(Clone, Debug, PartialEq)]
pub struct TrackedFeature {
    /// Track id.
    pub id: u64,
    /// Position in the primary camera (distorted pixels).
    pub uv: Vector2<f64>,
    /// Frames this track has been seen in (1 = detected this frame).
    pub age: u32,
    /// Stereo matches `(camera, distorted pixel)` this frame.
    pub matches: Vec<(usize, Vector2<f64>)>,
}

/// Wall time of each stage of the last frame (s; for reports only, never for decisions).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Equalization and pyramids.
    pub pyramids_s: f64,
    /// Temporal KLT, flow-back and templates at the new positions.
    pub temporal_s: f64,
    /// RANSAC.
    pub ransac_s: f64,
    /// Claiming neighbourhoods and Shi–Tomasi top-up (with the new tracks' templates).
    pub detect_s: f64,
    /// Stereo matching both ways and epipolar checks.
    pub stereo_s: f64,
    /// The whole call.
    pub total_s: f64,
}

/// What the last call did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrackReport {
    /// The frame stamp.
    pub t_ns: i64,
    /// The primary camera (`None`: no image).
    pub primary: Option<usize>,
    /// Tracks carried in from the previous frame.
    pub tracks_in: usize,
    /// Lost by temporal KLT (out of image, untrackable, diverged).
    pub klt_lost: usize,
    /// Rejected by the temporal flow-back check.
    pub flow_back_rejected: usize,
    /// Tracks re-anchored (their anchor patch no longer matched within the tolerance).
    pub reanchored: usize,
    /// Rejected by RANSAC: `(id, position)` where KLT had put them.
    pub ransac_rejected: Vec<(u64, Vector2<f64>)>,
    /// Dropped because an older track claimed their neighbourhood.
    pub crowded: usize,
    /// New tracks.
    pub detected: usize,
    /// Stereo matches tried (tracks × other cameras).
    pub stereo_tried: usize,
    /// Stereo matches made.
    pub stereo_matched: usize,
    /// Stereo matches rejected by flow-back.
    pub stereo_flow_back_rejected: usize,
    /// Stereo matches rejected by the epipolar or positive-depth check.
    pub stereo_epipolar_rejected: usize,
    /// Stage times.
    pub times: StageTimes,
}

#[derive(Clone, Debug)]
struct Track {
    id: u64,
    uv: Vector2<f64>,
    age: u32,
    template: Template,
    /// The patch of the first observation (or of the last re-anchoring) and its warp.
    anchor: Option<Box<AffineAnchor>>,
    matches: Vec<(usize, Vector2<f64>)>,
    /// Last frame's stereo disparities `(camera, match − uv)`: this frame's starting guesses.
    hints: Vec<(usize, Vector2<f64>)>,
}

/// The image front end: KLT tracks on the primary camera, stereo matches into the others.
#[derive(Clone, Debug)]
pub struct FeatureTracker {
    config: TrackerConfig,
    cameras: Vec<TrackerCamera>,
    /// Focal length (px) of each camera on the optical axis, for px ↔ normalized thresholds.
    focal: Vec<f64>,
    next_id: u64,
    primary: Option<usize>,
    tracks: Vec<Track>,
    prev: Pyramid,
    cur: Pyramid,
    other: Pyramid,
    /// Median disparity (px) of last frame's matches, per camera.
    disparity: Vec<Vector2<f64>>,
    scratch: CornerScratch,
    report: TrackReport,
}

impl FeatureTracker {
    /// A tracker for a rig (camera 0 is the primary camera while it delivers images).
    pub fn new(config: TrackerConfig, cameras: Vec<TrackerCamera>) -> Result<Self, TrackerError> {
        config.validate()?;
        if cameras.is_empty() {
            return Err(TrackerError::Config {
                field: "cameras",
                message: "the rig needs at least one camera".into(),
            });
        }
        let focal = cameras
            .iter()
            .map(|c| {
                c.model
                    .project_with_jacobian(&Vector3::new(0.0, 0.0, 1.0))
                    .map_or(1.0, |(_, j)| 0.5 * (j[(0, 0)] + j[(1, 1)]).abs())
                    .max(1e-9)
            })
            .collect();
        let n = cameras.len();
        Ok(Self {
            config,
            cameras,
            focal,
            next_id: 0,
            primary: None,
            tracks: Vec::new(),
            prev: Pyramid::default(),
            cur: Pyramid::default(),
            other: Pyramid::default(),
            disparity: vec![Vector2::zeros(); n],
            scratch: CornerScratch::default(),
            report: TrackReport::default(),
        })
    }

    /// The configuration.
    pub fn config(&self) -> &TrackerConfig {
        &self.config
    }

    /// What the last call to [`FeatureTracker::track`] did.
    pub fn report(&self) -> &TrackReport {
        &self.report
    }

    /// The live tracks after the last call, by id.
    pub fn tracks(&self) -> impl Iterator<Item = TrackedFeature> + '_ {
        self.tracks.iter().map(|t| TrackedFeature {
            id: t.id,
            uv: t.uv,
            age: t.age,
            matches: t.matches.clone(),
        })
    }

    /// Forgets every track (the next frame starts afresh with new ids).
    pub fn reset(&mut self) {
        self.tracks.clear();
        self.primary = None;
        self.disparity
            .iter_mut()
            .for_each(|d| *d = Vector2::zeros());
    }

    /// Tracks one multi-camera frame. `R_bprev_bcur` is the body rotation since the previous
    /// frame (from the gyroscope), used to predict where features moved.
    #[allow(non_snake_case)]
    pub fn track(
        &mut self,
        images: &[CameraImageView<'_>],
        t_ns: i64,
        R_bprev_bcur: Option<UnitQuaternion<f64>>,
    ) -> Result<FeatureFrame, TrackerError> {
        let start = Instant::now();
        for im in images {
            let cam = self
                .cameras
                .get(im.cam_id)
                .ok_or(TrackerError::UnknownCamera {
                    cam_id: im.cam_id,
                    cameras: self.cameras.len(),
                })?;
            let (w, h) = (cam.model.width(), cam.model.height());
            if (im.image.width(), im.image.height()) != (w, h) {
                return Err(TrackerError::ImageSize {
                    cam_id: im.cam_id,
                    got_w: im.image.width(),
                    got_h: im.image.height(),
                    want_w: w,
                    want_h: h,
                });
            }
        }
        let mut report = TrackReport {
            t_ns,
            ..Default::default()
        };
        let Some(primary) = images.iter().min_by_key(|im| im.cam_id) else {
            self.reset();
            self.report = report;
            return Ok(FeatureFrame {
                t_ns,
                cameras: Vec::new(),
            });
        };
        let p_cam = primary.cam_id;
        report.primary = Some(p_cam);
        if self.primary != Some(p_cam) {
            self.reset();
            self.primary = Some(p_cam);
        }
        let cfg = self.config;
        let klt = cfg.klt();
        let levels = cfg.max_level + 1;

        // Pyramid of the primary image.
        let t0 = Instant::now();
        std::mem::swap(&mut self.prev, &mut self.cur);
        build_pyramid(&mut self.cur, &primary.image, cfg.equalize, cfg.max_level);
        report.times.pyramids_s = t0.elapsed().as_secs_f64();

        // 1. Temporal KLT with flow-back.
        let t1 = Instant::now();
        report.tracks_in = self.tracks.len();
        let rotation = R_bprev_bcur.filter(|_| cfg.gyro_prediction).map(|r| {
            let q_b_c = self.cameras[p_cam].T_b_c.q;
            // R_ccur_cprev = R_c_b · R_bcur_bprev · R_b_c.
            q_b_c.inverse() * r.inverse() * q_b_c
        });
        let model = self.cameras[p_cam].model.clone();
        let mut kept: Vec<(Track, Vector2<f64>)> = Vec::with_capacity(self.tracks.len());
        for t in std::mem::take(&mut self.tracks) {
            let guess = rotation
                .and_then(|r| predict(model.as_ref(), &r, &t.uv))
                .unwrap_or(t.uv);
            let Ok(mut q) = track(&t.template, &self.cur, guess, cfg.max_level, &klt) else {
                report.klt_lost += 1;
                continue;
            };
            let mut anchor = t.anchor;
            if cfg.anchor_refinement {
                let refined = anchor
                    .as_mut()
                    .and_then(|a| a.refine(&self.cur, q, cfg.epsilon_px));
                match refined {
                    Some(r) if (r - q).norm() <= cfg.anchor_max_shift_px => q = r,
                    _ => {
                        report.reanchored += 1;
                        anchor = AffineAnchor::new(&self.cur, q, klt.half_window).map(Box::new);
                    }
                }
            }
            // The old template is done with: its buffers take the new one.
            let mut template = t.template;
            template.resample(&self.cur, q, levels, &klt);
            if cfg.flow_back {
                let back = track(&template, &self.prev, t.uv, 0, &klt);
                if !back.is_ok_and(|b| (b - t.uv).norm() <= cfg.flow_back_px) {
                    report.flow_back_rejected += 1;
                    continue;
                }
            }
            let prev_uv = t.uv;
            let hints = t.matches.iter().map(|&(c, m)| (c, m - t.uv)).collect();
            kept.push((
                Track {
                    id: t.id,
                    uv: q,
                    age: t.age + 1,
                    anchor,
                    template,
                    matches: Vec::new(),
                    hints,
                },
                prev_uv,
            ));
        }
        report.times.temporal_s = t1.elapsed().as_secs_f64();

        // 2. RANSAC on normalized coordinates.
        let t2 = Instant::now();
        if cfg.ransac && kept.len() >= 8 {
            let norm: Vec<Option<(Vector2<f64>, Vector2<f64>)>> = kept
                .iter()
                .map(|(t, p)| {
                    Some((
                        model.unproject_normalized(p)?,
                        model.unproject_normalized(&t.uv)?,
                    ))
                })
                .collect();
            let idx: Vec<usize> = (0..kept.len()).filter(|&i| norm[i].is_some()).collect();
            let x1: Vec<_> = idx.iter().map(|&i| norm[i].unwrap().0).collect();
            let x2: Vec<_> = idx.iter().map(|&i| norm[i].unwrap().1).collect();
            let params = RansacParams {
                threshold: cfg.ransac_threshold_px / self.focal[p_cam],
                confidence: cfg.ransac_confidence,
                max_iterations: cfg.ransac_max_iterations,
            };
            let seed = cfg.seed ^ (t_ns as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            let inlier = ransac_fundamental(&x1, &x2, &params, seed);
            let mut good = vec![false; kept.len()];
            for (k, &i) in idx.iter().enumerate() {
                good[i] = inlier[k];
            }
            let mut out = Vec::with_capacity(kept.len());
            for (i, (t, p)) in kept.into_iter().enumerate() {
                if good[i] {
                    out.push((t, p));
                } else {
                    report.ransac_rejected.push((t.id, t.uv));
                }
            }
            kept = out;
        }
        report.times.ransac_s = t2.elapsed().as_secs_f64();

        // 3. Oldest tracks claim their neighbourhood; 4. Shi–Tomasi top-up.
        let t3 = Instant::now();
        kept.sort_by(|a, b| b.0.age.cmp(&a.0.age).then(a.0.id.cmp(&b.0.id)));
        let (w, h) = (model.width() as usize, model.height() as usize);
        let mut occ = Occupancy::new(w, h, cfg.min_distance_px);
        let mut tracks = Vec::with_capacity(cfg.max_features);
        for (t, _) in kept {
            if occ.is_near(&t.uv) {
                report.crowded += 1;
                continue;
            }
            occ.insert(t.uv);
            tracks.push(t);
        }
        if tracks.len() < cfg.max_features {
            let existing: Vec<Vector2<f64>> = tracks.iter().map(|t| t.uv).collect();
            let params = CornerParams {
                quality_level: cfg.quality_level,
                min_response: cfg.min_corner_response,
                min_distance_px: cfg.min_distance_px,
                border_px: cfg.border_px,
                grid: cfg.grid,
            };
            let level = cfg.detect_level.min(self.cur.len() - 1);
            let found = detect_on_level(
                &self.cur.level(level),
                level,
                &self.cur.level(0),
                &existing,
                cfg.max_features - tracks.len(),
                &params,
                &mut self.scratch,
            );
            for uv in found {
                let template = Template::new(&self.cur, uv, levels, &klt);
                if !template.is_trackable() {
                    continue;
                }
                report.detected += 1;
                tracks.push(Track {
                    id: self.next_id,
                    uv,
                    age: 1,
                    anchor: cfg
                        .anchor_refinement
                        .then(|| AffineAnchor::new(&self.cur, uv, klt.half_window).map(Box::new))
                        .flatten(),
                    template,
                    matches: Vec::new(),
                    hints: Vec::new(),
                });
                self.next_id += 1;
            }
        }
        tracks.sort_by_key(|t| t.id);
        report.times.detect_s = t3.elapsed().as_secs_f64();

        // 5. Stereo matching into every other camera.
        let t4 = Instant::now();
        let mut others: Vec<&CameraImageView<'_>> =
            images.iter().filter(|im| im.cam_id != p_cam).collect();
        others.sort_by_key(|im| im.cam_id);
        if cfg.stereo {
            for other in others {
                let c = other.cam_id;
                build_pyramid(&mut self.other, &other.image, cfg.equalize, cfg.max_level);
                let geometry = StereoGeometry::new(&self.cameras[p_cam], &self.cameras[c]);
                let tol = cfg.epipolar_px / self.focal[p_cam].min(self.focal[c]);
                let prior = self.disparity[c];
                let mut disparities = Vec::new();
                let mut back_t: Option<Template> = None;
                for t in tracks.iter_mut() {
                    report.stereo_tried += 1;
                    let hint = t.hints.iter().find(|h| h.0 == c).map(|h| h.1);
                    let guess = t.uv + hint.unwrap_or(prior);
                    // Last frame's disparity is within a few pixels of this one's: the two finest
                    // levels suffice (±20 px); new tracks search the whole pyramid.
                    let top = if hint.is_some() {
                        cfg.max_level.min(1)
                    } else {
                        cfg.max_level
                    };
                    let Ok(q) = track(&t.template, &self.other, guess, top, &klt) else {
                        continue;
                    };
                    if cfg.flow_back {
                        let back_t = match back_t.as_mut() {
                            Some(b) => {
                                b.resample(&self.other, q, 1, &klt);
                                b
                            }
                            None => back_t.insert(Template::new(&self.other, q, 1, &klt)),
                        };
                        let back = track(back_t, &self.cur, t.uv, 0, &klt);
                        if !back.is_ok_and(|b| (b - t.uv).norm() <= cfg.flow_back_px) {
                            report.stereo_flow_back_rejected += 1;
                            continue;
                        }
                    }
                    let consistent = match (
                        self.cameras[p_cam].model.unproject(&t.uv),
                        self.cameras[c].model.unproject(&q),
                    ) {
                        (Some(f0), Some(f1)) => geometry.accepts(&f0, &f1, tol),
                        _ => false,
                    };
                    if !consistent {
                        report.stereo_epipolar_rejected += 1;
                        continue;
                    }
                    report.stereo_matched += 1;
                    disparities.push(q - t.uv);
                    t.matches.push((c, q));
                }
                self.disparity[c] = median2(&mut disparities).unwrap_or(prior);
            }
        }
        report.times.stereo_s = t4.elapsed().as_secs_f64();

        let mut cameras = vec![CameraFeatures {
            cam_id: p_cam,
            features: tracks
                .iter()
                .map(|t| FeatureObservation {
                    feature_id: t.id,
                    uv: t.uv,
                })
                .collect(),
        }];
        let mut other_ids: Vec<usize> = tracks
            .iter()
            .flat_map(|t| t.matches.iter().map(|m| m.0))
            .collect();
        other_ids.sort_unstable();
        other_ids.dedup();
        for c in other_ids {
            cameras.push(CameraFeatures {
                cam_id: c,
                features: tracks
                    .iter()
                    .filter_map(|t| {
                        t.matches
                            .iter()
                            .find(|m| m.0 == c)
                            .map(|m| FeatureObservation {
                                feature_id: t.id,
                                uv: m.1,
                            })
                    })
                    .collect(),
            });
        }
        self.tracks = tracks;
        report.times.total_s = start.elapsed().as_secs_f64();
        self.report = report;
        Ok(FeatureFrame { t_ns, cameras })
    }
}
