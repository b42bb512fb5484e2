//! Mono+IMU initialization (VINS-Mono): structure from motion over the window on one camera,
//! then the gyroscope bias from the visual rotations and velocities, gravity and metric scale
//! from the preintegrated IMU deltas.

use nalgebra::{UnitQuaternion, Vector3};

use super::alignment::{UpToScaleTrajectory, WheelSpeeds, align_with_scale, estimate_gyro_bias};
use super::sfm::{SfmFailure, SfmSettings, solve_sfm};
use super::stereo::initial_prior;
use super::{offset, repropagate, set_gravity_aligned, window_intervals};
use crate::factors::FeatureMeasurement;
use crate::geometry::Pose;
use crate::imu::Preintegration;
use crate::odometry::config::EstimatorConfig;
use crate::odometry::window::Window;

/// Why a mono+IMU initialization attempt failed (the next frame tries again).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MonoInitFailure {
    /// A window frame has no IMU interval from its predecessor.
    MissingImu,
    /// The structure from motion failed.
    Sfm(SfmFailure),
    /// The visual rotations do not determine a gyroscope bias.
    GyroBias,
    /// Gravity came out more than 1 m/s² off its norm, or the scale not positive.
    Alignment,
    /// The window's accelerations do not determine the scale: its relative standard deviation
    /// exceeds `mono_init_max_scale_sigma` (too little or too uniform acceleration, which the
    /// accelerometer bias can absorb).
    ScaleUnobservable,
    /// The alignment's whitened residual exceeds `mono_init_max_chi2_per_dof` times its
    /// degrees of freedom: the IMU deltas and the visual trajectory contradict each other.
    Inconsistent,
}

