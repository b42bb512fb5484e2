//! A persistent point of the window: its coordinates and what they mean ([`PointForm`]).

use nalgebra::Vector3;

use super::config::PointCoordinates;
use crate::factors::PointForm;
use crate::geometry::Pose;

/// A state of the window that outlives the keyframe its track was anchored in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PersistentPoint {
    /// What `coords` are.
    pub form: PointForm,
    /// The point block's values.
    pub coords: Vector3<f64>,
}

impl PersistentPoint {
    /// The point at world position `x_w`, in `coordinates`; inverse-distance points are
    /// anchored at camera pose `anchor` (world point coordinates when the point is not in
    /// front of it).
    pub fn new(coordinates: PointCoordinates, x_w: Vector3<f64>, anchor: &Pose) -> Self {
        let world = PersistentPoint {
            form: PointForm::World,
            coords: x_w,
        };
        match coordinates {
            PointCoordinates::World => world,
            PointCoordinates::InverseDistance => {
                let frame = anchor.q.to_rotation_matrix().into_inner();
                PointForm::anchored(anchor.p, frame, &x_w)
                    .map_or(world, |(form, coords)| PersistentPoint { form, coords })
            }
        }
    }

    /// The world position.
    pub fn world(&self) -> Vector3<f64> {
        self.form.world(&self.coords)
    }
}
