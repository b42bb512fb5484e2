//! Reprojection factors with inverse depth anchored in the first observing frame.
//!
//! A feature is parameterized by its inverse depth `λ` along the anchor camera's normalized ray
//! `(x, y, 1)`. Residuals live on the normalized image plane of the observing camera, as in
//! VINS-Fusion: `r = w · (π(P_c) − z_obs)` with `π(P) = (P_x/P_z, P_y/P_z)` and `w` the square-root
//! information (focal length / pixel σ for an isotropic pixel noise). Model-agnostic: any
//! [`crate::camera::CameraModel`] that unprojects to z > 0 feeds it.
//!
//! Time offset: a measurement taken at camera time `t` belongs to IMU time `t + td`. The front end
//! timestamps it with the current estimate `td_meas`; when the estimate moves to `td`, the feature
//! is shifted along its image velocity: `z(td) = z − (td − td_meas) · velocity` (Qin & Shen 2018).

use nalgebra::{Matrix2x3, Matrix3, SMatrix, UnitQuaternion, Vector2, Vector3};

use crate::geometry::{Pose, skew};
use crate::problem::{Factor, write_row_major};

/// One observation of a feature as the reprojection factors consume it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeatureMeasurement {
    /// Undistorted normalized-plane coordinates `(x/z, y/z)`.
    pub point: Vector2<f64>,
    /// Image-plane velocity of the feature in normalized coordinates per second.
    pub velocity: Vector2<f64>,
    /// The time offset (s) with which this measurement was stamped.
    pub td: f64,
}

impl FeatureMeasurement {
    /// A measurement with zero velocity stamped at `td = 0`.
    pub fn new(point: Vector2<f64>) -> Self {
        Self {
            point,
            velocity: Vector2::zeros(),
            td: 0.0,
        }
    }

    /// The point shifted to time offset `td`, as a homogeneous ray `(x, y, 1)`.
    #[inline]
    fn at_td(&self, td: f64) -> Vector3<f64> {
        let p = self.point - (td - self.td) * self.velocity;
        Vector3::new(p.x, p.y, 1.0)
    }
}

/// Which derivatives the core should produce.
#[derive(Clone, Copy, Default)]
struct Wanted {
    pose_i: bool,
    pose_j: bool,
    ex_a: bool,
    ex_b: bool,
    inv_depth: bool,
    td: bool,
}

/// Jacobians of the (whitened) 2-D residual with respect to each role.
#[derive(Default)]
struct CoreJacobians {
    pose_i: SMatrix<f64, 2, 6>,
    pose_j: SMatrix<f64, 2, 6>,
    ex_a: SMatrix<f64, 2, 6>,
    ex_b: SMatrix<f64, 2, 6>,
    inv_depth: SMatrix<f64, 2, 1>,
    td: SMatrix<f64, 2, 1>,
}

