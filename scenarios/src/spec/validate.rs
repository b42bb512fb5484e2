//! The checks every scenario passes before anything runs: every number finite and in its
//! physical range, cross-field checks (depth range order, distinct camera names, a stereo
//! baseline), and resource bounds computed before anything is allocated (samples, frames,
//! landmarks, knots). After them, building the world and estimator configurations fails only on
//! data files; each error names the key and its line.

use sim::limits;
use sim::plausible::{self, Plausible};

use super::{Scenario, SpecError, SuiteSpec};

/// Smallest image side (px) a feature camera can work with.
const MIN_IMAGE_SIDE_PX: u32 = 16;
/// Largest image side (px).
const MAX_IMAGE_SIDE_PX: u32 = 16_384;
/// Smallest stereo baseline (m) a stereo suite accepts.
const MIN_BASELINE_M: f64 = 1e-3;

/// Number checks that name the key.
struct Check<'a> {
    scenario: &'a Scenario,
}

impl Check<'_> {
    fn finite(&self, key: &str, v: f64) -> Result<(), SpecError> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(self
                .scenario
                .error(key, format!("expected a finite number, got {v}")))
        }
    }

    fn finite_all(&self, key: &str, v: &[f64]) -> Result<(), SpecError> {
        match v.iter().find(|x| !x.is_finite()) {
            None => Ok(()),
            Some(x) => Err(self
                .scenario
                .error(key, format!("expected finite numbers, got {x}"))),
        }
    }

    fn positive(&self, key: &str, v: f64) -> Result<(), SpecError> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(self
                .scenario
                .error(key, format!("expected a finite number > 0, got {v}")))
        }
    }

    fn non_negative(&self, key: &str, v: f64) -> Result<(), SpecError> {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(self
                .scenario
                .error(key, format!("expected a finite number ≥ 0, got {v}")))
        }
    }

    /// `lo ≤ v ≤ hi`; `why` says where the range comes from.
    fn within(&self, key: &str, v: f64, lo: f64, hi: f64, why: &str) -> Result<(), SpecError> {
        if v.is_finite() && v >= lo && v <= hi {
            Ok(())
        } else {
            Err(self.scenario.error(
                key,
                format!("expected a number in [{lo}, {hi}] ({why}), got {v}"),
            ))
        }
    }

    /// `v` in the physical range of its quantity ([`sim::plausible`]).
    fn plausible(&self, key: &str, v: f64, range: &Plausible) -> Result<(), SpecError> {
        range.check(v).map_err(|e| self.scenario.error(key, e))
    }

    fn at_most(&self, key: &str, v: usize, hi: usize, why: &str) -> Result<(), SpecError> {
        if v <= hi {
            Ok(())
        } else {
            Err(self
                .scenario
                .error(key, format!("expected at most {hi} ({why}), got {v}")))
        }
    }

    /// A rate whose period is a whole number of nanoseconds.
    fn whole_ns_period(&self, key: &str, rate_hz: f64) -> Result<(), SpecError> {
        if (1e9 / rate_hz - (1e9 / rate_hz).round()).abs() > 1e-6 {
            return Err(self.scenario.error(
                key,
                "expected a rate whose period is a whole number of nanoseconds",
            ));
        }
        Ok(())
    }
}

impl Scenario {
    /// Checks everything the world and estimator configurations need, so that
    /// [`Scenario::world_config`] and [`Scenario::estimator_config`] only fail on data files.
    pub(super) fn validate(&self) -> Result<(), SpecError> {
        self.render_config()?;
        self.tracker_config(0)?;
        let s = &self.spec;
        if s.description.trim().is_empty() || s.description.contains('\n') {
            return Err(self.error("description", "expected one non-empty line"));
        }
        self.validate_trajectory()?;
        self.validate_rig()?;
        self.validate_estimator()?;
        for i in 0..s.faults.len() {
            self.fault(i)?;
        }
        self.validate_expectations()?;
        self.validate_resources()
    }

