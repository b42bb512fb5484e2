//! The range checks of an [`EstimatorConfig`]: every setting, and the rig against the suite;
//! each error names its field.

use super::error::{ConfigError, count_in, non_negative, positive, positive_or_infinite, value_in};
use super::estimator_config::{EstimatorConfig, MAX_PERSISTENT_POINTS, MAX_WINDOW_SIZE};

impl EstimatorConfig {
    /// Checks the rig and every setting ([`EstimatorConfig::validate_settings`]); the error
    /// names the field. The estimator refuses a configuration that fails (no setting may
    /// panic later).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.cameras.is_empty() || self.cameras.len() > 2 {
            return Err(ConfigError::new(
                "cameras",
                format!("need 1 or 2, got {}", self.cameras.len()),
            ));
        }
        if self.cameras.len() != self.suite.cameras() {
            return Err(ConfigError::new(
                "cameras",
                format!(
                    "the {:?} suite needs exactly {} camera(s), got {}",
                    self.suite,
                    self.suite.cameras(),
                    self.cameras.len()
                ),
            ));
        }
        for (i, c) in self.cameras.iter().enumerate() {
            positive(&format!("cameras[{i}].pixel_sigma"), c.pixel_sigma)?;
            non_negative(
                &format!("cameras[{i}].rolling_shutter.readout_s"),
                c.rolling_shutter.readout_s,
            )?;
            let t = &c.T_b_c;
            if !(t.p.iter().all(|v| v.is_finite()) && t.q.coords.iter().all(|v| v.is_finite())) {
                return Err(ConfigError::new(
                    format!("cameras[{i}].T_b_c"),
                    "must be finite",
                ));
            }
        }
        let n = &self.imu_noise;
        positive(
            "imu_noise.gyroscope_noise_density",
            n.gyroscope_noise_density,
        )?;
        positive(
            "imu_noise.accelerometer_noise_density",
            n.accelerometer_noise_density,
        )?;
        positive("imu_noise.gyroscope_random_walk", n.gyroscope_random_walk)?;
        positive(
            "imu_noise.accelerometer_random_walk",
            n.accelerometer_random_walk,
        )?;
        if self.suite.uses_imu() && self.init_frames < 4 {
            return Err(ConfigError::new(
                "init_frames",
                format!("must be ≥ 4 with an IMU, got {}", self.init_frames),
            ));
        }
        self.validate_settings()
    }

    /// Checks every setting (not the rig) for finiteness and its range, including bounds on
    /// the resources a setting commits (the dense window system grows with the cube of its
    /// size); the error names the field as it is serialized (`solver.max_iterations`).
    pub fn validate_settings(&self) -> Result<(), ConfigError> {
        count_in(
            "window_size",
            self.window_size,
            3,
            MAX_WINDOW_SIZE,
            " keyframes",
        )?;
        count_in(
            "startup_window_size",
            self.startup_window_size,
            3,
            MAX_WINDOW_SIZE,
            " keyframes",
        )?;
        non_negative("startup_window_s", self.startup_window_s)?;
        if let Some(p) = self.pixel_sigma_px {
            positive("pixel_sigma_px", p)?;
        }
        for (key, v) in self.imu_noise_model.entries() {
            if let Some(v) = v {
                positive(&format!("imu_noise.{key}"), v)?;
            }
        }
        if !matches!(self.imu_noise_model.bias_process_keys_set(), 0 | 3) {
            return Err(ConfigError::new(
                "imu_noise.bias_correlation_time_s",
                "the bias instability takes three keys together: gyroscope_bias_instability, accelerometer_bias_instability and bias_correlation_time_s",
            ));
        }
        count_in(
            "init_frames",
            self.init_frames,
            4,
            MAX_WINDOW_SIZE,
            " frames",
        )?;
        // The initialization waits for `init_frames` frames in the window: a smaller window
        // never holds them, and nothing would ever be tracked.
        if self.window_size < self.init_frames {
            return Err(ConfigError::new(
                "window_size",
                format!(
                    "{} keyframes cannot hold the {} frames the initialization needs \
                     (init_frames); set window_size ≥ init_frames",
                    self.window_size, self.init_frames
                ),
            ));
        }
        count_in(
            "solver.max_iterations",
            self.solver.max_iterations,
            1,
            1000,
            "",
        )?;
        if !(0.0..=1.0).contains(&self.solver.function_tolerance) {
            return Err(ConfigError::new(
                "solver.function_tolerance",
                format!(
                    "expected a relative cost decrease in [0, 1], got {}",
                    self.solver.function_tolerance
                ),
            ));
        }
        non_negative("solver.gradient_tolerance", self.solver.gradient_tolerance)?;
        non_negative(
            "solver.parameter_tolerance",
            self.solver.parameter_tolerance,
        )?;
        positive(
            "solver.initial_trust_radius",
            self.solver.initial_trust_radius,
        )?;
        non_negative("solver.min_diagonal", self.solver.min_diagonal)?;
        positive("keyframe_parallax_px", self.keyframe_parallax_px)?;
        if !(self.relative_pose_interval_s > 0.0 && self.relative_pose_interval_s <= 60.0) {
            return Err(ConfigError::new(
                "relative_pose_interval_s",
                format!(
                    "expected an interval in (0, 60] s, got {}",
                    self.relative_pose_interval_s
                ),
            ));
        }
        positive("huber_sigma", self.huber_sigma)?;
        positive(
            "outlier_reprojection_sigma",
            self.outlier_reprojection_sigma,
        )?;
        positive("min_depth_m", self.min_depth_m)?;
        positive("max_depth_m", self.max_depth_m)?;
        if self.min_depth_m >= self.max_depth_m {
            return Err(ConfigError::new(
                "min_depth_m",
                format!(
                    "must be below max_depth_m ({}), got {}",
                    self.max_depth_m, self.min_depth_m
                ),
            ));
        }
        // A time offset is a small clock difference: a second is already far past any rig.
        if !(self.td_s.is_finite() && self.td_s.abs() <= 1.0) {
            return Err(ConfigError::new(
                "td_s",
                format!("expected a clock offset within ±1 s, got {}", self.td_s),
            ));
        }
        non_negative("stereo_init_window_s", self.stereo_init_window_s)?;
        value_in("init_td_search_s", self.init_td_search_s, 0.0, 1.0, " s")?;
        positive("mono_init_parallax_px", self.mono_init_parallax_px)?;
        positive("mono_init_window_s", self.mono_init_window_s)?;
        positive("mono_init_max_scale_sigma", self.mono_init_max_scale_sigma)?;
        positive_or_infinite(
            "mono_init_max_chi2_per_dof",
            self.mono_init_max_chi2_per_dof,
            "no consistency gate",
        )?;
        non_negative("repropagate_ba", self.repropagate_ba)?;
        non_negative("repropagate_bg", self.repropagate_bg)?;
        positive("initial_ba_sigma", self.initial_ba_sigma)?;
        positive("initial_bg_sigma", self.initial_bg_sigma)?;
        // Infinite: no gauge prior (the gauge tests study the free window).
        positive_or_infinite("gauge_sigma", self.gauge_sigma, "no gauge prior")?;
        positive_or_infinite(
            "point_relinearize_fraction",
            self.point_relinearize_fraction,
            "never",
        )?;
        positive_or_infinite(
            "frame_relinearize_fraction",
            self.frame_relinearize_fraction,
            "never",
        )?;
        if self.min_track_frames < 1 {
            return Err(ConfigError::new("min_track_frames", "must be ≥ 1"));
        }
        if self.max_persistent_points > MAX_PERSISTENT_POINTS {
            return Err(ConfigError::new(
                "max_persistent_points",
                format!(
                    "expected at most {MAX_PERSISTENT_POINTS} points in the dense window \
                     system, got {}",
                    self.max_persistent_points
                ),
            ));
        }
        if self.keyframe_min_tracked > 100_000 {
            return Err(ConfigError::new(
                "keyframe_min_tracked",
                format!("expected at most 100000, got {}", self.keyframe_min_tracked),
            ));
        }
        if let Some((g, a)) = self.imu_spike_threshold {
            positive("imu_spike_threshold (gyroscope)", g)?;
            positive("imu_spike_threshold (accelerometer)", a)?;
        }
        positive("sensor_timeout_s", self.sensor_timeout_s)?;
        positive("imu_max_gap_s", self.imu_max_gap_s)?;
        if let Some((g, a)) = self.imu_range {
            // Infinite: that axis does not saturate.
            if !(g > 0.0 && a > 0.0) {
                return Err(ConfigError::new(
                    "imu_range",
                    format!("must be > 0 on both sensors, got [{g}, {a}]"),
                ));
            }
        }
        positive("extrinsic_prior_sigma_deg", self.extrinsic_prior_sigma_deg)?;
        positive("extrinsic_prior_sigma_m", self.extrinsic_prior_sigma_m)?;
        positive(
            "calibration_release_sigma_deg",
            self.calibration_release_sigma_deg,
        )?;
        positive(
            "calibration_release_sigma_m",
            self.calibration_release_sigma_m,
        )?;
        positive(
            "calibration_release_sigma_ms",
            self.calibration_release_sigma_ms,
        )?;
        positive(
            "calibration_contradiction_sigma_ms",
            self.calibration_contradiction_sigma_ms,
        )?;
        positive_or_infinite(
            "calibration_release_disagreement_sigmas",
            self.calibration_release_disagreement_sigmas,
            "released only once determined",
        )?;
        positive(
            "extrinsic_relative_prior_sigma_deg",
            self.extrinsic_relative_prior_sigma_deg,
        )?;
        positive(
            "extrinsic_relative_prior_sigma_m",
            self.extrinsic_relative_prior_sigma_m,
        )?;
        value_in(
            "calibration_warmup_s",
            self.calibration_warmup_s,
            0.0,
            3600.0,
            " s",
        )?;
        let z = &self.zero_velocity;
        positive("zero_velocity.window_s", z.window_s)?;
        if z.window_s > 10.0 {
            return Err(ConfigError::new(
                "zero_velocity.window_s",
                format!("expected at most 10 s, got {}", z.window_s),
            ));
        }
        positive("zero_velocity.max_rate_rad_s", z.max_rate_rad_s)?;
        positive("zero_velocity.chi2_z", z.chi2_z)?;
        positive("zero_velocity.image_motion_sigmas", z.image_motion_sigmas)?;
        positive("zero_velocity.velocity_sigma_m_s", z.velocity_sigma_m_s)?;
        positive("zero_velocity.max_speed_m_s", z.max_speed_m_s)?;
        self.gnss.validate()?;
        self.wheel.validate()?;
        let h = &self.health;
        positive("health.max_accel_bias_m_s2", h.max_accel_bias_m_s2)?;
        positive("health.max_gyro_bias_rad_s", h.max_gyro_bias_rad_s)?;
        positive("health.max_jump_m", h.max_jump_m)?;
        positive("health.max_rotation_jump_deg", h.max_rotation_jump_deg)?;
        positive(
            "health.max_time_offset_deviation_s",
            h.max_time_offset_deviation_s,
        )?;
        count_in(
            "health.imu_chi2_solves",
            h.imu_chi2_solves,
            1,
            1000,
            " solves",
        )?;
        count_in(
            "health.rejected_solves",
            h.rejected_solves,
            1,
            1000,
            " solves",
        )?;
        non_negative("health.restart_trial_s", h.restart_trial_s)?;
        positive_or_infinite(
            "health.max_rejected_fraction",
            h.max_rejected_fraction,
            "no rejection test",
        )?;
        // Infinite: the IMU χ² test is off.
        if h.imu_chi2_z.is_nan() || h.imu_chi2_z <= 0.0 {
            return Err(ConfigError::new(
                "health.imu_chi2_z",
                format!(
                    "expected a number of σ > 0 (infinite: off), got {}",
                    h.imu_chi2_z
                ),
            ));
        }
        Ok(())
    }
}
