//! Feature-level cameras: measurements reproject to their landmarks within the noise; occluded
//! and back-facing landmarks are never reported; stereo association by id.

use crate::common;

use estimator::camera::in_image;
use nalgebra::Vector3;
use sim::camera::{RigSim, TrackIds};
use sim::scene::{Aabb, Scene, Surface};
use sim::stream::Measurement;
use sim::{World, WorldConfig};
use std::sync::Arc;

#[test]
fn measurements_reproject_within_noise_and_are_unoccluded() {
    let mut rig = common::rig(2);
    for c in &mut rig.cameras {
        c.pixel_sigma = 0.5;
    }
    let world = World::new(WorldConfig {
        seed: 3,
        duration_s: 20.0,
        rig: Some(rig.clone()),
        ..WorldConfig::default()
    })
    .unwrap();
    let scene = world.scene().clone();
    let mut stream = world.stream();
    let (mut n, mut sum_sq, mut max_err, mut frames, mut stereo): (usize, f64, f64, usize, usize) =
        (0, 0.0, 0.0, 0, 0);
    while let Some(m) = stream.next() {
        let Measurement::Frame(f) = m else { continue };
        frames += 1;
        let gt = stream.truth(f.t_ns).unwrap();
        for cf in &f.cameras {
            let c = &rig.cameras[cf.cam_id];
            let t_w_c = gt.pose.compose(&c.t_b_c);
            assert!(
                cf.features
                    .windows(2)
                    .all(|w| w[0].feature_id < w[1].feature_id)
            );
            assert!(cf.features.len() <= c.max_features);
            for o in &cf.features {
                let lm = stream.landmark(o.feature_id).unwrap();
                let p_c = t_w_c.inverse().transform(&lm.p);
                let uv = c.model.project(&p_c).unwrap();
                let e = (uv - o.uv).norm();
                sum_sq += e * e;
                max_err = max_err.max(e);
                n += 1;
                assert!(
                    !scene.occluded(&t_w_c.p, &lm.p),
                    "occluded landmark reported"
                );
                assert!(
                    lm.normal.dot(&(t_w_c.p - lm.p)) > 0.0,
                    "back-facing landmark reported"
                );
            }
        }
        let ids0: Vec<u64> = f.cameras[0].features.iter().map(|o| o.feature_id).collect();
        stereo += f.cameras[1]
            .features
            .iter()
            .filter(|o| ids0.binary_search(&o.feature_id).is_ok())
            .count();
    }
    let rms = (sum_sq / n as f64).sqrt();
    println!(
        "{frames} frames, {n} observations, {stereo} stereo matches, rms {rms:.3} px, max {max_err:.2} px"
    );
    assert_eq!(frames, 401);
    assert!(n > frames * 150, "too few observations: {n}");
    // 2-D isotropic noise of σ = 0.5 px: rms of the error norm is σ·√2.
    assert!((rms / (0.5 * 2f64.sqrt()) - 1.0).abs() < 0.05, "rms {rms}");
    assert!(max_err < 0.5 * 6.0);
    assert!(stereo > n / 4, "stereo association too rare: {stereo}");
}

