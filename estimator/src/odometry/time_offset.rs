//! The image velocities the time-offset model shifts measurements along
//! ([`crate::factors::FeatureMeasurement::point_at_td`]), predicted from the window's motion.
//!
//! A measurement stamped with `td_meas` belongs to the window frame at IMU time
//! `t_cam + td_meas`; when `td` moves, the residual compares the landmark with the point shifted
//! by `(td − td_meas)` along its image velocity. Finite differences of the track's pixels make a
//! poor velocity: the previous displacement lags by a frame and a half (it biased `td` by about
//! 2 ms per second of a free run), and any difference carries the pixel noise, which is
//! independent of the poses. That noise breaks the near-degeneracy between a time shift and a
//! pose shift that only the IMU resolves, so the window and its prior take the noise for `td`
//! information and pin `td` where it started (the prior claimed σ ≈ 0.5 ms while the window alone
//! knew it to several ms).
//!
//! Here the velocity is what the window's own state predicts for the landmark: the camera moves
//! with the frame's velocity and the bias-corrected gyro rate measured at the frame's time. A
//! time shift is then exactly (to first order) the pose shift it stands for, and `td` is
//! estimated from what the IMU says about that shift, as in filters that propagate the clone to
//! `t + td` (Li & Mourikis 2014).

use nalgebra::{Matrix3, Vector2, Vector3};

use super::window::Window;
use crate::geometry::Pose;

/// A body's state at one window frame, in the form the image velocity needs: `R_b_w`,
/// `p_w_b`, and its body-frame velocity and angular rate.
struct BodyMotion {
    r_bw: Matrix3<f64>,
    p_wb: Vector3<f64>,
    v_b: Vector3<f64>,
    w_b: Vector3<f64>,
}

/// A camera on the body: `R_c_b` and `p_b_c`.
struct CameraMount {
    r_cb: Matrix3<f64>,
    p_bc: Vector3<f64>,
}

impl CameraMount {
    #[allow(non_snake_case)]
    fn new(T_b_c: &Pose) -> Self {
        Self {
            r_cb: T_b_c.q.inverse().to_rotation_matrix().into_inner(),
            p_bc: T_b_c.p,
        }
    }
}

impl BodyMotion {
    #[allow(non_snake_case)]
    fn new(T_w_b: &Pose, v_b: Vector3<f64>, w_b: Vector3<f64>) -> Self {
        Self {
            r_bw: T_w_b.q.inverse().to_rotation_matrix().into_inner(),
            p_wb: T_w_b.p,
            v_b,
            w_b,
        }
    }

    /// The velocity (1/s) of world point `x_w` on the normalized image plane of `camera`;
    /// `None` when the point is not in front of it.
    fn image_velocity(&self, camera: &CameraMount, x_w: &Vector3<f64>) -> Option<Vector2<f64>> {
        let p_b = self.r_bw * (x_w - self.p_wb);
        // The point moves in the body frame as ṗ_b = −ω × p_b − v_b.
        let dp_b = -self.w_b.cross(&p_b) - self.v_b;
        let p_c = camera.r_cb * (p_b - camera.p_bc);
        let dp_c = camera.r_cb * dp_b;
        (p_c.z > 1e-3).then(|| {
            Vector2::new(
                (dp_c.x - p_c.x / p_c.z * dp_c.z) / p_c.z,
                (dp_c.y - p_c.y / p_c.z * dp_c.z) / p_c.z,
            )
        })
    }
}

impl Window {
    /// The body angular rate at window frame `idx` (bias-corrected, body frame): the IMU
    /// sample at the end of the frame's interval, or at the start of the next frame's.
    fn angular_rate(&self, idx: usize) -> Option<Vector3<f64>> {
        let frame = &self.frames[idx];
        let at_end = frame
            .preint
            .as_ref()
            .and_then(|p| p.samples().last())
            .filter(|s| s.t_ns == frame.t_ns);
        let at_start = || {
            self.frames
                .get(idx + 1)?
                .preint
                .as_ref()?
                .samples()
                .first()
                .filter(|s| s.t_ns == frame.t_ns)
        };
        at_end
            .or_else(at_start)
            .map(|s| s.gyro - frame.bg)
            .filter(|w| w.iter().all(|x| x.is_finite()))
    }

