//! Reprojection factors with inverse depth anchored in the first observing frame.
//!
//! A feature is a landmark block `[λ, cx, cy]`: its inverse depth `λ` along the anchor camera's
//! normalized ray `(x + cx, y + cy, 1)`, where `(x, y)` is the anchor measurement and
//! `(cx, cy)` the correction of that measurement's noise, estimated like everything else and
//! held to zero by [`AnchorBearing`] with the measurement's weight. The anchor observation is
//! thus a residual like any other rather than an exact ray (the 1-dof form VINS-Fusion uses,
//! which credits every track's anchor with perfect accuracy and makes the window overconfident
//! about the relative poses of anchor frames). Residuals live on the normalized image plane of the observing camera, as in
//! VINS-Fusion: `r = w · (π(P_c) − z_obs)` with `π(P) = (P_x/P_z, P_y/P_z)` and `w` the square-root
//! information (focal length / pixel σ for an isotropic pixel noise). Model-agnostic: any
//! [`crate::camera::CameraModel`] that unprojects to z > 0 feeds it.
//!
//! Time offset: a measurement taken at camera time `t` belongs to IMU time `t + td`. The front end
//! timestamps it with the current estimate `td_meas`; when the estimate moves to `td`, the feature
//! is shifted along its image velocity: `z(td) = z − (td − td_meas) · velocity` (Qin & Shen 2018).

use nalgebra::{Matrix2x3, Matrix3, UnitQuaternion, Vector2, Vector3};

use crate::geometry::Pose;
use crate::problem::Factor;

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

    /// The normalized point shifted to time offset `td` along its image velocity.
    #[inline]
    pub fn point_at_td(&self, td: f64) -> Vector2<f64> {
        self.point - (td - self.td) * self.velocity
    }

    /// The point shifted to time offset `td`, as a homogeneous ray `(x, y, 1)`.
    #[inline]
    fn at_td(&self, td: f64) -> Vector3<f64> {
        let p = self.point_at_td(td);
        Vector3::new(p.x, p.y, 1.0)
    }
}

/// Where the core writes each role's Jacobian (row-major `2 × t`); `None` = not wanted.
#[derive(Default)]
struct CoreOut<'a> {
    pose_i: Option<&'a mut [f64]>,
    pose_j: Option<&'a mut [f64]>,
    ex_a: Option<&'a mut [f64]>,
    ex_b: Option<&'a mut [f64]>,
    /// One extrinsic block for both cameras (the same-camera factor): `∂/∂ex_a + ∂/∂ex_b`.
    ex_shared: Option<&'a mut [f64]>,
    landmark: Option<&'a mut [f64]>,
    td: Option<&'a mut [f64]>,
}

impl CoreOut<'_> {
    fn any(&self) -> bool {
        self.pose_i.is_some()
            || self.pose_j.is_some()
            || self.ex_a.is_some()
            || self.ex_b.is_some()
            || self.ex_shared.is_some()
            || self.landmark.is_some()
            || self.td.is_some()
    }
}

/// Rotation matrices of the chain's poses computed by the caller (`None`: compute here).
#[derive(Clone, Copy, Default)]
struct Rotations<'a> {
    pose_i: Option<&'a Matrix3<f64>>,
    pose_j: Option<&'a Matrix3<f64>>,
    ex_a: Option<&'a Matrix3<f64>>,
    ex_b: Option<&'a Matrix3<f64>>,
}

/// `u ⋅ [p]×` for each row `u` of `m`: row-wise `u × p`.
#[inline(always)]
fn rows_times_skew(m: &Matrix2x3<f64>, p: &Vector3<f64>) -> Matrix2x3<f64> {
    let mut out = Matrix2x3::zeros();
    for r in 0..2 {
        let (u0, u1, u2) = (m[(r, 0)], m[(r, 1)], m[(r, 2)]);
        out[(r, 0)] = u1 * p.z - u2 * p.y;
        out[(r, 1)] = u2 * p.x - u0 * p.z;
        out[(r, 2)] = u0 * p.y - u1 * p.x;
    }
    out
}