#[test]
fn a_box_between_camera_and_wall_hides_the_wall_behind_it() {
    // A wall at x = 5 facing −x, a 1 m box at x ∈ [2, 3] in front of the camera at the origin.
    let wall = Surface::new(
        Vector3::new(5.0, -5.0, -5.0),
        Vector3::new(0.0, 10.0, 0.0),
        Vector3::new(0.0, 0.0, 10.0),
        -Vector3::x(),
    );
    let bx = Aabb::new(Vector3::new(2.0, -0.5, -0.5), Vector3::new(3.0, 0.5, 0.5));
    let scene = Arc::new(Scene::with_landmarks(vec![wall], vec![bx], 20.0, 1));
    let mut rig = common::rig(1);
    rig.cameras[0].t_b_c = common::forward_camera(Vector3::zeros());
    rig.cameras[0].max_features = 100_000;
    let sim = RigSim::new(rig, scene.clone(), 1);
    let pose = estimator::geometry::Pose::identity();
    let vis = sim.visible(0, &pose);
    assert!(!vis.is_empty());
    let mut hidden = 0;
    for lm in &scene.landmarks {
        // The box's shadow on the wall: |y|, |z| < 0.5·5/2 (projected from the origin through
        // the box's near face at x = 2), minus a margin.
        let in_shadow = lm.p.y.abs() < 1.2 && lm.p.z.abs() < 1.2;
        let seen = vis.iter().any(|p| p.id == lm.id);
        if in_shadow {
            assert!(!seen, "landmark {:?} behind the box was reported", lm.p);
            hidden += 1;
        }
    }
    assert!(hidden > 50);
    // Outside the shadow but within the field of view, the wall is seen.
    assert!(
        vis.iter()
            .any(|p| scene.landmarks[p.id as usize].p.y.abs() > 1.5)
    );
}

