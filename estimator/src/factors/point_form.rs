//! How a persistent point's three coordinates place it in the world: as the world point itself,
//! or as inverse distance about a fixed anchor (Civera, Davison and Montiel's inverse-depth
//! point, with an anchor that is a constant rather than a state).
//!
//! A far point seen over a short baseline is known well in bearing and poorly in distance; in
//! world coordinates that uncertainty is a long, curved region that one Gaussian fits badly,
//! and a marginalization prior holds the Gaussian for as long as the point lives. In
//! `(α, β, ρ)` — the normalized image coordinates and the inverse distance in a frozen camera
//! frame — the projection into any camera is nearly linear over the same region, and a point
//! at infinity is the finite `ρ = 0`.

use nalgebra::{Matrix3, RowVector3, Vector3};

/// The meaning of a persistent point's coordinates `c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointForm {
    /// `c` is the world point `X_w`.
    World,
    /// `X_w = anchor + R_w_a (α, β, 1)ᵀ / ρ` with `c = (α, β, ρ)`: normalized coordinates and
    /// inverse distance along the anchor frame's z axis. `anchor` and `R_w_a` are constants
    /// fixed when the point is made (a camera's position and orientation at the time).
    InverseDistance {
        /// The anchor's world position.
        anchor: Vector3<f64>,
        /// The anchor frame's orientation `R_w_a`.
        frame: Matrix3<f64>,
    },
}

/// The ray from a position `p` to a point, scaled by a positive `s`: `h = s (X_w − p)`, with
/// its derivatives in the point's coordinates. Projections only need the direction, so `s`
/// can be chosen to keep `h` finite for a point at infinity.
#[derive(Clone, Copy, Debug)]
pub struct ScaledRay {
    /// `h = s (X_w − p)`.
    pub h: Vector3<f64>,
    /// `∂h/∂c`.
    pub dh: Matrix3<f64>,
    /// The scale `s` (1 for [`PointForm::World`], `ρ` for the inverse distance).
    pub scale: f64,
    /// `∂s/∂c`.
    pub dscale: RowVector3<f64>,
}

impl PointForm {
    /// The inverse-distance form anchored at a camera with pose `(anchor, frame)` and the
    /// coordinates of world point `x_w` in it; `None` when the point is not in front of it.
    pub fn anchored(
        anchor: Vector3<f64>,
        frame: Matrix3<f64>,
        x_w: &Vector3<f64>,
    ) -> Option<(PointForm, Vector3<f64>)> {
        let form = PointForm::InverseDistance { anchor, frame };
        let m = frame.transpose() * (x_w - anchor);
        (m.z > 0.0 && m.z.is_finite())
            .then(|| (form, Vector3::new(m.x / m.z, m.y / m.z, 1.0 / m.z)))
    }

    /// The world point of coordinates `c`.
    pub fn world(&self, c: &Vector3<f64>) -> Vector3<f64> {
        match self {
            PointForm::World => *c,
            PointForm::InverseDistance { anchor, frame } => {
                anchor + frame * Vector3::new(c.x, c.y, 1.0) / c.z
            }
        }
    }

    /// The change of coordinates `c` that moves the point by the small world displacement
    /// `dx`, to first order: `(∂X_w/∂c)⁻¹ dx`.
    pub fn coordinates_step(&self, c: &Vector3<f64>, dx: &Vector3<f64>) -> Vector3<f64> {
        match self {
            PointForm::World => *dx,
            PointForm::InverseDistance { frame, .. } => {
                // ∂X/∂(α, β, ρ) = R_w_a [e_x/ρ, e_y/ρ, −(α, β, 1)ᵀ/ρ²].
                let w = frame.transpose() * dx;
                let (alpha, beta, rho) = (c.x, c.y, c.z);
                Vector3::new(
                    rho * (w.x - alpha * w.z),
                    rho * (w.y - beta * w.z),
                    -rho * rho * w.z,
                )
            }
        }
    }

    /// The ray from `p` to the point of coordinates `c`, scaled ([`ScaledRay`]).
    pub fn ray_from(&self, c: &Vector3<f64>, p: &Vector3<f64>) -> ScaledRay {
        match self {
            PointForm::World => ScaledRay {
                h: c - p,
                dh: Matrix3::identity(),
                scale: 1.0,
                dscale: RowVector3::zeros(),
            },
            PointForm::InverseDistance { anchor, frame } => {
                // h = ρ (X_w − p) = R_w_a (α, β, 1)ᵀ + ρ (anchor − p).
                let to_anchor = anchor - p;
                let mut dh = Matrix3::zeros();
                dh.set_column(0, &frame.column(0));
                dh.set_column(1, &frame.column(1));
                dh.set_column(2, &to_anchor);
                ScaledRay {
                    h: frame * Vector3::new(c.x, c.y, 1.0) + to_anchor * c.z,
                    dh,
                    scale: c.z,
                    dscale: RowVector3::new(0.0, 0.0, 1.0),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn anchored_example() -> (PointForm, Vector3<f64>, Vector3<f64>) {
        let frame = UnitQuaternion::from_euler_angles(0.3, -0.2, 1.1)
            .to_rotation_matrix()
            .into_inner();
        let anchor = Vector3::new(1.0, -2.0, 0.5);
        let x_w = anchor + frame * Vector3::new(0.4, -0.1, 7.0);
        let (form, c) = PointForm::anchored(anchor, frame, &x_w).expect("in front");
        (form, c, x_w)
    }

    #[test]
    fn anchored_coordinates_give_back_the_world_point() {
        let (form, c, x_w) = anchored_example();
        assert!((c - Vector3::new(0.4 / 7.0, -0.1 / 7.0, 1.0 / 7.0)).norm() < 1e-15);
        assert!((form.world(&c) - x_w).norm() < 1e-12);
        // Behind the anchor: no coordinates.
        let (anchor, frame) = match form {
            PointForm::InverseDistance { anchor, frame } => (anchor, frame),
            PointForm::World => unreachable!(),
        };
        assert!(PointForm::anchored(anchor, frame, &(2.0 * anchor - x_w)).is_none());
    }

    #[test]
    fn coordinates_step_moves_the_world_point_by_the_displacement() {
        let (form, c, x_w) = anchored_example();
        let dx = Vector3::new(0.3, -0.7, 0.2) * 1e-6;
        let moved = form.world(&(c + form.coordinates_step(&c, &dx)));
        assert!(
            (moved - x_w - dx).norm() < 1e-10,
            "{}",
            (moved - x_w - dx).norm()
        );
        assert_eq!(PointForm::World.coordinates_step(&c, &dx), dx);
    }

    #[test]
    fn scaled_ray_and_its_derivatives_match_finite_differences() {
        let (form, c, x_w) = anchored_example();
        let p = Vector3::new(0.2, 0.1, -0.3);
        let ray = form.ray_from(&c, &p);
        assert!((ray.h - ray.scale * (x_w - p)).norm() < 1e-12);
        let eps = 1e-7;
        for k in 0..3 {
            let mut up = c;
            up[k] += eps;
            let mut down = c;
            down[k] -= eps;
            let (a, b) = (form.ray_from(&up, &p), form.ray_from(&down, &p));
            let dh = (a.h - b.h) / (2.0 * eps);
            assert!((dh - ray.dh.column(k)).norm() < 1e-6, "column {k}");
            let ds = (a.scale - b.scale) / (2.0 * eps);
            assert!((ds - ray.dscale[k]).abs() < 1e-9);
        }
        let world = PointForm::World.ray_from(&x_w, &p);
        assert_eq!(world.h, x_w - p);
        assert_eq!(world.scale, 1.0);
    }
}
