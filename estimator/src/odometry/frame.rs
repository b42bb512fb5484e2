//! A frame's state in the window, the window's parameter blocks by name, and the marginalization
//! prior's shape: the ground floor that the window, its problem and every part that adds
//! factors share.

use std::sync::Arc;

use nalgebra::Vector3;

use crate::geometry::Pose;
use crate::imu::Preintegration;
use crate::problem::PriorFactor;

/// A frame's state in the window.
#[derive(Clone, Debug)]
pub(super) struct WindowFrame {
    pub seq: u64,
    pub t_ns: i64,
    pub pose: Pose,
    pub v: Vector3<f64>,
    pub ba: Vector3<f64>,
    pub bg: Vector3<f64>,
    /// IMU interval from the previous window frame to this one.
    pub preint: Option<Preintegration>,
}

/// A parameter block of the window, independent of any one `Problem`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum BlockRef {
    Pose(u64),
    SpeedBias(u64),
    Extrinsic(usize),
    Td,
    /// A persistent world point (`Window::points` key).
    Point(u64),
    /// The GNSS alignment `T_g_w` (see [`super::aiding`]).
    GnssAlignment,
    /// The biases' constant mean (see [`super::bias_mean`]).
    BiasMean,
}

/// The marginalization prior and the window states it constrains, in its block order.
pub(super) type Prior = (Arc<PriorFactor>, Vec<BlockRef>);