/// Writes a pose Jacobian `[T | R]` (two 2×3 halves, translation then rotation) row-major.
#[inline(always)]
pub(super) fn write_pose(out: &mut [f64], t: &Matrix2x3<f64>, r: &Matrix2x3<f64>) {
    for row in 0..2 {
        for c in 0..3 {
            out[row * 6 + c] = t[(row, c)];
            out[row * 6 + 3 + c] = r[(row, c)];
        }
    }
}

/// The general chain: anchor camera `a` of body frame `i` → world → body frame `j` → camera `b`.
/// The three public factors are this chain with blocks shared (one camera) or poses fixed to the
/// identity (one frame). `shared_ex`: `ex_a` and `ex_b` are the same block.
///
/// The Jacobians are products of the 2×3 projection derivative with rotations, evaluated left to
/// right (row vectors times 3×3 matrices), so no 3×3 × 3×3 product is formed.
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
    shared_ex: bool,
    landmark: &[f64],
    td: f64,
    rotations: Rotations,
    residual: &mut [f64],
    out: &mut CoreOut,
) -> bool {
    let inv_depth = landmark[0];
    let ray_i = obs_i.at_td(td) + Vector3::new(landmark[1], landmark[2], 0.0);
    let ray_j = obs_j.at_td(td);
    let depth = 1.0 / inv_depth;
    let p_ca = ray_i * depth;
    // The caller's matrices where given (no copy), else computed here.
    let (own_a, own_i, own_j, own_b);
    let ra: &Matrix3<f64> = match rotations.ex_a {
        Some(m) => m,
        None => {
            own_a = rot(&ex_a.q);
            &own_a
        }
    };
    let ri: &Matrix3<f64> = match rotations.pose_i {
        Some(m) => m,
        None => {
            own_i = rot(&pose_i.q);
            &own_i
        }
    };
    let rj: &Matrix3<f64> = match rotations.pose_j {
        Some(m) => m,
        None => {
            own_j = rot(&pose_j.q);
            &own_j
        }
    };
    let rb: &Matrix3<f64> = match (shared_ex, rotations.ex_b) {
        (true, _) => ra,
        (false, Some(m)) => m,
        (false, None) => {
            own_b = rot(&ex_b.q);
            &own_b
        }
    };
    let p_bi = ra * p_ca + ex_a.p;
    let p_w = ri * p_bi + pose_i.p;
    let p_bj = rj.tr_mul(&(p_w - pose_j.p));
    let p_cb = rb.tr_mul(&(p_bj - ex_b.p));
    if !(p_cb.z.abs() > 1e-9 && inv_depth.is_finite()) {
        return false;
    }
    let inv_z = 1.0 / p_cb.z;
    residual[0] = weight * (p_cb.x * inv_z - ray_j.x);
    residual[1] = weight * (p_cb.y * inv_z - ray_j.y);
    if !out.any() {
        return true;
    }
    let wz = weight * inv_z;
    let reduce = Matrix2x3::new(wz, 0.0, -wz * p_cb.x * inv_z, 0.0, wz, -wz * p_cb.y * inv_z);
    // ∂r/∂P for the point in each frame along the chain.
    let d_bj = reduce * rb.transpose();
    let d_w = d_bj * rj.transpose();
    let d_bi = d_w * ri;
    if let Some(o) = out.pose_i.as_deref_mut() {
        write_pose(o, &d_w, &-rows_times_skew(&d_bi, &p_bi));
    }
    if let Some(o) = out.pose_j.as_deref_mut() {
        write_pose(o, &-d_w, &rows_times_skew(&d_bj, &p_bj));
    }
    let need_ca =
        out.ex_a.is_some() || out.ex_shared.is_some() || out.landmark.is_some() || out.td.is_some();
    if !need_ca && out.ex_b.is_none() {
        return true;
    }
    let d_ca = d_bi * ra;
    let ex_a_rot = -rows_times_skew(&d_ca, &p_ca);
    let ex_b_rot = rows_times_skew(&reduce, &p_cb);
    if let Some(o) = out.ex_a.as_deref_mut() {
        write_pose(o, &d_bi, &ex_a_rot);
    }
    if let Some(o) = out.ex_b.as_deref_mut() {
        write_pose(o, &-d_bj, &ex_b_rot);
    }
    if let Some(o) = out.ex_shared.as_deref_mut() {
        write_pose(o, &(d_bi - d_bj), &(ex_a_rot + ex_b_rot));
    }
    if let Some(o) = out.landmark.as_deref_mut() {
        // Columns: inverse depth, then the bearing correction (∂P_ca/∂c = depth · e_x, e_y).
        let j = d_ca * (-ray_i * (depth * depth));
        for r in 0..2 {
            o[r * LANDMARK_SIZE] = j[r];
            o[r * LANDMARK_SIZE + 1] = d_ca[(r, 0)] * depth;
            o[r * LANDMARK_SIZE + 2] = d_ca[(r, 1)] * depth;
        }
    }
    if let Some(o) = out.td.as_deref_mut() {
        let vel_i = Vector3::new(obs_i.velocity.x, obs_i.velocity.y, 0.0);
        let j = d_ca * (-vel_i * depth) + weight * obs_j.velocity;
        o[0] = j.x;
        o[1] = j.y;
    }
    true
}

