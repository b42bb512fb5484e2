//! Geometry helpers of the tracker: pyramids of possibly equalized images, gyro-predicted
//! feature positions, stereo epipolar/depth checks and the median disparity.

use nalgebra::{UnitQuaternion, Vector2, Vector3};

use super::image::{ImageView, OwnedImage, Pyramid};
use super::types::TrackerCamera;
use crate::camera::CameraModel;

/// Builds `pyr` from `image`, equalized first when asked.
pub(super) fn build_pyramid(
    pyr: &mut Pyramid,
    image: &ImageView<'_>,
    equalize: bool,
    max_level: usize,
) {
    if equalize {
        let eq = OwnedImage::equalized(image);
        pyr.rebuild(&eq.view(), max_level);
    } else {
        pyr.rebuild(image, max_level);
    }
}

/// Where a pixel moves under a pure camera rotation `R_ccur_cprev` (points far away).
#[allow(non_snake_case)]
pub(super) fn predict(
    model: &dyn CameraModel,
    R_ccur_cprev: &UnitQuaternion<f64>,
    uv: &Vector2<f64>,
) -> Option<Vector2<f64>> {
    let f = model.unproject(uv)?;
    let g = R_ccur_cprev * f;
    let q = model.project(&g)?;
    model.is_valid(&q).then_some(q)
}

/// The relative pose of a camera pair, for epipolar and depth checks of matches.
#[allow(non_snake_case)]
pub(super) struct StereoGeometry {
    /// `R_c0_c1`.
    R: nalgebra::Matrix3<f64>,
    /// `p_c0_c1`.
    t: Vector3<f64>,
}

impl StereoGeometry {
    pub(super) fn new(c0: &TrackerCamera, c1: &TrackerCamera) -> Self {
        let t_c0_c1 = c0.T_b_c.inverse().compose(&c1.T_b_c);
        Self {
            R: t_c0_c1.q.to_rotation_matrix().into_inner(),
            t: t_c0_c1.p,
        }
    }

    /// True if bearings `f0` (camera 0) and `f1` (camera 1) are within `tol` rad of coplanar
    /// with the baseline and their rays meet in front of both cameras.
    pub(super) fn accepts(&self, f0: &Vector3<f64>, f1: &Vector3<f64>, tol: f64) -> bool {
        let f0 = f0.normalize();
        let g1 = (self.R * f1).normalize();
        let n = self.t.cross(&g1);
        let nn = n.norm();
        if nn < 1e-12 {
            return false;
        }
        if (f0.dot(&n) / nn).abs() > tol {
            return false;
        }
        // Solve λ0·f0 − λ1·g1 ≈ t in least squares; both depths must be positive.
        let (a, b, c) = (f0.dot(&f0), -f0.dot(&g1), g1.dot(&g1));
        let (d, e) = (f0.dot(&self.t), -g1.dot(&self.t));
        let det = a * c - b * b;
        if det.abs() < 1e-12 {
            return false;
        }
        let l0 = (c * d - b * e) / det;
        let l1 = (a * e - b * d) / det;
        l0 > 0.0 && l1 > 0.0
    }
}

/// Component-wise median (lower middle) of a set of 2-vectors.
pub(super) fn median2(v: &mut [Vector2<f64>]) -> Option<Vector2<f64>> {
    if v.is_empty() {
        return None;
    }
    let m = v.len() / 2;
    let mut xs: Vec<f64> = v.iter().map(|p| p.x).collect();
    let mut ys: Vec<f64> = v.iter().map(|p| p.y).collect();
    xs.sort_by(f64::total_cmp);
    ys.sort_by(f64::total_cmp);
    Some(Vector2::new(xs[m], ys[m]))
}
