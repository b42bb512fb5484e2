//! Shared test helpers: a minimal pinhole camera model and rigs.
#![allow(dead_code)]

use estimator::camera::CameraModel;
use estimator::geometry::Pose;
use nalgebra::{Matrix2x3, Matrix3, UnitQuaternion, Vector2, Vector3};
use sim::camera::{CameraConfig, RigConfig};
use std::sync::Arc;

/// Undistorted pinhole (test-only stand-in for the estimator's models).
#[derive(Debug, Clone)]
pub struct Pinhole {
    pub w: u32,
    pub h: u32,
    pub f: f64,
    pub cx: f64,
    pub cy: f64,
}

impl Pinhole {
    pub fn euroc_like() -> Self {
        Self {
            w: 752,
            h: 480,
            f: 458.0,
            cx: 367.0,
            cy: 248.0,
        }
    }
}

impl CameraModel for Pinhole {
    fn width(&self) -> u32 {
        self.w
    }
    fn height(&self) -> u32 {
        self.h
    }
    fn project(&self, p: &Vector3<f64>) -> Option<Vector2<f64>> {
        (p.z > 1e-6)
            .then(|| Vector2::new(self.f * p.x / p.z + self.cx, self.f * p.y / p.z + self.cy))
    }
    fn project_with_jacobian(&self, p: &Vector3<f64>) -> Option<(Vector2<f64>, Matrix2x3<f64>)> {
        let uv = self.project(p)?;
        let iz = 1.0 / p.z;
        let j = Matrix2x3::new(
            self.f * iz,
            0.0,
            -self.f * p.x * iz * iz,
            0.0,
            self.f * iz,
            -self.f * p.y * iz * iz,
        );
        Some((uv, j))
    }
    fn unproject(&self, uv: &Vector2<f64>) -> Option<Vector3<f64>> {
        Some(Vector3::new((uv.x - self.cx) / self.f, (uv.y - self.cy) / self.f, 1.0).normalize())
    }
    fn is_valid(&self, uv: &Vector2<f64>) -> bool {
        uv.x >= -0.5 && uv.y >= -0.5 && uv.x <= self.w as f64 - 0.5 && uv.y <= self.h as f64 - 0.5
    }
}

/// Camera looking along body +x (camera x = body −y, camera y = body −z), at body offset `p`.
pub fn forward_camera(p: Vector3<f64>) -> Pose {
    let r = Matrix3::new(0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0);
    Pose::new(UnitQuaternion::from_matrix(&r), p)
}

/// A stereo rig (baseline 0.11 m) of `n` (1 or 2) forward cameras.
pub fn rig(n: usize) -> RigConfig {
    let model: Arc<dyn CameraModel> = Arc::new(Pinhole::euroc_like());
    let mut cams = vec![CameraConfig::new(
        "cam0",
        model.clone(),
        forward_camera(Vector3::new(0.0, 0.055, 0.0)),
    )];
    if n > 1 {
        cams.push(CameraConfig::new(
            "cam1",
            model,
            forward_camera(Vector3::new(0.0, -0.055, 0.0)),
        ));
    }
    RigConfig::new(cams)
}