    /// Replaces the image velocity of every measurement of a triangulated track with the one
    /// the window's state predicts (see the module documentation). Measurements of tracks
    /// without a depth, or of frames without an IMU sample at their time, keep theirs.
    pub fn predict_image_velocities(&mut self) {
        // The motion of each window frame (by sequence number), rotations as matrices: each
        // is used for every measurement of that frame.
        let motion: Vec<(u64, Option<BodyMotion>)> = (0..self.frames.len())
            .map(|i| {
                let f = &self.frames[i];
                let v_b = f.pose.q.inverse() * f.v;
                let body = self
                    .angular_rate(i)
                    .map(|w| BodyMotion::new(&f.pose, v_b, w));
                (f.seq, body)
            })
            .collect();
        let cameras: Vec<CameraMount> = self.extrinsics.iter().map(CameraMount::new).collect();
        let points: Vec<(u64, Vector3<f64>)> = self
            .features
            .tracks
            .keys()
            .filter_map(|&id| Some((id, self.track_world_point(id)?)))
            .collect();
        for (id, x_w) in points {
            let track = self.features.tracks.get_mut(&id).expect("listed");
            for o in &mut track.obs {
                let Some(Some(body)) = motion.iter().find(|(seq, _)| *seq == o.seq).map(|m| &m.1)
                else {
                    continue;
                };
                for (m, camera) in o.meas.iter_mut().zip(&cameras) {
                    let Some(m) = m.as_mut() else {
                        continue;
                    };
                    if let Some(velocity) = body.image_velocity(camera, &x_w) {
                        m.velocity = velocity;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::so3_exp;
    use nalgebra::UnitQuaternion;

    /// The predicted velocity is the derivative of the projection along the motion it is
    /// predicted from: body at `(R·Exp(ω t), p + R·v_b t)`, central differences over ±1 µs.
    #[test]
    #[allow(non_snake_case)]
    fn image_velocity_is_the_derivative_of_the_projection() {
        let T_w_b = Pose::new(
            UnitQuaternion::from_euler_angles(0.2, -0.3, 1.1),
            Vector3::new(0.5, -1.0, 1.5),
        );
        let T_b_c = Pose::new(
            UnitQuaternion::from_euler_angles(-1.5, 0.05, -1.6),
            Vector3::new(0.02, 0.055, -0.01),
        );
        let (v_b, w_b) = (Vector3::new(0.8, -0.3, 0.2), Vector3::new(0.4, -0.9, 0.6));
        let project = |t: f64, x_w: &Vector3<f64>| {
            let body = Pose::new(T_w_b.q * so3_exp(&(w_b * t)), T_w_b.p + T_w_b.q * v_b * t);
            let p_c = body.compose(&T_b_c).inverse().transform(x_w);
            Vector2::new(p_c.x / p_c.z, p_c.y / p_c.z)
        };
        let camera = T_w_b.compose(&T_b_c);
        for p_c in [
            Vector3::new(0.3, -0.2, 2.0),
            Vector3::new(-1.0, 0.5, 0.8),
            Vector3::new(0.0, 0.0, 6.0),
        ] {
            let x_w = camera.transform(&p_c);
            let body = BodyMotion::new(&T_w_b, v_b, w_b);
            let predicted = body
                .image_velocity(&CameraMount::new(&T_b_c), &x_w)
                .unwrap();
            let h = 1e-6;
            let numeric = (project(h, &x_w) - project(-h, &x_w)) / (2.0 * h);
            assert!(
                (predicted - numeric).norm() < 1e-6 * numeric.norm().max(1.0),
                "{predicted} vs {numeric}"
            );
        }
        // Behind the camera: no velocity.
        let behind = camera.transform(&Vector3::new(0.0, 0.0, -1.0));
        let body = BodyMotion::new(&T_w_b, v_b, w_b);
        assert!(
            body.image_velocity(&CameraMount::new(&T_b_c), &behind)
                .is_none()
        );
    }
}