/// The rotation of the identity pose (exactly what `rot` gives for it).
const IDENTITY: Matrix3<f64> = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);

#[inline]
fn rot(q: &UnitQuaternion<f64>) -> Matrix3<f64> {
    q.to_rotation_matrix().into_inner()
}

/// Borrows each requested Jacobian buffer separately (the buffers stay in the caller's list, so a
/// robust loss applied after `evaluate` still sees them).
#[inline]
fn split<'a, const N: usize>(
    jacobians: &'a mut Option<&mut [Option<&mut [f64]>]>,
) -> [Option<&'a mut [f64]>; N] {
    let mut out: [Option<&'a mut [f64]>; N] = [const { None }; N];
    if let Some(js) = jacobians.as_deref_mut() {
        for (o, j) in out.iter_mut().zip(js.iter_mut()) {
            *o = j.as_deref_mut();
        }
    }
    out
}

/// A feature anchored in frame `i` and observed in frame `j` by the same camera.
///
/// Parameter blocks: `pose_i` (7), `pose_j` (7), `T_b_c` (7), landmark `[λ, cx, cy]` (3), `td` (1).
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
        &[7, 7, 7, LANDMARK_SIZE, 1]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6, 6, LANDMARK_SIZE, 1]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        self.evaluate_with_rotations(params, &[None; 5], residuals, jacobians)
    }
    fn evaluate_with_rotations(
        &self,
        params: &[&[f64]],
        rotations: &[Option<&Matrix3<f64>>],
        residuals: &mut [f64],
        mut jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let ex = Pose::from_slice(params[2]);
        let [pose_i, pose_j, ex_shared, landmark, td] = split::<5>(&mut jacobians);
        let mut out = CoreOut {
            pose_i,
            pose_j,
            ex_shared,
            landmark,
            td,
            ..CoreOut::default()
        };
        reproject_core(
            &self.obs_i,
            &self.obs_j,
            self.weight,
            &Pose::from_slice(params[0]),
            &Pose::from_slice(params[1]),
            &ex,
            &ex,
            true,
            params[3],
            params[4][0],
            Rotations {
                pose_i: rotations[0],
                pose_j: rotations[1],
                ex_a: rotations[2],
                ex_b: rotations[2],
            },
            residuals,
            &mut out,
        )
    }
}

