//! The checks every scenario passes before anything runs: after them, building the world and
//! estimator configurations fails only on data files.

use super::{Scenario, SpecError, SuiteSpec};

impl Scenario {
    /// Checks everything the world and estimator configurations need, so that
    /// [`Scenario::world_config`] and [`Scenario::estimator_config`] only fail on data files.
    pub(super) fn validate(&self) -> Result<(), SpecError> {
        self.render_config()?;
        self.tracker_config(0)?;
        let s = &self.spec;
        let pos = |key: &str, v: f64| -> Result<(), SpecError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(self.error(key, format!("expected a finite number > 0, got {v}")))
            }
        };
        let nonneg = |key: &str, v: f64| -> Result<(), SpecError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(self.error(key, format!("expected a finite number ≥ 0, got {v}")))
            }
        };
        if s.description.trim().is_empty() || s.description.contains('\n') {
            return Err(self.error("description", "expected one non-empty line"));
        }
        if let Some(d) = s.world.landmark_density {
            pos("world.landmark_density", d)?;
        }
        // Trajectory.
        let t = &s.trajectory;
        pos("trajectory.duration_s", t.duration_s)?;
        if let Some(ss) = t.static_start {
            nonneg("trajectory.static_start.hold_s", ss.hold_s)?;
            nonneg("trajectory.static_start.ramp_s", ss.ramp_s)?;
        }
        let given: Vec<&str> = [
            ("figure_eight", t.figure_eight.is_some()),
            ("circle", t.circle.is_some()),
            ("lissajous", t.lissajous.is_some()),
            ("waypoints", t.waypoints.is_some()),
            ("replay", t.replay.is_some()),
        ]
        .into_iter()
        .filter_map(|(n, g)| g.then_some(n))
        .collect();
        if given.len() != 1 {
            return Err(self.error(
                "trajectory",
                format!(
                    "expected exactly one of figure_eight, circle, lissajous, waypoints, replay; got {}",
                    if given.is_empty() {
                        "none".to_string()
                    } else {
                        given.join(", ")
                    }
                ),
            ));
        }
        if let Some(f) = t.figure_eight {
            pos("trajectory.figure_eight.period_s", f.period_s)?;
            nonneg("trajectory.figure_eight.half_width_m", f.half_width_m)?;
            nonneg("trajectory.figure_eight.half_height_m", f.half_height_m)?;
        }
        if let Some(c) = t.circle {
            pos("trajectory.circle.period_s", c.period_s)?;
            nonneg("trajectory.circle.radius_m", c.radius_m)?;
        }
        if let Some(w) = t.waypoints {
            pos("trajectory.waypoints.spacing_s", w.spacing_s)?;
            if (0..3).any(|i| w.max[i] <= w.min[i]) {
                return Err(self.error("trajectory.waypoints.max", "expected max > min per axis"));
            }
        }
        if let Some(r) = &t.replay
            && let Some(k) = r.knot_spacing_s
        {
            pos("trajectory.replay.knot_spacing_s", k)?;
        }
        // Rig.
        let rig = &s.rig;
        pos("rig.rate_hz", rig.rate_hz)?;
        if (1e9 / rig.rate_hz - (1e9 / rig.rate_hz).round()).abs() > 1e-6 {
            return Err(self.error(
                "rig.rate_hz",
                "expected a rate whose period is a whole number of nanoseconds",
            ));
        }
        if !rig.time_offset_s.is_finite() {
            return Err(self.error("rig.time_offset_s", "expected a finite number"));
        }
        let allowed = match s.suite {
            SuiteSpec::MonoImu => 1..=2,
            SuiteSpec::StereoImu | SuiteSpec::Stereo => 2..=2,
        };
        if !allowed.contains(&rig.cameras.len()) {
            let want = if allowed.start() == allowed.end() {
                allowed.start().to_string()
            } else {
                format!("{} or {}", allowed.start(), allowed.end())
            };
            return Err(self.error(
                "rig.cameras",
                format!(
                    "expected {want} cameras for the {} suite, got {}",
                    s.suite.as_str(),
                    rig.cameras.len()
                ),
            ));
        }
        for i in 0..rig.cameras.len() {
            self.camera_model(i)?;
            self.extrinsic(i)?;
            let c = &rig.cameras[i];
            nonneg(
                &format!("rig.cameras[{i}].pixel_sigma_px"),
                c.pixel_sigma_px,
            )?;
            if let Some(d) = c.min_depth_m {
                pos(&format!("rig.cameras[{i}].min_depth_m"), d)?;
            }
            if let Some(d) = c.max_depth_m {
                pos(&format!("rig.cameras[{i}].max_depth_m"), d)?;
            }
        }
        let imu = &rig.imu;
        pos("rig.imu.rate_hz", imu.rate_hz)?;
        if (1e9 / imu.rate_hz - (1e9 / imu.rate_hz).round()).abs() > 1e-6 {
            return Err(self.error(
                "rig.imu.rate_hz",
                "expected a rate whose period is a whole number of nanoseconds",
            ));
        }
        pos(
            "rig.imu.gyroscope_noise_density",
            imu.gyroscope_noise_density,
        )?;
        pos(
            "rig.imu.accelerometer_noise_density",
            imu.accelerometer_noise_density,
        )?;
        pos("rig.imu.gyroscope_random_walk", imu.gyroscope_random_walk)?;
        pos(
            "rig.imu.accelerometer_random_walk",
            imu.accelerometer_random_walk,
        )?;
        if let Some(r) = imu.gyro_range_rad_s {
            pos("rig.imu.gyro_range_rad_s", r)?;
        }
        if let Some(r) = imu.accel_range_m_s2 {
            pos("rig.imu.accel_range_m_s2", r)?;
        }
        // Estimator.
        let e = &s.estimator;
        if let Some(w) = e.window_size
            && w < 3
        {
            return Err(self.error("estimator.window_size", "expected ≥ 3"));
        }
        if let Some(n) = e.init_frames
            && n < 4
        {
            return Err(self.error("estimator.init_frames", "expected ≥ 4"));
        }
        if let Some(n) = e.solver_iterations
            && n < 1
        {
            return Err(self.error("estimator.solver_iterations", "expected ≥ 1"));
        }
        if let Some(p) = e.pixel_sigma_px {
            pos("estimator.pixel_sigma_px", p)?;
        }
        for (key, v) in [
            ("estimator.keyframe_parallax_px", e.keyframe_parallax_px),
            ("estimator.huber_sigma", e.huber_sigma),
            (
                "estimator.outlier_reprojection_px",
                e.outlier_reprojection_px,
            ),
        ] {
            if let Some(v) = v {
                pos(key, v)?;
            }
        }
        // Faults.
        for i in 0..s.faults.len() {
            self.fault(i)?;
        }
        // Expectations.
        for (name, b) in s.expectations.bounds() {
            if b.min.is_none() && b.max.is_none() {
                return Err(self.error(
                    &format!("expectations.{name}"),
                    "expected `min` and/or `max`",
                ));
            }
        }
        Ok(())
    }
}