    fn validate_trajectory(&self) -> Result<(), SpecError> {
        let c = Check { scenario: self };
        let t = &self.spec.trajectory;
        c.within(
            "trajectory.duration_s",
            t.duration_s,
            1e-3,
            limits::MAX_DURATION_S,
            "one day at most",
        )?;
        if let Some(ss) = t.static_start {
            c.non_negative("trajectory.static_start.hold_s", ss.hold_s)?;
            c.non_negative("trajectory.static_start.ramp_s", ss.ramp_s)?;
        }
        let mut previous_end = f64::NEG_INFINITY;
        for (i, stop) in t.stops.iter().enumerate() {
            let key = |k: &str| format!("trajectory.stops[{i}].{k}");
            c.non_negative(&key("at_s"), stop.at_s)?;
            c.non_negative(&key("duration_s"), stop.duration_s)?;
            c.within(
                &key("ramp_s"),
                stop.ramp_s,
                1e-3,
                60.0,
                "a ramp of 1 ms to 60 s",
            )?;
            if stop.at_s < previous_end {
                return Err(self.error(
                    &key("at_s"),
                    format!(
                        "expected the stops sorted and apart: this one starts at {} s, before the previous one is back to speed at {previous_end} s",
                        stop.at_s
                    ),
                ));
            }
            previous_end = stop.at_s + stop.duration_s + 2.0 * stop.ramp_s;
        }
        let given = t.motions_given();
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
            c.finite_all("trajectory.figure_eight.center", &f.center)?;
            c.positive("trajectory.figure_eight.period_s", f.period_s)?;
            c.non_negative("trajectory.figure_eight.half_width_m", f.half_width_m)?;
            c.non_negative("trajectory.figure_eight.half_height_m", f.half_height_m)?;
        }
        if let Some(g) = t.ground_vehicle {
            let k = |n: &str| format!("trajectory.ground_vehicle.{n}");
            c.finite_all(&k("center"), &g.center)?;
            c.positive(&k("period_s"), g.period_s)?;
            // Both extents > 0: the heading is defined only where the velocity never vanishes.
            c.positive(&k("half_width_m"), g.half_width_m)?;
            c.positive(&k("half_height_m"), g.half_height_m)?;
        }
        if let Some(o) = t.circle {
            c.finite_all("trajectory.circle.center", &o.center)?;
            c.positive("trajectory.circle.period_s", o.period_s)?;
            c.non_negative("trajectory.circle.radius_m", o.radius_m)?;
        }
        if let Some(l) = t.lissajous {
            let k = |n: &str| format!("trajectory.lissajous.{n}");
            c.finite_all(&k("center"), &l.center)?;
            c.finite_all(&k("amplitude_m"), &l.amplitude_m)?;
            c.finite_all(&k("freq_hz"), &l.freq_hz)?;
            c.finite_all(&k("phase_rad"), &l.phase_rad)?;
            for (n, v) in [
                ("yaw0_rad", l.yaw0_rad),
                ("yaw_rate_rad_s", l.yaw_rate_rad_s),
                ("yaw_amplitude_rad", l.yaw_amplitude_rad),
                ("yaw_freq_hz", l.yaw_freq_hz),
                ("tilt_amplitude_rad", l.tilt_amplitude_rad),
                ("tilt_freq_hz", l.tilt_freq_hz),
            ] {
                c.finite(&k(n), v)?;
            }
        }
        if let Some(w) = t.waypoints {
            c.finite_all("trajectory.waypoints.min", &w.min)?;
            c.finite_all("trajectory.waypoints.max", &w.max)?;
            c.positive("trajectory.waypoints.spacing_s", w.spacing_s)?;
            c.non_negative("trajectory.waypoints.max_yaw_step_rad", w.max_yaw_step_rad)?;
            c.non_negative("trajectory.waypoints.max_tilt_rad", w.max_tilt_rad)?;
            if (0..3).any(|i| w.max[i] <= w.min[i]) {
                return Err(self.error("trajectory.waypoints.max", "expected max > min per axis"));
            }
            let knots = t.duration_s / w.spacing_s;
            if knots > limits::MAX_SPLINE_KNOTS {
                return Err(self.error(
                    "trajectory.waypoints.spacing_s",
                    format!(
                        "{knots:.3e} waypoints (duration / spacing) exceed the limit of {:.0e}",
                        limits::MAX_SPLINE_KNOTS
                    ),
                ));
            }
        }
        if let Some(r) = &t.replay {
            self.validate_replay_keys(r)?;
        }
        Ok(())
    }

    fn validate_rig(&self) -> Result<(), SpecError> {
        let c = Check { scenario: self };
        let s = &self.spec;
        let rig = &s.rig;
        let imu = &rig.imu;
        c.within(
            "rig.imu.rate_hz",
            imu.rate_hz,
            limits::MIN_IMU_RATE_HZ,
            limits::MAX_IMU_RATE_HZ,
            "a physical IMU",
        )?;
        c.whole_ns_period("rig.imu.rate_hz", imu.rate_hz)?;
        c.within(
            "rig.rate_hz",
            rig.rate_hz,
            1e-3,
            limits::MAX_CAMERA_RATE_HZ.min(imu.rate_hz),
            "a camera no faster than 1 kHz nor than the IMU",
        )?;
        c.plausible("rig.rate_hz", rig.rate_hz, &plausible::CAMERA_RATE_HZ)?;
        if let Some(g) = rig.gnss {
            c.within("rig.gnss.rate_hz", g.rate_hz, 0.01, 1000.0, "a receiver")?;
            c.whole_ns_period("rig.gnss.rate_hz", g.rate_hz)?;
            for (i, v) in g.sigma_m.iter().enumerate() {
                c.positive(&format!("rig.gnss.sigma_m[{i}]"), *v)?;
            }
            c.finite_all("rig.gnss.lever_arm_m", &g.lever_arm_m)?;
        }
        if let Some(w) = rig.wheel {
            c.within("rig.wheel.rate_hz", w.rate_hz, 0.1, 10_000.0, "an odometer")?;
            c.whole_ns_period("rig.wheel.rate_hz", w.rate_hz)?;
            c.non_negative("rig.wheel.sigma_m_s", w.sigma_m_s)?;
        }
        c.within(
            "rig.time_offset_s",
            rig.time_offset_s,
            -limits::MAX_TIME_OFFSET_S,
            limits::MAX_TIME_OFFSET_S,
            "a clock offset",
        )?;
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
        let names: Vec<String> = (0..rig.cameras.len())
            .map(|i| rig.cameras[i].name.clone().unwrap_or(format!("cam{i}")))
            .collect();
        for i in 0..rig.cameras.len() {
            let k = |n: &str| format!("rig.cameras[{i}].{n}");
            let cam = &rig.cameras[i];
            if names[..i].contains(&names[i]) {
                return Err(self.error(
                    &k("name"),
                    format!(
                        "two cameras are named `{}`: names select the noise streams and must differ",
                        names[i]
                    ),
                ));
            }
            let [w, h] = cam.resolution;
            if !(MIN_IMAGE_SIDE_PX..=MAX_IMAGE_SIDE_PX).contains(&w.min(h))
                || w.max(h) > MAX_IMAGE_SIDE_PX
            {
                return Err(self.error(
                    &k("resolution"),
                    format!(
                        "expected both sides in [{MIN_IMAGE_SIDE_PX}, {MAX_IMAGE_SIDE_PX}] px, got [{w}, {h}]"
                    ),
                ));
            }
            c.finite_all(&k("intrinsics"), &cam.intrinsics)?;
            let [fx, fy, _, _] = cam.intrinsics;
            // A focal length under a pixel puts the whole hemisphere into one pixel.
            if fx.min(fy) < 1.0 {
                return Err(self.error(
                    &k("intrinsics"),
                    format!("expected focal lengths fx, fy ≥ 1 px, got {fx}, {fy}"),
                ));
            }
            let longer = f64::from(w.max(h));
            for f in [fx, fy] {
                plausible::check_focal_length(f, longer)
                    .map_err(|e| self.error(&k("intrinsics"), e))?;
            }
            c.finite_all(&k("distortion"), &cam.distortion)?;
            for d in &cam.distortion {
                c.plausible(&k("distortion"), *d, &plausible::DISTORTION_COEFFICIENT)?;
            }
            self.camera_model(i)?;
            let offset = self.extrinsic(i)?.p.norm();
            plausible::CAMERA_OFFSET_M.check(offset).map_err(|e| {
                self.error(
                    &k("T_b_c.translation_m"),
                    format!("the camera {offset} m from the IMU: {e}"),
                )
            })?;
            // Noise beyond a tenth of the image makes every feature a random pixel.
            let side = f64::from(w.min(h));
            c.within(
                &k("pixel_sigma_px"),
                cam.pixel_sigma_px,
                0.0,
                0.1 * side,
                "at most a tenth of the smaller image side",
            )?;
            self.tracker_error_model(i)?;
            if let Some(e) = &cam.calibration_error {
                c.finite_all(&k("calibration_error.rotation_deg"), &e.rotation_deg)?;
                c.finite_all(&k("calibration_error.translation_m"), &e.translation_m)?;
                let (deg, m) = (
                    nalgebra::Vector3::from(e.rotation_deg).norm(),
                    nalgebra::Vector3::from(e.translation_m).norm(),
                );
                c.within(
                    &k("calibration_error.rotation_deg"),
                    deg,
                    0.0,
                    30.0,
                    "a rotation of at most 30° (a calibration error, not a remount)",
                )?;
                c.within(
                    &k("calibration_error.translation_m"),
                    m,
                    0.0,
                    0.5,
                    "a shift of at most 0.5 m",
                )?;
            }
            if let Some(e) = &cam.intrinsics_error {
                c.finite_all(&k("intrinsics_error.focal_percent"), &e.focal_percent)?;
                c.finite_all(
                    &k("intrinsics_error.principal_point_px"),
                    &e.principal_point_px,
                )?;
                c.finite_all(&k("intrinsics_error.distortion"), &e.distortion)?;
                for v in e.focal_percent {
                    c.within(
                        &k("intrinsics_error.focal_percent"),
                        v,
                        -20.0,
                        20.0,
                        "within ±20 % (a calibration error, not another lens)",
                    )?;
                }
                for (v, side) in e.principal_point_px.into_iter().zip([w, h]) {
                    let most = 0.1 * f64::from(side);
                    c.within(
                        &k("intrinsics_error.principal_point_px"),
                        v,
                        -most,
                        most,
                        "within a tenth of the image side",
                    )?;
                }
                self.estimator_camera_model(i)?;
            }
            if let Some(r) = &cam.rolling_shutter {
                // A readout longer than the frame period would overlap the next frame's.
                c.within(
                    &k("rolling_shutter.readout_ms"),
                    r.readout_ms,
                    0.0,
                    1e3 / rig.rate_hz,
                    "at most the frame period (1000 / rig.rate_hz ms)",
                )?;
            }
            if let Some(d) = cam.min_depth_m {
                c.positive(&k("min_depth_m"), d)?;
            }
            if let Some(d) = cam.max_depth_m {
                c.positive(&k("max_depth_m"), d)?;
            }
            let (lo, hi) = (
                cam.min_depth_m.unwrap_or(0.1),
                cam.max_depth_m.unwrap_or(40.0),
            );
            if lo >= hi {
                return Err(self.error(
                    &k("max_depth_m"),
                    format!("expected min_depth_m < max_depth_m, got {lo} m and {hi} m"),
                ));
            }
            if let Some(n) = cam.max_features {
                c.at_most(
                    &k("max_features"),
                    n,
                    limits::MAX_FEATURES_PER_FRAME,
                    "features per frame",
                )?;
            }
        }
        if matches!(s.suite, SuiteSpec::StereoImu | SuiteSpec::Stereo) {
            let baseline = (self.extrinsic(0)?.p - self.extrinsic(1)?.p).norm();
            if baseline < MIN_BASELINE_M {
                return Err(self.error(
                    "rig.cameras[1].T_b_c.translation_m",
                    format!(
                        "the {} suite needs a stereo baseline ≥ {MIN_BASELINE_M} m, got {baseline} m (both cameras at the same place)",
                        s.suite.as_str()
                    ),
                ));
            }
        }
        for (key, v, range) in [
            (
                "rig.imu.gyroscope_noise_density",
                imu.gyroscope_noise_density,
                plausible::GYROSCOPE_NOISE_DENSITY,
            ),
            (
                "rig.imu.accelerometer_noise_density",
                imu.accelerometer_noise_density,
                plausible::ACCELEROMETER_NOISE_DENSITY,
            ),
            (
                "rig.imu.gyroscope_random_walk",
                imu.gyroscope_random_walk,
                plausible::GYROSCOPE_RANDOM_WALK,
            ),
            (
                "rig.imu.accelerometer_random_walk",
                imu.accelerometer_random_walk,
                plausible::ACCELEROMETER_RANDOM_WALK,
            ),
        ] {
            c.positive(key, v)?;
            c.plausible(key, v, &range)?;
        }
        c.finite_all(
            "rig.imu.initial_gyro_bias_rad_s",
            &imu.initial_gyro_bias_rad_s,
        )?;
        c.finite_all(
            "rig.imu.initial_accel_bias_m_s2",
            &imu.initial_accel_bias_m_s2,
        )?;
        if let Some(r) = imu.gyro_range_rad_s {
            c.positive("rig.imu.gyro_range_rad_s", r)?;
            c.plausible("rig.imu.gyro_range_rad_s", r, &plausible::GYRO_RANGE_RAD_S)?;
        }
        if let Some(r) = imu.accel_range_m_s2 {
            c.positive("rig.imu.accel_range_m_s2", r)?;
            c.plausible("rig.imu.accel_range_m_s2", r, &plausible::ACCEL_RANGE_M_S2)?;
        }
        Ok(())
    }

    /// The `[estimator]` settings' own ranges ([`EstimatorConfig::validate_settings`]), the
    /// error at the setting's key.
    fn validate_estimator(&self) -> Result<(), SpecError> {
        self.settings
            .validate_settings()
            .map_err(|e| self.error(&format!("estimator.{}", e.field), e.message))
    }

    /// The estimator's own checks as a backstop (after the camera models are built): whatever
    /// it refuses is refused here, with its field named.
    pub(super) fn validate_estimator_config(&self) -> Result<(), SpecError> {
        let cfg = self.estimator_config()?;
        cfg.validate().map_err(|e| {
            self.error(
                "estimator",
                format!("unusable estimator settings: {e} (from the rig and [estimator])"),
            )
        })
    }

    fn validate_expectations(&self) -> Result<(), SpecError> {
        let c = Check { scenario: self };
        for (name, b) in self.spec.expectations.bounds() {
            let key = format!("expectations.{name}");
            if b.min.is_none() && b.max.is_none() {
                return Err(self.error(&key, "expected `min` and/or `max`"));
            }
            if let Some(v) = b.min {
                c.finite(&format!("{key}.min"), v)?;
            }
            if let Some(v) = b.max {
                c.finite(&format!("{key}.max"), v)?;
            }
            if let (Some(lo), Some(hi)) = (b.min, b.max)
                && lo > hi
            {
                return Err(self.error(&key, format!("expected min ≤ max, got {lo} > {hi}")));
            }
        }
        Ok(())
    }

    /// Samples, frames and landmarks the run will produce, bounded before anything is
    /// allocated (the duration may still be shortened by `--duration`).
    fn validate_resources(&self) -> Result<(), SpecError> {
        let s = &self.spec;
        let d = s.trajectory.duration_s;
        let samples = d * s.rig.imu.rate_hz;
        if samples > limits::MAX_IMU_SAMPLES {
            return Err(self.error(
                "rig.imu.rate_hz",
                format!(
                    "{samples:.3e} IMU samples (duration × rate) exceed the limit of {:.0e}: shorten the run or lower the rate",
                    limits::MAX_IMU_SAMPLES
                ),
            ));
        }
        let frames = d * s.rig.rate_hz * s.rig.cameras.len() as f64;
        if frames > limits::MAX_CAMERA_FRAMES {
            return Err(self.error(
                "rig.rate_hz",
                format!(
                    "{frames:.3e} camera frames (duration × rate × cameras) exceed the limit of {:.0e}",
                    limits::MAX_CAMERA_FRAMES
                ),
            ));
        }
        if let Some(v) = s.world.landmark_density {
            Check { scenario: self }.non_negative("world.landmark_density", v)?;
        }
        let scene = self.scene_config();
        let landmarks = scene.expected_landmarks();
        if landmarks > limits::MAX_LANDMARKS {
            return Err(self.error(
                "world.landmark_density",
                format!(
                    "the {:?} scene would hold {landmarks:.3e} landmarks (density × surface area), more than the limit of {:.0e}",
                    scene.preset,
                    limits::MAX_LANDMARKS
                ),
            ));
        }
        Ok(())
    }

    /// The motion stays in the scene's free space (inside the room or hall, outside its solid
    /// boxes) for the whole run; the error names the motion's key. Waypoints are drawn with the
    /// file's seed here (the simulator checks again with the seed a run uses).
    pub(super) fn validate_free_space(&self) -> Result<(), SpecError> {
        let t = &self.spec.trajectory;
        let key = t
            .motions_given()
            .first()
            .map_or("trajectory".to_string(), |m| format!("trajectory.{m}"));
        let reference: std::sync::Arc<dyn sim::motion::Reference> = match self.trajectory()? {
            sim::TrajectoryConfig::Lissajous(l) => std::sync::Arc::new(l),
            sim::TrajectoryConfig::Waypoints(w) => {
                std::sync::Arc::new(w.build(self.spec.world.seed))
            }
            sim::TrajectoryConfig::Reference(r) => r,
            sim::TrajectoryConfig::Replay { .. } => return Ok(()),
        };
        let preset = self.scene_config().preset;
        let (_, boxes) = sim::scene::Scene::preset_geometry(preset);
        let duration = reference
            .duration()
            .map_or(t.duration_s, |d| d.min(t.duration_s));
        sim::validate::check_free_space(reference.as_ref(), &preset.free_space(), &boxes, duration)
            .map_err(|e| {
                let why = e.to_string();
                let why = why.strip_prefix("invalid configuration: ").unwrap_or(&why);
                self.error(&key, why.to_string())
            })
    }

    /// The replay keys that can be checked without reading the file.
    fn validate_replay_keys(&self, r: &super::ReplaySpec) -> Result<(), SpecError> {
        if let Some(k) = r.knot_spacing_s {
            Check { scenario: self }.within(
                "trajectory.replay.knot_spacing_s",
                k,
                1e-3,
                1.0,
                "knots resolve the motion, they do not replace it",
            )?;
        }
        let c = Check { scenario: self };
        if let Some(v) = r.fit_tolerance_m {
            c.within("trajectory.replay.fit_tolerance_m", v, 1e-6, 1.0, "metres")?;
        }
        if let Some(v) = r.fit_tolerance_deg {
            c.within(
                "trajectory.replay.fit_tolerance_deg",
                v,
                1e-4,
                45.0,
                "degrees",
            )?;
        }
        if let Some(p) = r.placement {
            c.finite_all(
                "trajectory.replay.placement.translation_m",
                &p.translation_m,
            )?;
            c.finite("trajectory.replay.placement.yaw_deg", p.yaw_deg)?;
        }
        Ok(())
    }
}