/// The general chain: anchor camera `a` of body frame `i` → world → body frame `j` → camera `b`.
/// The three public factors are this chain with blocks shared (one camera) or poses fixed to the
/// identity (one frame).
#[allow(clippy::too_many_arguments)]
#[inline]
fn reproject_core(
    obs_i: &FeatureMeasurement,
    obs_j: &FeatureMeasurement,
    weight: f64,
    pose_i: &Pose,
    pose_j: &Pose,
    ex_a: &Pose,
    ex_b: &Pose,
    inv_depth: f64,
    td: f64,
    residual: &mut [f64],
    wanted: Wanted,
    jac: &mut CoreJacobians,
) -> bool {
    let ray_i = obs_i.at_td(td);
    let ray_j = obs_j.at_td(td);
    let p_ca = ray_i / inv_depth;
    let ra = rot(&ex_a.q);
    let ri = rot(&pose_i.q);
    let rj_t = rot(&pose_j.q).transpose();
    let rb_t = rot(&ex_b.q).transpose();
    let p_bi = ra * p_ca + ex_a.p;
    let p_w = ri * p_bi + pose_i.p;
    let p_bj = rj_t * (p_w - pose_j.p);
    let p_cb = rb_t * (p_bj - ex_b.p);
    if !(p_cb.z.abs() > 1e-9 && inv_depth.is_finite()) {
        return false;
    }
    let inv_z = 1.0 / p_cb.z;
    residual[0] = weight * (p_cb.x * inv_z - ray_j.x);
    residual[1] = weight * (p_cb.y * inv_z - ray_j.y);

    let any = wanted.pose_i || wanted.pose_j || wanted.ex_a || wanted.ex_b;
    if !(any || wanted.inv_depth || wanted.td) {
        return true;
    }
    let wz = weight * inv_z;
    let reduce = Matrix2x3::new(wz, 0.0, -wz * p_cb.x * inv_z, 0.0, wz, -wz * p_cb.y * inv_z);
    // d P_cb / d P_w and d P_cb / d P_ca.
    let a: Matrix3<f64> = rb_t * rj_t;
    let a_ri = a * ri;
    let a_ri_ra = a_ri * ra;
    let red_a = reduce * a;
    if wanted.pose_i {
        jac.pose_i.fixed_view_mut::<2, 3>(0, 0).copy_from(&red_a);
        jac.pose_i
            .fixed_view_mut::<2, 3>(0, 3)
            .copy_from(&(-(reduce * a_ri) * skew(&p_bi)));
    }
    if wanted.pose_j {
        jac.pose_j.fixed_view_mut::<2, 3>(0, 0).copy_from(&-red_a);
        jac.pose_j
            .fixed_view_mut::<2, 3>(0, 3)
            .copy_from(&(reduce * rb_t * skew(&p_bj)));
    }
    if wanted.ex_a {
        let red_a_ri = reduce * a_ri;
        jac.ex_a.fixed_view_mut::<2, 3>(0, 0).copy_from(&red_a_ri);
        jac.ex_a
            .fixed_view_mut::<2, 3>(0, 3)
            .copy_from(&(-(reduce * a_ri_ra) * skew(&p_ca)));
    }
    if wanted.ex_b {
        jac.ex_b
            .fixed_view_mut::<2, 3>(0, 0)
            .copy_from(&(-reduce * rb_t));
        jac.ex_b
            .fixed_view_mut::<2, 3>(0, 3)
            .copy_from(&(reduce * skew(&p_cb)));
    }
    if wanted.inv_depth || wanted.td {
        let red_chain = reduce * a_ri_ra;
        if wanted.inv_depth {
            jac.inv_depth = red_chain * (-ray_i / (inv_depth * inv_depth));
        }
        if wanted.td {
            let vel_i = Vector3::new(obs_i.velocity.x, obs_i.velocity.y, 0.0);
            jac.td = red_chain * (-vel_i / inv_depth) + weight * obs_j.velocity;
        }
    }
    true
}

#[inline]
fn rot(q: &UnitQuaternion<f64>) -> Matrix3<f64> {
    q.to_rotation_matrix().into_inner()
}

#[inline]
fn put<const C: usize>(
    jacobians: &mut Option<&mut [Option<&mut [f64]>]>,
    k: usize,
    m: &SMatrix<f64, 2, C>,
) {
    if let Some(js) = jacobians.as_deref_mut()
        && let Some(out) = js[k].as_deref_mut()
    {
        write_row_major(m, out);
    }
}

fn wants(jacobians: &Option<&mut [Option<&mut [f64]>]>, k: usize) -> bool {
    jacobians.as_ref().is_some_and(|j| j[k].is_some())
}

/// A feature anchored in frame `i` and observed in frame `j` by the same camera.
///
/// Parameter blocks: `pose_i` (7), `pose_j` (7), `T_b_c` (7), inverse depth (1), `td` (1).
#[derive(Clone, Debug)]
pub struct ProjectionTwoFrameOneCam {
    /// Anchor observation (frame i).
    pub obs_i: FeatureMeasurement,
    /// Observation in frame j.
    pub obs_j: FeatureMeasurement,
    /// Square-root information on the normalized plane (focal / pixel σ).
    pub weight: f64,
}

impl Factor for ProjectionTwoFrameOneCam {
    fn residual_dim(&self) -> usize {
        2
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 7, 7, 1, 1]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6, 6, 1, 1]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        mut jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let ex = Pose::from_slice(params[2]);
        let wanted = Wanted {
            pose_i: wants(&jacobians, 0),
            pose_j: wants(&jacobians, 1),
            ex_a: wants(&jacobians, 2),
            ex_b: wants(&jacobians, 2),
            inv_depth: wants(&jacobians, 3),
            td: wants(&jacobians, 4),
        };
        let mut jac = CoreJacobians::default();
        let ok = reproject_core(
            &self.obs_i,
            &self.obs_j,
            self.weight,
            &Pose::from_slice(params[0]),
            &Pose::from_slice(params[1]),
            &ex,
            &ex,
            params[3][0],
            params[4][0],
            residuals,
            wanted,
            &mut jac,
        );
        if ok && jacobians.is_some() {
            put(&mut jacobians, 0, &jac.pose_i);
            put(&mut jacobians, 1, &jac.pose_j);
            put(&mut jacobians, 2, &(jac.ex_a + jac.ex_b));
            put(&mut jacobians, 3, &jac.inv_depth);
            put(&mut jacobians, 4, &jac.td);
        }
        ok
    }
}