/// Initializes the window from camera `cam` alone and the IMU. On success the frames carry
/// metric, gravity-aligned poses (world origin at the oldest frame, yaw as the SfM left it),
/// velocities and the gyroscope bias; every track's depth is cleared for re-triangulation and
/// the initial prior is set. On failure the states are untouched (the intervals may have been
/// re-linearized at the estimated gyroscope bias).
pub(in crate::odometry) fn initialize_mono_inertial(
    window: &mut Window,
    config: &EstimatorConfig,
    focal: &[f64],
    cam: usize,
) -> Result<(), MonoInitFailure> {
    if window_intervals(window).is_none() {
        return Err(MonoInitFailure::MissingImu);
    }
    // Each view with its weight (the camera model's magnification there over the pixel σ).
    type Views = Vec<(usize, FeatureMeasurement)>;
    let (tracks, weights): (Vec<Views>, Vec<Vec<f64>>) = window
        .features
        .tracks
        .values()
        .map(|t| {
            t.obs
                .iter()
                .filter_map(|o| Some(((window.frame_index(o.seq)?, o.meas[cam]?), o.weight[cam])))
                .unzip::<_, _, Vec<_>, Vec<_>>()
        })
        .filter(|(t, _)| t.len() >= 2)
        .unzip();
    let settings = SfmSettings {
        focal: focal[cam],
        pixel_sigma: config.cameras[cam].pixel_sigma,
        min_parallax_px: config.mono_init_parallax_px,
        td: window.td,
    };
    let sfm = solve_sfm(&tracks, Some(&weights), window.frames.len(), &settings)
        .map_err(MonoInitFailure::Sfm)?;
    let t_b_c = window.extrinsics[cam];
    // Body attitudes in the SfM world: R_w_b = R_w_c R_b_cᵀ.
    let body_q: Vec<UnitQuaternion<f64>> =
        sfm.poses.iter().map(|p| p.q * t_b_c.q.inverse()).collect();
    let attitudes: Vec<Pose> = body_q
        .iter()
        .map(|q| Pose::new(*q, Vector3::zeros()))
        .collect();
    let cam_positions: Vec<Vector3<f64>> = sfm.poses.iter().map(|p| p.p).collect();
    let rotations: Vec<_> = body_q
        .iter()
        .map(|q| q.to_rotation_matrix().into_inner())
        .collect();
    if config.estimate_td && config.init_td_search_s > 0.0 {
        // The offset the interior frames' intervals align best at (see `offset.rs`).
        let last = window.frames.len() - 1;
        let m = last - 1;
        let cov = sfm
            .position_covariance
            .view((3, 3), (3 * m, 3 * m))
            .into_owned();
        let shift = offset::best_shift(window, config.init_td_search_s, |intervals| {
            let refs: Vec<&Preintegration> = intervals.iter().collect();
            let bg = estimate_gyro_bias(&attitudes[1..last], &refs)?;
            for p in intervals.iter_mut() {
                p.repropagate(Vector3::zeros(), bg);
            }
            let refs: Vec<&Preintegration> = intervals.iter().collect();
            let visual = UpToScaleTrajectory {
                cam_positions: &cam_positions[1..last],
                cam_covariance: &cov,
                body_rotations: &rotations[1..last],
                t_b_c: &t_b_c.p,
            };
            align_with_scale(
                &visual,
                &refs,
                &bg,
                config.initial_ba_sigma,
                crate::GRAVITY,
                None,
            )
            .map(|a| (a.chi2_per_dof, a.dof))
        });
        if !offset::apply_shift(window, shift) {
            return Err(MonoInitFailure::MissingImu);
        }
    }
    let intervals = window_intervals(window).ok_or(MonoInitFailure::MissingImu)?;
    let bg = estimate_gyro_bias(&attitudes, &intervals).ok_or(MonoInitFailure::GyroBias)?;
    repropagate(window, Vector3::zeros(), bg);
    let visual = UpToScaleTrajectory {
        cam_positions: &cam_positions,
        cam_covariance: &sfm.position_covariance,
        body_rotations: &rotations,
        t_b_c: &t_b_c.p,
    };
    // Wheel odometry, where it covers the window's frames, measures the metric velocity.
    let speeds: Vec<Option<f64>> = window
        .frames
        .iter()
        .map(|f| window.aiding.wheel_speed(f.t_ns, config.wheel.max_gap_s))
        .collect();
    let wheel = WheelSpeeds {
        speeds: &speeds,
        speed_sigma: config.wheel.speed_sigma_m_s,
        lateral_sigma: config.wheel.lateral_sigma_m_s,
    };
    let aligned = align_with_scale(
        &visual,
        &window_intervals(window).ok_or(MonoInitFailure::MissingImu)?,
        &bg,
        config.initial_ba_sigma,
        crate::GRAVITY,
        speeds.iter().any(Option::is_some).then_some(&wheel),
    )
    .ok_or(MonoInitFailure::Alignment)?;
    if aligned.scale_rel_sigma > config.mono_init_max_scale_sigma {
        return Err(MonoInitFailure::ScaleUnobservable);
    }
    if aligned.chi2_per_dof.is_nan() || aligned.chi2_per_dof > config.mono_init_max_chi2_per_dof {
        return Err(MonoInitFailure::Inconsistent);
    }
    let (vel, g, s, ba) = (
        &aligned.velocities,
        &aligned.gravity,
        aligned.scale,
        aligned.ba,
    );
    repropagate(window, ba, bg);
    // Metric body poses: p_b = s c̄ − R_w_b t_b_c.
    let body: Vec<Pose> = cam_positions
        .iter()
        .zip(&rotations)
        .zip(&body_q)
        .map(|((c, r), q)| Pose::new(*q, c * s - r * t_b_c.p))
        .collect();
    if !set_gravity_aligned(window, &body, vel, g, ba, bg) {
        return Err(MonoInitFailure::Alignment);
    }
    for t in window.features.tracks.values_mut() {
        t.set_inv_depth(None);
    }
    window.prior = initial_prior(&window.frames[0], config);
    Ok(())
}