/// A feature anchored in camera `a` of frame `i` and observed by another camera `b` in frame `j`.
///
/// Parameter blocks: `pose_i` (7), `pose_j` (7), `T_b_ca` (7), `T_b_cb` (7), landmark (3),
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
        &[7, 7, 7, 7, LANDMARK_SIZE, 1]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6, 6, 6, LANDMARK_SIZE, 1]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        self.evaluate_with_rotations(params, &[None; 6], residuals, jacobians)
    }
    fn evaluate_with_rotations(
        &self,
        params: &[&[f64]],
        rotations: &[Option<&Matrix3<f64>>],
        residuals: &mut [f64],
        mut jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let [pose_i, pose_j, ex_a, ex_b, landmark, td] = split::<6>(&mut jacobians);
        let mut out = CoreOut {
            pose_i,
            pose_j,
            ex_a,
            ex_b,
            landmark,
            td,
            ..CoreOut::default()
        };
        reproject_core(
            &self.obs_i,
            &self.obs_j,
            self.weight,
            &Pose::from_slice(params[0]),
            &Pose::from_slice(params[1]),
            &Pose::from_slice(params[2]),
            &Pose::from_slice(params[3]),
            false,
            params[4],
            params[5][0],
            Rotations {
                pose_i: rotations[0],
                pose_j: rotations[1],
                ex_a: rotations[2],
                ex_b: rotations[3],
            },
            residuals,
            &mut out,
        )
    }
}

/// A feature anchored in camera `a` and observed by camera `b` in the same frame (stereo).
///
/// Parameter blocks: `T_b_ca` (7), `T_b_cb` (7), landmark (3), `td` (1). The body pose
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
        &[7, 7, LANDMARK_SIZE, 1]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[6, 6, LANDMARK_SIZE, 1]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        self.evaluate_with_rotations(params, &[None; 4], residuals, jacobians)
    }
    fn evaluate_with_rotations(
        &self,
        params: &[&[f64]],
        rotations: &[Option<&Matrix3<f64>>],
        residuals: &mut [f64],
        mut jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        let [ex_a, ex_b, landmark, td] = split::<4>(&mut jacobians);
        let mut out = CoreOut {
            ex_a,
            ex_b,
            landmark,
            td,
            ..CoreOut::default()
        };
        let id = Pose::identity();
        reproject_core(
            &self.obs_a,
            &self.obs_b,
            self.weight,
            &id,
            &id,
            &Pose::from_slice(params[0]),
            &Pose::from_slice(params[1]),
            false,
            params[2],
            params[3][0],
            Rotations {
                pose_i: Some(&IDENTITY),
                pose_j: Some(&IDENTITY),
                ex_a: rotations[0],
                ex_b: rotations[1],
            },
            residuals,
            &mut out,
        )
    }
}

/// Size (ambient and tangent) of a landmark block `[λ, cx, cy]`.
pub const LANDMARK_SIZE: usize = 3;

/// The anchor observation of a landmark `[λ, cx, cy]` as a residual: `r = weight · (cx, cy)`,
/// the correction of the anchor measurement's noise held to zero with that measurement's
/// square-root information (the reprojection factors read the anchor ray through it).
///
/// Parameter block: the landmark (3).
#[derive(Clone, Debug)]
pub struct AnchorBearing {
    /// Square-root information on the normalized plane (focal / pixel σ).
    pub weight: f64,
}

