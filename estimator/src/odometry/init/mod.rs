//! Initialization: the first gravity-aligned attitude, stereo+IMU and mono+IMU
//! visual-inertial alignment, and the initial prior that pins the unobservable directions.

mod alignment;
pub(crate) mod five_point;
mod mono;
mod offset;
pub(crate) mod sfm;
mod stereo;

pub(super) use alignment::gravity_aligned_rotation;
pub(super) use mono::initialize_mono_inertial;
pub(super) use stereo::{initial_prior, initialize_stereo_inertial};

use nalgebra::{UnitQuaternion, Vector3};

use crate::geometry::Pose;
use crate::imu::Preintegration;
use crate::odometry::window::Window;

/// The IMU intervals between consecutive window frames (each frame's from its predecessor);
/// `None` when a frame has none (an IMU gap inside the window) or one integrated a clipped
/// reading: the alignments weigh every interval alike, so a biased one would bend gravity and
/// the gyroscope bias (4.7° of tilt at the start of a fast rotation when they did).
fn window_intervals(window: &Window) -> Option<Vec<&Preintegration>> {
    window
        .frames
        .iter()
        .skip(1)
        .map(|f| f.preint.as_ref().filter(|p| !p.clipped()))
        .collect()
}

/// Re-linearizes every interval of the window at the biases `(ba, bg)`.
fn repropagate(window: &mut Window, ba: Vector3<f64>, bg: Vector3<f64>) {
    for f in window.frames.iter_mut().skip(1) {
        if let Some(p) = &mut f.preint {
            p.repropagate(ba, bg);
        }
    }
}

/// Writes the aligned states into the window: `poses`, `velocities` and `gravity` are in the
/// alignment's world; it is rotated so that gravity points along −z (minimal rotation) with
/// the origin at the oldest frame, and every frame gets the biases. `false` (window untouched)
/// when gravity has no direction.
fn set_gravity_aligned(
    window: &mut Window,
    poses: &[Pose],
    velocities: &[Vector3<f64>],
    gravity: &Vector3<f64>,
    ba: Vector3<f64>,
    bg: Vector3<f64>,
) -> bool {
    let Some(r_align) = UnitQuaternion::rotation_between(gravity, &crate::gravity_w()) else {
        return false;
    };
    let origin = poses[0].p;
    for ((f, pose), v) in window.frames.iter_mut().zip(poses).zip(velocities) {
        f.pose = Pose::new(r_align * pose.q, r_align * (pose.p - origin));
        f.v = r_align * v;
        f.ba = ba;
        f.bg = bg;
    }
    true
}
