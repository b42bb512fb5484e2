//! Landmark initialization and outlier rejection over the window's tracks.

use nalgebra::{Matrix4, SymmetricEigen, Vector2, Vector3, Vector4};

use super::config::EstimatorConfig;
use super::window::Window;
use crate::geometry::Pose;

/// Triangulates tracks without depth from every camera view of the track in the window (DLT),
/// keeping those whose depth along the anchor camera's ray is in range and that reproject onto
/// every observation within 5× `outlier_reprojection_sigma` pixel σ of its camera. `focal`:
/// effective focal length of each camera (px).
pub(super) fn triangulate_tracks(window: &mut Window, config: &EstimatorConfig, focal: &[f64]) {
    let ids: Vec<u64> = window
        .features
        .tracks
        .iter()
        .filter(|(_, t)| t.inv_depth.is_none())
        .map(|(id, _)| *id)
        .collect();
    for id in ids {
        let track = &window.features.tracks[&id];
        let mut views: Vec<(Pose, Vector2<f64>)> = Vec::new();
        // Each view's largest reprojection error in normalized coordinates.
        let mut limits: Vec<f64> = Vec::new();
        let anchor = &track.obs[0];
        let Some(ai) = window.frame_index(anchor.seq) else {
            continue;
        };
        let anchor_cam = window.camera_pose(ai, track.anchor_cam);
        for o in &track.obs {
            let Some(fi) = window.frame_index(o.seq) else {
                continue;
            };
            for cam in 0..2 {
                if let Some(m) = o.meas[cam] {
                    views.push((window.camera_pose(fi, cam), m.point));
                    limits.push(outlier_limit_px(config, cam) * 5.0 / focal[cam]);
                }
            }
        }
        if views.len() < 2 {
            continue;
        }
        let Some(p_w) = triangulate(&views) else {
            continue;
        };
        let p_c = anchor_cam.inverse().transform(&p_w);
        if p_c.z < config.min_depth_m || p_c.z > config.max_depth_m {
            continue;
        }
        // Reject triangulations that do not reproject onto their observations.
        let ok = views.iter().zip(&limits).all(|((t_w_c, z), limit)| {
            let q = t_w_c.inverse().transform(&p_w);
            q.z > 0.0 && (Vector2::new(q.x / q.z, q.y / q.z) - z).norm() < *limit
        });
        if ok {
            window
                .features
                .tracks
                .get_mut(&id)
                .expect("exists")
                .set_inv_depth(Some(1.0 / p_c.z));
        }
    }
}

/// The outlier test's reprojection error of camera `cam` (px): `outlier_reprojection_sigma`
/// of its pixel σ.
fn outlier_limit_px(config: &EstimatorConfig, cam: usize) -> f64 {
    config.outlier_reprojection_sigma * config.cameras[cam].pixel_sigma
}

/// Drops tracks whose mean reprojection error (distorted pixels, both cameras, each in units
/// of its camera's outlier limit) exceeds 1: a track seen by cameras of one noise level is
/// dropped past `outlier_reprojection_sigma` of their pixel σ. Returns how many triangulated
/// tracks were checked and how many of them dropped.
pub(super) fn reject_outliers(window: &mut Window, config: &EstimatorConfig) -> (usize, usize) {
    let (mut bad, mut checked) = (Vec::new(), 0);
    // `T_c_w` of both cameras of every window frame, by frame sequence number.
    let cameras = window.extrinsics.len();
    let t_c_w: Vec<(u64, [Option<Pose>; 2])> = (0..window.frames.len())
        .map(|fi| {
            let cam = |c: usize| (c < cameras).then(|| window.camera_pose(fi, c).inverse());
            (window.frames[fi].seq, [cam(0), cam(1)])
        })
        .collect();
    for (id, t) in &window.features.tracks {
        let Some(p_w) = window.track_world_point(*id) else {
            continue;
        };
        let (mut sum, mut n) = (0.0, 0);
        for o in &t.obs {
            let Some((_, poses)) = t_c_w.iter().find(|(seq, _)| *seq == o.seq) else {
                continue;
            };
            for cam in 0..2 {
                let (Some(uv), Some(_), Some(pose)) = (o.uv[cam], o.meas[cam], &poses[cam]) else {
                    continue;
                };
                let p_c = pose.transform(&p_w);
                let limit = outlier_limit_px(config, cam);
                match config.cameras[cam].model.project(&p_c) {
                    Some(px) if p_c.z > 0.0 => sum += (px - uv).norm() / limit,
                    _ => sum += 1e3,
                }
                n += 1;
            }
        }
        checked += usize::from(n > 0);
        if n > 0 && sum / n as f64 > 1.0 {
            bad.push(*id);
        }
    }
    let rejected = bad.len();
    for id in bad {
        window.features.tracks.remove(&id);
    }
    (checked, rejected)
}

/// Linear triangulation (DLT) of one point from camera poses `T_w_c` and normalized
/// observations, by the smallest eigenvector of `AᵀA`.
pub(super) fn triangulate(views: &[(Pose, Vector2<f64>)]) -> Option<Vector3<f64>> {
    let mut ata = Matrix4::<f64>::zeros();
    for (t_w_c, z) in views {
        let t_c_w = t_w_c.inverse();
        let r = t_c_w.q.to_rotation_matrix().into_inner();
        let p = [
            Vector4::new(r[(0, 0)], r[(0, 1)], r[(0, 2)], t_c_w.p.x),
            Vector4::new(r[(1, 0)], r[(1, 1)], r[(1, 2)], t_c_w.p.y),
            Vector4::new(r[(2, 0)], r[(2, 1)], r[(2, 2)], t_c_w.p.z),
        ];
        for row in [p[0] - p[2] * z.x, p[1] - p[2] * z.y] {
            ata += row * row.transpose();
        }
    }
    let eig = SymmetricEigen::new(ata);
    let (mut imin, mut vmin) = (0, f64::INFINITY);
    for i in 0..4 {
        if eig.eigenvalues[i] < vmin {
            vmin = eig.eigenvalues[i];
            imin = i;
        }
    }
    let x = eig.eigenvectors.column(imin);
    if x[3].abs() < 1e-12 {
        return None;
    }
    let p = Vector3::new(x[0] / x[3], x[1] / x[3], x[2] / x[3]);
    p.iter().all(|v| v.is_finite()).then_some(p)
}