#[test]
fn max_track_length_ends_tracks() {
    let mut rig = common::rig(1);
    rig.cameras[0].max_track_length = Some(10);
    let world = World::new(WorldConfig {
        duration_s: 10.0,
        rig: Some(rig),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut run: std::collections::BTreeMap<u64, u32> = Default::default();
    for m in world.stream() {
        let Measurement::Frame(f) = m else { continue };
        let ids: Vec<u64> = f.cameras[0].features.iter().map(|o| o.feature_id).collect();
        run.retain(|id, _| ids.contains(id));
        for id in ids {
            let r = run.entry(id).or_insert(0);
            *r += 1;
            assert!(*r <= 10, "track {id} longer than 10 frames");
        }
    }
}

#[test]
fn euroc_radtan_rig_reprojects_through_the_distortion() {
    let world = World::new(WorldConfig {
        seed: 9,
        duration_s: 5.0,
        ..WorldConfig::default()
    })
    .unwrap();
    let rig = world.config().rig.clone().unwrap();
    let mut stream = world.stream();
    let (mut n, mut sum_sq) = (0usize, 0.0);
    while let Some(m) = stream.next() {
        let Measurement::Frame(f) = m else { continue };
        let gt = stream.truth(f.t_ns).unwrap();
        for cf in &f.cameras {
            let c = &rig.cameras[cf.cam_id];
            let t_c_w = gt.pose.compose(&c.t_b_c).inverse();
            for o in &cf.features {
                let uv = c
                    .model
                    .project(&t_c_w.transform(&stream.landmark(o.feature_id).unwrap().p))
                    .unwrap();
                sum_sq += (uv - o.uv).norm_squared();
                n += 1;
            }
        }
    }
    let rms = (sum_sq / n as f64).sqrt();
    assert!(n > 101 * 2 * 100, "{n}");
    assert!((rms / (0.5 * 2f64.sqrt()) - 1.0).abs() < 0.05, "rms {rms}");
}

/// Per frame, per camera: (feature id, pixel).
type Observed = Vec<Vec<Vec<(u64, nalgebra::Vector2<f64>)>>>;

/// Runs a sparse room (0.3 landmarks/m²) with noise-free cameras; returns per frame the
/// features of each camera and checks every observation against `Stream::landmark`.
fn sparse_run(cams: usize, reseed: bool) -> Observed {
    let mut rig = common::rig(cams);
    rig.reseed = reseed;
    for c in &mut rig.cameras {
        c.pixel_sigma = 0.0;
    }
    let world = World::new(WorldConfig {
        seed: 11,
        duration_s: 4.0,
        rig: Some(rig.clone()),
        scene: sim::scene::SceneConfig {
            landmark_density: 0.3,
            ..Default::default()
        },
        ..WorldConfig::default()
    })
    .unwrap();
    let scene = world.scene().clone();
    let mut stream = world.stream();
    let mut out = Vec::new();
    while let Some(m) = stream.next() {
        let Measurement::Frame(f) = m else { continue };
        let gt = stream.truth(f.t_ns).unwrap();
        let mut per_cam = Vec::new();
        for cf in &f.cameras {
            let c = &rig.cameras[cf.cam_id];
            let t_w_c = gt.pose.compose(&c.t_b_c);
            for o in &cf.features {
                let lm = stream.landmark(o.feature_id).expect("reported ids resolve");
                // Noise-free: the observation is the landmark's projection.
                let uv = c.model.project(&t_w_c.inverse().transform(&lm.p)).unwrap();
                assert!(
                    (uv - o.uv).norm() < 1e-6,
                    "id {}: {uv} vs {}",
                    o.feature_id,
                    o.uv
                );
                // The landmark lies on the first surface along the ray from the camera.
                let d = lm.p - t_w_c.p;
                let (t, _) = scene.ray_cast(&t_w_c.p, &d.normalize(), 1e-6, 1e3).unwrap();
                assert!(
                    (t - d.norm()).abs() < 1e-6,
                    "landmark {} is not on the first surface",
                    o.feature_id
                );
            }
            per_cam.push(cf.features.iter().map(|o| (o.feature_id, o.uv)).collect());
        }
        out.push(per_cam);
    }
    out
}

#[test]
fn sparse_views_are_reseeded_and_stay_consistent() {
    let without = sparse_run(2, false);
    let with = sparse_run(2, true);
    let mean = |runs: &Observed, cam: usize| {
        runs.iter().map(|f| f[cam].len()).sum::<usize>() as f64 / runs.len() as f64
    };
    let (a, b) = (mean(&without, 0), mean(&with, 0));
    println!("mean features per frame (cam0): {a:.1} without seeding, {b:.1} with");
    assert!(
        a < 100.0,
        "the sparse room should run short without seeding ({a})"
    );
    assert!(
        b > 1.3 * a && b > 100.0,
        "seeding should fill the view ({a} → {b})"
    );
    // Stereo association covers seeded landmarks: cam1 reports ids cam0 seeded.
    let seeded_in_both = with
        .iter()
        .flat_map(|f| {
            f[1].iter()
                .filter(|(id, _)| f[0].iter().any(|(i, _)| i == id))
        })
        .count();
    assert!(seeded_in_both > 0);
    // Appending a camera does not change the first one, seeding included.
    let alone = sparse_run(1, true);
    assert_eq!(alone.len(), with.len());
    for (x, y) in alone.iter().zip(&with) {
        assert_eq!(x[0], y[0]);
    }
}

#[test]
fn machine_hall_and_outdoor_presets_give_consistent_features() {
    for preset in [
        sim::scene::ScenePreset::MachineHall,
        sim::scene::ScenePreset::Outdoor,
    ] {
        let mut rig = common::rig(2);
        rig.reseed = true;
        for c in &mut rig.cameras {
            c.pixel_sigma = 0.0;
        }
        let world = World::new(WorldConfig {
            seed: 5,
            duration_s: 3.0,
            rig: Some(rig.clone()),
            scene: sim::scene::SceneConfig {
                preset,
                ..Default::default()
            },
            ..WorldConfig::default()
        })
        .unwrap();
        assert!(!world.scene().landmarks.is_empty());
        let mut stream = world.stream();
        let (mut frames, mut features) = (0usize, 0usize);
        while let Some(m) = stream.next() {
            let Measurement::Frame(f) = m else { continue };
            frames += 1;
            let gt = stream.truth(f.t_ns).unwrap();
            for cf in &f.cameras {
                let c = &rig.cameras[cf.cam_id];
                let t_c_w = gt.pose.compose(&c.t_b_c).inverse();
                for o in &cf.features {
                    let lm = stream.landmark(o.feature_id).unwrap();
                    let uv = c.model.project(&t_c_w.transform(&lm.p)).unwrap();
                    assert!((uv - o.uv).norm() < 1e-6);
                }
                features += cf.features.len();
            }
        }
        let mean = features as f64 / (2.0 * frames as f64);
        println!("{preset:?}: {mean:.1} features per camera and frame");
        assert!(
            mean > 100.0,
            "{preset:?}: only {mean:.1} features per camera and frame"
        );
    }
}

/// Per camera: feature id → the frames it was reported in.
fn reports_by_id(
    track_ids: TrackIds,
    seed: u64,
) -> Vec<std::collections::BTreeMap<u64, Vec<usize>>> {
    let mut rig = common::rig(2);
    rig.track_ids = track_ids;
    for c in &mut rig.cameras {
        // Large noise, so that some noisy pixels leave the image.
        c.pixel_sigma = 2.0;
    }
    let world = World::new(WorldConfig {
        seed,
        duration_s: 30.0,
        rig: Some(rig.clone()),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    let mut by_id = vec![std::collections::BTreeMap::<u64, Vec<usize>>::new(); 2];
    let (mut frame, mut outside) = (0, 0);
    while let Some(m) = stream.next() {
        let Measurement::Frame(f) = m else { continue };
        for cf in &f.cameras {
            let model = &rig.cameras[cf.cam_id].model;
            for o in &cf.features {
                assert!(stream.landmark(o.feature_id).is_some());
                let inside = in_image(model.width(), model.height(), &o.uv);
                outside += usize::from(!inside);
                by_id[cf.cam_id]
                    .entry(o.feature_id)
                    .or_default()
                    .push(frame);
            }
        }
        frame += 1;
    }
    match track_ids {
        TrackIds::Realistic => assert_eq!(outside, 0, "realistic tracks report pixels outside"),
        TrackIds::Landmark => assert!(outside > 0, "the noise should push some pixels out"),
    }
    by_id
}

/// Ids reported again after a gap of frames in camera 0 (which starts every track it has).
fn reappearing(by_id: &std::collections::BTreeMap<u64, Vec<usize>>) -> usize {
    by_id
        .values()
        .filter(|frames| frames.windows(2).any(|w| w[1] != w[0] + 1))
        .count()
}

#[test]
fn realistic_track_ids_are_new_after_every_reacquisition() {
    let realistic = reports_by_id(TrackIds::Realistic, 4);
    let ideal = reports_by_id(TrackIds::Landmark, 4);
    // With landmark ids, landmarks that leave the view come back under the same id.
    let back = reappearing(&ideal[0]);
    assert!(back > 100, "{back} landmark ids reappear after a gap");
    // A tracker's ids never do: each is one unbroken run of frames in the camera that began it.
    assert_eq!(reappearing(&realistic[0]), 0);
    // Stereo association still shares ids: most of cam1's tracks are cam0's.
    let shared = realistic[1]
        .keys()
        .filter(|id| realistic[0].contains_key(id))
        .count();
    assert!(
        shared * 10 > realistic[1].len() * 8,
        "{shared} of {} cam1 ids come from cam0",
        realistic[1].len()
    );
    // More tracks than landmarks: re-acquisitions are new tracks.
    let landmarks: std::collections::BTreeSet<u64> = ideal[0].keys().copied().collect();
    assert!(realistic[0].len() > landmarks.len() + back / 2);
}

#[test]
fn rolling_shutter_pixels_are_where_their_own_row_saw_them() {
    use estimator::camera::{ReadoutDirection, RollingShutter};
    let mut rig = common::rig(2);
    for (c, direction) in rig
        .cameras
        .iter_mut()
        .zip([ReadoutDirection::TopToBottom, ReadoutDirection::BottomToTop])
    {
        c.pixel_sigma = 0.0;
        c.rolling_shutter = RollingShutter {
            readout_s: 0.02,
            direction,
        };
    }
    let world = World::new(WorldConfig {
        seed: 4,
        duration_s: 10.0,
        rig: Some(rig.clone()),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    let (mut n, mut worst, mut shifts) = (0usize, 0.0f64, Vec::new());
    while let Some(m) = stream.next() {
        let Measurement::Frame(f) = m else { continue };
        let t_cap = f.t_ns + rig.td_ns;
        let at_stamp = stream.truth(t_cap).unwrap().pose;
        for cf in &f.cameras {
            let c = &rig.cameras[cf.cam_id];
            for o in &cf.features {
                let lm = stream.landmark(o.feature_id).unwrap().p;
                let dt_ns = (c.rolling_shutter.row_time_s(&o.uv, c.model.height()) * 1e9).round();
                let pose = stream.truth(t_cap + dt_ns as i64).unwrap().pose;
                let uv = c
                    .model
                    .project(&pose.compose(&c.t_b_c).inverse().transform(&lm))
                    .unwrap();
                worst = worst.max((uv - o.uv).norm());
                let global = c
                    .model
                    .project(&at_stamp.compose(&c.t_b_c).inverse().transform(&lm))
                    .unwrap();
                shifts.push((global - o.uv).norm());
                n += 1;
            }
        }
    }
    shifts.sort_by(f64::total_cmp);
    let median = shifts[shifts.len() / 2];
    println!(
        "{n} observations, worst {worst:.2e} px off its row's projection, median shift {median:.2} px"
    );
    assert!(n > 201 * 2 * 100, "{n}");
    // The fixed point is solved to 1e-9 px; the row time is rounded to the nanosecond.
    assert!(worst < 1e-4, "worst {worst}");
    // On the figure-eight the rows' motion moves features by pixels: the test sees the shutter.
    assert!(median > 0.3, "median shift {median} px");
}

/// Under a tracker error model, a track's error against the truth is a white jitter on a
/// random walk from its first observation (per-axis variance `σ_w² + k·σ_d²` at age `k`), and
/// the second camera sees the first camera's error of the same track plus its own stereo σ.
#[test]
fn tracker_error_drifts_along_a_track_and_the_stereo_match_follows_it() {
    let model = sim::tracker_error::TrackerErrorModel {
        white_px: 0.1,
        drift_px: 0.03,
        sliding_fraction: 0.0,
        sliding_drift_px: 1.0,
        stereo_px: 0.07,
    };
    let mut rig = common::rig(2);
    for c in &mut rig.cameras {
        c.tracker_error = Some(model);
    }
    let world = World::new(WorldConfig {
        seed: 5,
        duration_s: 40.0,
        rig: Some(rig.clone()),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    let ages = 20usize;
    let (mut var, mut count) = (vec![0.0f64; ages], vec![0usize; ages]);
    let (mut stereo, mut pairs) = (0.0f64, 0usize);
    let mut first: std::collections::BTreeMap<u64, usize> = Default::default();
    let mut frame = 0usize;
    while let Some(m) = stream.next() {
        let Measurement::Frame(f) = m else { continue };
        let gt = stream.truth(f.t_ns).unwrap();
        let mut left = std::collections::BTreeMap::new();
        for cf in &f.cameras {
            let c = &rig.cameras[cf.cam_id];
            let t_c_w = gt.pose.compose(&c.t_b_c).inverse();
            for o in &cf.features {
                let lm = stream.landmark(o.feature_id).unwrap();
                let e = o.uv - c.model.project(&t_c_w.transform(&lm.p)).unwrap();
                if cf.cam_id == 0 {
                    left.insert(o.feature_id, e);
                    let age = frame - *first.entry(o.feature_id).or_insert(frame);
                    if age < ages {
                        var[age] += 0.5 * e.norm_squared();
                        count[age] += 1;
                    }
                } else if let Some(l) = left.get(&o.feature_id) {
                    stereo += 0.5 * (e - l).norm_squared();
                    pairs += 1;
                }
            }
        }
        frame += 1;
    }
    for k in 0..ages {
        let (v, want) = (var[k] / count[k] as f64, 0.01 + k as f64 * 0.0009);
        assert!(count[k] > 500, "age {k}: {} samples", count[k]);
        assert!(
            (v - want).abs() < 0.12 * want,
            "age {k}: {v} against {want}"
        );
    }
    let s = (stereo / pairs as f64).sqrt();
    assert!(
        pairs > 10_000 && (s - 0.07).abs() < 0.005,
        "{pairs} pairs, σ {s}"
    );
}