impl Factor for AnchorBearing {
    fn residual_dim(&self) -> usize {
        2
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &[LANDMARK_SIZE]
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &[LANDMARK_SIZE]
    }
    fn evaluate(
        &self,
        params: &[&[f64]],
        residuals: &mut [f64],
        jacobians: Option<&mut [Option<&mut [f64]>]>,
    ) -> bool {
        residuals[0] = self.weight * params[0][1];
        residuals[1] = self.weight * params[0][2];
        if let Some(js) = jacobians
            && let Some(j) = js[0].as_deref_mut()
        {
            j.copy_from_slice(&[0.0, self.weight, 0.0, 0.0, 0.0, self.weight]);
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::rotation_matrix;

    /// Precomputed rotation matrices give bit-identical residuals and Jacobians.
    #[test]
    fn evaluate_with_rotations_equals_evaluate() {
        let pose = |a: f64| {
            let p = Pose::new(
                UnitQuaternion::from_euler_angles(0.3 * a, -0.2 * a, 0.7 * a),
                Vector3::new(a, -0.5 * a, 0.2),
            );
            p.to_array().to_vec()
        };
        let obs = |x: f64, y: f64| FeatureMeasurement {
            point: Vector2::new(x, y),
            velocity: Vector2::new(0.1, -0.2),
            td: 0.001,
        };
        let (pi, pj, ea, eb) = (pose(0.1), pose(0.4), pose(0.01), pose(-0.02));
        let (obs_i, obs_j) = (obs(0.1, -0.05), obs(0.12, -0.03));
        type Case = (Box<dyn Factor>, Vec<Vec<f64>>);
        let factors: Vec<Case> = vec![
            (
                Box::new(ProjectionTwoFrameOneCam {
                    obs_i,
                    obs_j,
                    weight: 300.0,
                }),
                vec![
                    pi.clone(),
                    pj.clone(),
                    ea.clone(),
                    vec![0.4, 0.003, -0.002],
                    vec![0.002],
                ],
            ),
            (
                Box::new(ProjectionTwoFrameTwoCam {
                    obs_i,
                    obs_j,
                    weight: 300.0,
                }),
                vec![
                    pi,
                    pj,
                    ea.clone(),
                    eb.clone(),
                    vec![0.4, 0.003, -0.002],
                    vec![0.002],
                ],
            ),
            (
                Box::new(ProjectionOneFrameTwoCam {
                    obs_a: obs_i,
                    obs_b: obs_j,
                    weight: 300.0,
                }),
                vec![
                    ea.clone(),
                    eb.clone(),
                    vec![0.4, 0.003, -0.002],
                    vec![0.002],
                ],
            ),
            (
                Box::new(crate::factors::WorldPointProjection {
                    obs: obs_j,
                    weight: 300.0,
                    form: crate::factors::PointForm::World,
                }),
                vec![pose(0.1), ea, vec![0.4, 0.3, 2.5], vec![0.002]],
            ),
        ];
        for (f, params) in &factors {
            let views: Vec<&[f64]> = params.iter().map(|p| p.as_slice()).collect();
            let rots: Vec<Option<nalgebra::Matrix3<f64>>> = params
                .iter()
                .map(|p| (p.len() == 7).then(|| rotation_matrix(&p[3..7])))
                .collect();
            let rot_refs: Vec<Option<&nalgebra::Matrix3<f64>>> =
                rots.iter().map(|r| r.as_ref()).collect();
            let run = |with: bool| {
                let mut r = [0.0; 2];
                let mut store: Vec<Vec<f64>> = f
                    .parameter_tangent_sizes()
                    .iter()
                    .map(|t| vec![0.0; 2 * t])
                    .collect();
                let mut js: Vec<Option<&mut [f64]>> =
                    store.iter_mut().map(|j| Some(j.as_mut_slice())).collect();
                let ok = if with {
                    f.evaluate_with_rotations(&views, &rot_refs, &mut r, Some(&mut js))
                } else {
                    f.evaluate(&views, &mut r, Some(&mut js))
                };
                assert!(ok);
                let mut bits: Vec<u64> = r.iter().map(|v| v.to_bits()).collect();
                bits.extend(store.iter().flatten().map(|v| v.to_bits()));
                bits
            };
            assert_eq!(run(true), run(false));
        }
    }
}