/// A feature anchored in camera `a` of frame `i` and observed by another camera `b` in frame `j`.
///
/// Parameter blocks: `pose_i` (7), `pose_j` (7), `T_b_ca` (7), `T_b_cb` (7), inverse depth (1),
/// `td` (1).
#[derive(Clone, Debug)]
pub struct ProjectionTwoFrameTwoCam {
    /// Anchor observation (camera a, frame i).
    pub obs_i: FeatureMeasurement,
    /// Observation by camera b in frame j.
    pub obs_j: FeatureMeasurement,
    /// Square-root information on the normalized plane.
    pub weight: f64,
}

impl Factor for ProjectionTwoFrameTwoCam {
    fn residual_dim(&self) -> usize {
        2
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 7, 7, 7, 1, 1]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6, 6, 6, 1, 1]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        mut jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let wanted = Wanted {
            pose_i: wants(&jacobians, 0),
            pose_j: wants(&jacobians, 1),
            ex_a: wants(&jacobians, 2),
            ex_b: wants(&jacobians, 3),
            inv_depth: wants(&jacobians, 4),
            td: wants(&jacobians, 5),
        };
        let mut jac = CoreJacobians::default();
        let ok = reproject_core(
            &self.obs_i,
            &self.obs_j,
            self.weight,
            &Pose::from_slice(params[0]),
            &Pose::from_slice(params[1]),
            &Pose::from_slice(params[2]),
            &Pose::from_slice(params[3]),
            params[4][0],
            params[5][0],
            residuals,
            wanted,
            &mut jac,
        );
        if ok && jacobians.is_some() {
            put(&mut jacobians, 0, &jac.pose_i);
            put(&mut jacobians, 1, &jac.pose_j);
            put(&mut jacobians, 2, &jac.ex_a);
            put(&mut jacobians, 3, &jac.ex_b);
            put(&mut jacobians, 4, &jac.inv_depth);
            put(&mut jacobians, 5, &jac.td);
        }
        ok
    }
}

/// A feature anchored in camera `a` and observed by camera `b` in the same frame (stereo).
///
/// Parameter blocks: `T_b_ca` (7), `T_b_cb` (7), inverse depth (1), `td` (1). The body pose
/// cancels, so this factor constrains depth and the extrinsics only.
#[derive(Clone, Debug)]
pub struct ProjectionOneFrameTwoCam {
    /// Anchor observation (camera a).
    pub obs_a: FeatureMeasurement,
    /// Observation by camera b at the same time.
    pub obs_b: FeatureMeasurement,
    /// Square-root information on the normalized plane.
    pub weight: f64,
}

impl Factor for ProjectionOneFrameTwoCam {
    fn residual_dim(&self) -> usize {
        2
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[7, 7, 1, 1]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6, 1, 1]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        mut jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let wanted = Wanted {
            ex_a: wants(&jacobians, 0),
            ex_b: wants(&jacobians, 1),
            inv_depth: wants(&jacobians, 2),
            td: wants(&jacobians, 3),
            ..Wanted::default()
        };
        let mut jac = CoreJacobians::default();
        let id = Pose::identity();
        let ok = reproject_core(
            &self.obs_a,
            &self.obs_b,
            self.weight,
            &id,
            &id,
            &Pose::from_slice(params[0]),
            &Pose::from_slice(params[1]),
            params[2][0],
            params[3][0],
            residuals,
            wanted,
            &mut jac,
        );
        if ok && jacobians.is_some() {
            put(&mut jacobians, 0, &jac.ex_a);
            put(&mut jacobians, 1, &jac.ex_b);
            put(&mut jacobians, 2, &jac.inv_depth);
            put(&mut jacobians, 3, &jac.td);
        }
        ok
    }
}
