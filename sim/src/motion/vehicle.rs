//! A ground vehicle's reference motion: a horizontal figure-eight at constant height, the
//! body's x axis along the velocity (a car-like vehicle neither slides sideways nor rolls or
//! pitches on a flat floor). Planar motion at near-constant speed is where visual-inertial
//! odometry loses observability (the accelerometer bias along gravity, scale for a single
//! camera), and where wheel odometry helps.

use nalgebra::{UnitQuaternion, Vector3};

use super::reference::{RefState, Reference, attitude_derivatives};

/// A horizontal figure-eight `x = cx + a·sin(ωt)`, `y = cy + b·sin(2ωt)` at height `cz`, the
/// heading along the velocity (it never vanishes on this curve: `ẋ` and `ẏ` are never zero
/// together).
#[derive(Clone, Debug, PartialEq)]
pub struct GroundVehicle {
    /// Centre of the figure-eight; `z` is the body's height (m).
    pub center: Vector3<f64>,
    /// Half extent along x (m).
    pub half_width_m: f64,
    /// Half extent along y (m).
    pub half_height_m: f64,
    /// One loop (s).
    pub period_s: f64,
}

impl GroundVehicle {
    /// Position, velocity and acceleration at `t`.
    fn translation(&self, t: f64) -> [Vector3<f64>; 3] {
        let w = std::f64::consts::TAU / self.period_s;
        let (a, b) = (self.half_width_m, self.half_height_m);
        let (s1, c1) = (w * t).sin_cos();
        let (s2, c2) = (2.0 * w * t).sin_cos();
        [
            self.center + Vector3::new(a * s1, b * s2, 0.0),
            Vector3::new(a * w * c1, 2.0 * b * w * c2, 0.0),
            Vector3::new(-a * w * w * s1, -4.0 * b * w * w * s2, 0.0),
        ]
    }

    fn attitude(&self, t: f64) -> UnitQuaternion<f64> {
        let v = self.translation(t)[1];
        UnitQuaternion::from_axis_angle(&Vector3::z_axis(), v.y.atan2(v.x))
    }
}

impl Reference for GroundVehicle {
    fn state(&self, t: f64) -> RefState {
        let [p, v, a] = self.translation(t);
        let (omega_w, alpha_w) = attitude_derivatives(|s| self.attitude(s), t);
        RefState {
            p,
            v,
            a,
            q: self.attitude(t),
            omega_w,
            alpha_w,
        }
    }

    fn duration(&self) -> Option<f64> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_body_faces_along_its_velocity_and_stays_level() {
        let g = GroundVehicle {
            center: Vector3::new(3.0, 4.0, -1.7),
            half_width_m: 9.0,
            half_height_m: 6.0,
            period_s: 60.0,
        };
        for k in 0..600 {
            let s = g.state(k as f64 * 0.1);
            let forward = s.q * Vector3::x();
            let lateral = (s.q.inverse() * s.v).y;
            assert!(lateral.abs() < 1e-9 * s.v.norm().max(1.0), "t {k}");
            assert!(forward.z.abs() < 1e-12 && s.v.norm() > 0.5, "t {k}");
            assert!((s.p.z + 1.7).abs() < 1e-12);
            // The yaw rate follows the curvature: ψ' = (vx·ay − vy·ax)/|v|².
            let psi_dot = (s.v.x * s.a.y - s.v.y * s.a.x) / s.v.norm_squared();
            assert!((s.omega_w.z - psi_dot).abs() < 1e-5, "t {k}");
        }
    }
}
