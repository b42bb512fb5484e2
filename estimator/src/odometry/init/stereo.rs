//! Stereo+IMU initialization from the visually solved window (metric scale from stereo).

use std::sync::Arc;

use nalgebra::Vector3;

use super::alignment::{align_velocities_and_gravity, estimate_gyro_bias};
use super::{repropagate, set_gravity_aligned, window_intervals};
use crate::geometry::Pose;
use crate::odometry::config::EstimatorConfig;
use crate::odometry::frame::{BlockRef, Prior, WindowFrame};
use crate::odometry::window::Window;
use crate::problem::{Euclidean, PoseManifold, PriorFactor};

/// Aligns the visually solved window with the IMU: the gyroscope bias from the visual rotations,
/// then velocities and gravity by linear alignment; the world is rotated so that gravity is −z
/// (minimal rotation, origin at the oldest frame) and the window gets the initial prior. Returns
/// `false` when an interval is missing or a step fails; the states are then untouched (the
/// intervals may have been re-linearized at the estimated gyroscope bias).
pub(in crate::odometry) fn initialize_stereo_inertial(
    window: &mut Window,
    config: &EstimatorConfig,
) -> bool {
    // The window's poses must be stereo vision's, not predictions: every frame needs as many
    // landmarks seen by both cameras as a tracked frame needs observations.
    let stereo_seen = |seq: u64| {
        window
            .features
            .tracks
            .values()
            .filter(|t| {
                t.obs
                    .iter()
                    .any(|o| o.seq == seq && o.meas.iter().all(Option::is_some))
            })
            .count()
    };
    if window
        .frames
        .iter()
        .any(|f| stereo_seen(f.seq) < config.min_tracking_observations)
    {
        return false;
    }
    let poses: Vec<Pose> = window.frames.iter().map(|f| f.pose).collect();
    let Some(intervals) = window_intervals(window) else {
        return false;
    };
    let Some(bg) = estimate_gyro_bias(&poses, &intervals) else {
        return false;
    };
    let ba = Vector3::zeros();
    repropagate(window, ba, bg);
    let Some(intervals) = window_intervals(window) else {
        return false;
    };
    let Some((vel, g)) = align_velocities_and_gravity(&poses, &intervals, &ba, &bg, crate::GRAVITY)
    else {
        return false;
    };
    if !set_gravity_aligned(window, &poses, &vel, &g, ba, bg) {
        return false;
    }
    // Landmarks are anchored in camera frames: unaffected. The prior starts as a bias prior
    // on the oldest frame (no earlier prior exists: vision-only frames carry none).
    window.prior = initial_prior(&window.frames[0], config);
    true
}

/// The initial prior on frame `first`: its position and yaw (the four directions no sensor
/// observes, pinned with `gauge_sigma` so that the solver never wanders along them) and its
/// biases (`initial_ba_sigma`, `initial_bg_sigma` around their current estimates).
/// Marginalization carries it forward.
pub(in crate::odometry) fn initial_prior(
    first: &WindowFrame,
    config: &EstimatorConfig,
) -> Option<Prior> {
    let sb0: Vec<f64> = first
        .v
        .iter()
        .chain(first.ba.iter())
        .chain(first.bg.iter())
        .copied()
        .collect();
    // Rows: position (3), yaw (1), ba (3), bg (3); columns: pose tangent (6), speed-bias (9).
    let (rows, cols) = (10, 15);
    let mut jac = vec![0.0; rows * cols];
    let w_gauge = 1.0 / config.gauge_sigma;
    for i in 0..3 {
        jac[i * cols + i] = w_gauge;
    }
    // Yaw of R·Exp(δθ) about world z: e_zᵀ R δθ.
    let r = first.pose.q.to_rotation_matrix().into_inner();
    for c in 0..3 {
        jac[3 * cols + 3 + c] = w_gauge * r[(2, c)];
    }
    for i in 0..3 {
        jac[(4 + i) * cols + 6 + 3 + i] = 1.0 / config.initial_ba_sigma;
        jac[(7 + i) * cols + 6 + 6 + i] = 1.0 / config.initial_bg_sigma;
    }
    let manifolds: Vec<Arc<dyn crate::problem::Manifold>> =
        vec![Arc::new(PoseManifold), Arc::new(Euclidean::new(9))];
    let points = vec![first.pose.to_array().to_vec(), sb0];
    PriorFactor::new(manifolds, points, jac, vec![0.0; rows])
        .ok()
        .map(|f| {
            (
                Arc::new(f),
                vec![BlockRef::Pose(first.seq), BlockRef::SpeedBias(first.seq)],
            )
        })
}
