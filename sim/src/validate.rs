//! The checks a [`WorldConfig`] passes before anything is built: every number finite and in its
//! physical range, and resource bounds computed before allocation (samples, frames, landmarks,
//! spline knots), so that no configuration panics or exhausts memory later.

use crate::faults::Fault;
use crate::limits;
use crate::motion::Reference;
use crate::scene::{Aabb, SceneConfig};
use crate::vibration::Vibration;
use crate::world_config::{SimError, TrajectoryConfig, WorldConfig};

fn finite_positive(what: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SimError::Config(format!(
            "{what} must be finite and > 0, got {v}"
        )))
    }
}

fn finite_non_negative(what: &str, v: f64) -> Result<(), SimError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(SimError::Config(format!(
            "{what} must be finite and ≥ 0, got {v}"
        )))
    }
}

fn validate_vibration(v: &Vibration, rate_hz: f64) -> Result<(), SimError> {
    let a = &v.activity;
    finite_non_negative("vibration speed at rest (m/s)", a.speed_at_rest_m_s)?;
    within(
        "vibration speed in flight (m/s)",
        a.speed_in_flight_m_s,
        a.speed_at_rest_m_s,
        f64::MAX,
        "at least the speed at rest",
    )?;
    finite_non_negative("vibration time constant (s)", a.time_constant_s)?;
    let nyquist = rate_hz / 2.0;
    for p in [&v.rest, &v.flight] {
        for b in &p.bands {
            finite_non_negative("vibration band lower edge (Hz)", b.lo_hz)?;
            within(
                "vibration band upper edge (Hz)",
                b.hi_hz,
                b.lo_hz + f64::MIN_POSITIVE,
                nyquist,
                "above the lower edge and at most half the IMU rate",
            )?;
            for x in b.gyro_rms.iter().chain(b.accel_rms.iter()) {
                finite_non_negative("vibration band RMS", *x)?;
            }
        }
        for l in &p.lines {
            within(
                "vibration line frequency (Hz)",
                l.freq_hz,
                0.0,
                nyquist,
                "at most half the IMU rate",
            )?;
            for x in l.gyro_rms.iter().chain(l.accel_rms.iter()) {
                finite_non_negative("vibration line RMS", *x)?;
            }
        }
    }
    Ok(())
}

fn within(what: &str, v: f64, lo: f64, hi: f64, why: &str) -> Result<(), SimError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err(SimError::Config(format!(
            "{what} must be in [{lo}, {hi}] ({why}), got {v}"
        )))
    }
}

impl SceneConfig {
    /// How many landmarks the preset holds at this density (before occluded ones are dropped).
    pub fn expected_landmarks(&self) -> f64 {
        let (surfaces, _) = crate::scene::Scene::preset_geometry(self.preset);
        surfaces.iter().map(|s| s.area()).sum::<f64>() * self.landmark_density
    }
}

impl crate::motion::Lissajous {
    /// Checks that every parameter is finite (a NaN centre would only surface when ground
    /// truth is written).
    pub fn validate(&self) -> Result<(), SimError> {
        let vectors = [
            ("centre", self.center),
            ("amplitude", self.amplitude),
            ("frequency", self.freq_hz),
            ("phase", self.phase),
        ];
        for (what, v) in vectors {
            if !v.iter().all(|x| x.is_finite()) {
                return Err(SimError::Config(format!(
                    "trajectory {what} must be finite, got [{}, {}, {}]",
                    v.x, v.y, v.z
                )));
            }
        }
        for (what, v) in [
            ("yaw0", self.yaw0),
            ("yaw rate", self.yaw_rate),
            ("yaw amplitude", self.yaw_amplitude),
            ("yaw frequency", self.yaw_freq_hz),
            ("tilt amplitude", self.tilt_amplitude),
            ("tilt frequency", self.tilt_freq_hz),
        ] {
            if !v.is_finite() {
                return Err(SimError::Config(format!(
                    "trajectory {what} must be finite, got {v}"
                )));
            }
        }
        if let Some(d) = self.duration_s {
            finite_positive("trajectory duration (s)", d)?;
        }
        Ok(())
    }
}

impl Fault {
    /// Checks the fault's parameters (finite, in range, a non-empty interval).
    pub fn validate(&self) -> Result<(), SimError> {
        let interval = |start: i64, end: i64| {
            if end > start {
                Ok(())
            } else {
                Err(SimError::Config(format!(
                    "fault interval [{start}, {end}) ns is empty"
                )))
            }
        };
        let probability = |p: f64| within("fault probability", p, 0.0, 1.0, "a probability");
        match *self {
            Fault::CameraBlackout {
                start_ns, end_ns, ..
            }
            | Fault::ImuDropout { start_ns, end_ns }
            | Fault::GnssOutage { start_ns, end_ns }
            | Fault::CameraFreeze {
                start_ns, end_ns, ..
            } => interval(start_ns, end_ns),
            Fault::CameraDeath { .. } => Ok(()),
            Fault::FrameDrops {
                start_ns,
                end_ns,
                probability: p,
            } => {
                interval(start_ns, end_ns)?;
                probability(p)
            }
            Fault::ImuSpikes {
                start_ns,
                end_ns,
                probability: p,
                gyro,
                accel,
            } => {
                interval(start_ns, end_ns)?;
                probability(p)?;
                finite_non_negative("spike gyroscope size (rad/s)", gyro)?;
                finite_non_negative("spike accelerometer size (m/s²)", accel)
            }
            Fault::ImuSaturation {
                start_ns,
                end_ns,
                gyro_range,
                accel_range,
            } => {
                interval(start_ns, end_ns)?;
                // Infinite: that sensor does not saturate.
                for (what, r) in [("gyroscope", gyro_range), ("accelerometer", accel_range)] {
                    if r.is_nan() || r <= 0.0 {
                        return Err(SimError::Config(format!(
                            "saturation {what} range must be > 0, got {r}"
                        )));
                    }
                }
                Ok(())
            }
            Fault::TimestampJitter {
                start_ns,
                end_ns,
                imu_sigma_ns,
                camera_sigma_ns,
            } => {
                interval(start_ns, end_ns)?;
                finite_non_negative("IMU jitter σ (ns)", imu_sigma_ns)?;
                finite_non_negative("camera jitter σ (ns)", camera_sigma_ns)
            }
            Fault::GnssBiasJump { offset_m, .. } => {
                if offset_m.iter().all(|x| x.is_finite()) {
                    Ok(())
                } else {
                    Err(SimError::Config(format!(
                        "GNSS bias jump must be finite, got {:?}",
                        offset_m.as_slice()
                    )))
                }
            }
            Fault::WheelSlip {
                start_ns,
                end_ns,
                slip_ratio,
            } => {
                interval(start_ns, end_ns)?;
                within(
                    "wheel slip ratio",
                    slip_ratio,
                    -1.0,
                    10.0,
                    "from locked wheels (-1) to spinning ten times too fast",
                )
            }
            Fault::CameraTimeOffset { td_ns, .. } => within(
                "camera time offset (s)",
                td_ns as f64 * 1e-9,
                -limits::MAX_TIME_OFFSET_S,
                limits::MAX_TIME_OFFSET_S,
                "a clock offset, not a shift of the recording",
            ),
        }
    }
}

impl WorldConfig {
    /// Checks every value for finiteness and range and bounds the resources the run will use;
    /// [`crate::World::new`] calls it first.
    pub fn validate(&self) -> Result<(), SimError> {
        use limits::*;
        within(
            "duration (s)",
            self.duration_s,
            f64::MIN_POSITIVE,
            MAX_DURATION_S,
            "one day at most",
        )?;
        let imu = &self.imu;
        within(
            "IMU rate (Hz)",
            imu.rate_hz,
            MIN_IMU_RATE_HZ,
            MAX_IMU_RATE_HZ,
            "a physical IMU",
        )?;
        let samples = self.duration_s * imu.rate_hz;
        if samples > MAX_IMU_SAMPLES {
            return Err(SimError::Config(format!(
                "{samples:.3e} IMU samples (duration × rate) exceed the limit of {MAX_IMU_SAMPLES:.0e}: shorten the run or lower the rate"
            )));
        }
        if let Some(n) = &imu.noise {
            finite_non_negative("gyroscope noise density", n.gyroscope_noise_density)?;
            finite_non_negative("accelerometer noise density", n.accelerometer_noise_density)?;
            finite_non_negative("gyroscope random walk", n.gyroscope_random_walk)?;
            finite_non_negative("accelerometer random walk", n.accelerometer_random_walk)?;
        }
        let vectors = [
            ("initial gyroscope bias", imu.initial_gyro_bias.iter()),
            ("initial accelerometer bias", imu.initial_accel_bias.iter()),
        ];
        for (what, mut v) in vectors {
            if !v.all(|x| x.is_finite()) {
                return Err(SimError::Config(format!("{what} must be finite")));
            }
        }
        if !(imu.gyro_matrix.iter().all(|x| x.is_finite())
            && imu.accel_matrix.iter().all(|x| x.is_finite()))
        {
            return Err(SimError::Config(
                "IMU scale/misalignment matrices must be finite".into(),
            ));
        }
        for (what, r) in [
            ("gyroscope range", imu.gyro_range),
            ("accelerometer range", imu.accel_range),
        ] {
            if let Some(r) = r {
                finite_positive(what, r)?;
            }
        }
        if let Some(b) = &imu.bias_instability {
            finite_non_negative("gyroscope bias instability", b.gyro_rad_s)?;
            finite_non_negative("accelerometer bias instability", b.accel_m_s2)?;
            finite_positive("bias instability correlation time (s)", b.correlation_s)?;
        }
        if let Some(v) = &imu.vibration {
            validate_vibration(v, imu.rate_hz)?;
        }
        within(
            "landmark density (per m²)",
            self.scene.landmark_density,
            0.0,
            f64::MAX,
            "a density",
        )?;
        let landmarks = self.scene.expected_landmarks();
        if landmarks > MAX_LANDMARKS {
            return Err(SimError::Config(format!(
                "the scene would hold {landmarks:.3e} landmarks (density × surface area), more than the limit of {MAX_LANDMARKS:.0e}: lower the landmark density"
            )));
        }
        if let Some(g) = &self.gnss {
            within("GNSS rate (Hz)", g.rate_hz, 0.01, 1000.0, "a receiver")?;
            for x in g.sigma_m.iter() {
                finite_positive("GNSS σ (m)", *x)?;
            }
            if !g.lever_arm_b.iter().all(|x| x.is_finite()) {
                return Err(SimError::Config("GNSS lever arm must be finite".into()));
            }
        }
        if let Some(w) = &self.wheel {
            within("wheel rate (Hz)", w.rate_hz, 0.1, 10_000.0, "an odometer")?;
            finite_non_negative("wheel speed σ (m/s)", w.sigma_m_s)?;
        }
        if let Some(rig) = &self.rig {
            within(
                "frame rate (Hz)",
                rig.rate_hz,
                1e-3,
                MAX_CAMERA_RATE_HZ.min(imu.rate_hz),
                "a camera no faster than the IMU",
            )?;
            let frames = self.duration_s * rig.rate_hz * rig.cameras.len() as f64;
            if frames > MAX_CAMERA_FRAMES {
                return Err(SimError::Config(format!(
                    "{frames:.3e} camera frames (duration × rate × cameras) exceed the limit of {MAX_CAMERA_FRAMES:.0e}"
                )));
            }
            within(
                "camera time offset (s)",
                rig.td_ns as f64 * 1e-9,
                -MAX_TIME_OFFSET_S,
                MAX_TIME_OFFSET_S,
                "a clock offset",
            )?;
            for (i, c) in rig.cameras.iter().enumerate() {
                if rig.cameras[..i].iter().any(|o| o.name == c.name) {
                    return Err(SimError::Config(format!(
                        "two cameras are named `{}`: names select the noise streams and must differ",
                        c.name
                    )));
                }
                finite_non_negative(&format!("{} pixel σ", c.name), c.pixel_sigma)?;
                finite_positive(&format!("{} min depth", c.name), c.min_depth)?;
                finite_positive(&format!("{} max depth", c.name), c.max_depth)?;
                if c.min_depth >= c.max_depth {
                    return Err(SimError::Config(format!(
                        "{}: min depth {} m must be below max depth {} m",
                        c.name, c.min_depth, c.max_depth
                    )));
                }
                if c.max_features > MAX_FEATURES_PER_FRAME {
                    return Err(SimError::Config(format!(
                        "{}: max features {} exceeds the limit of {MAX_FEATURES_PER_FRAME}",
                        c.name, c.max_features
                    )));
                }
                let t = &c.t_b_c;
                if !(t.p.iter().all(|v| v.is_finite()) && t.q.coords.iter().all(|v| v.is_finite()))
                {
                    return Err(SimError::Config(format!(
                        "{}: T_b_c must be finite",
                        c.name
                    )));
                }
            }
        }
        match &self.trajectory {
            TrajectoryConfig::Lissajous(l) => l.validate()?,
            TrajectoryConfig::Waypoints(w) => {
                finite_positive("waypoint spacing (s)", w.spacing_s)?;
                finite_positive("waypoint duration (s)", w.duration_s)?;
                let knots = w.duration_s / w.spacing_s;
                if knots > MAX_SPLINE_KNOTS {
                    return Err(SimError::Config(format!(
                        "{knots:.3e} waypoints exceed the limit of {MAX_SPLINE_KNOTS:.0e}"
                    )));
                }
                for i in 0..3 {
                    if !(w.min[i].is_finite() && w.max[i].is_finite() && w.min[i] <= w.max[i]) {
                        return Err(SimError::Config(
                            "waypoint box corners must be finite with min ≤ max".into(),
                        ));
                    }
                }
                for (what, v) in [
                    ("waypoint yaw step", w.max_yaw_step),
                    ("waypoint tilt", w.max_tilt),
                ] {
                    finite_non_negative(what, v)?;
                }
            }
            TrajectoryConfig::Replay { knot_spacing_s, .. } => {
                finite_positive("replay knot spacing (s)", *knot_spacing_s)?;
            }
            TrajectoryConfig::Reference(_) => {}
        }
        if let Some(s) = self.static_start {
            finite_non_negative("static start hold (s)", s.hold_s)?;
            finite_non_negative("static start ramp (s)", s.ramp_s)?;
        }
        let mut previous_end = f64::NEG_INFINITY;
        for s in &self.stops {
            finite_non_negative("stop start (s)", s.at_s)?;
            finite_non_negative("stop duration (s)", s.duration_s)?;
            finite_positive("stop ramp (s)", s.ramp_s)?;
            if s.at_s < previous_end {
                return Err(SimError::Config(format!(
                    "the stop at {} s starts before the previous one ends ({previous_end} s)",
                    s.at_s
                )));
            }
            previous_end = s.end_s();
        }
        finite_non_negative("ground-truth retention (s)", self.truth_retention_s)?;
        for f in &self.faults {
            f.validate()?;
        }
        Ok(())
    }
}

/// Checks that the reference motion stays in the scene's free space over `[0, duration_s]`:
/// inside `free_space` and outside every solid box (sampled every 50 ms, at most 10⁵ samples).
/// A trajectory through a wall would be flown through, with no features for as long as the
/// camera is inside the solid.
pub fn check_free_space(
    reference: &dyn Reference,
    free_space: &Aabb,
    boxes: &[Aabb],
    duration_s: f64,
) -> Result<(), SimError> {
    let n = ((duration_s / 0.05).ceil() as usize).clamp(1, 100_000);
    for k in 0..=n {
        let t = duration_s * k as f64 / n as f64;
        let p = reference.state(t).p;
        let fmt = |v: &nalgebra::Vector3<f64>| format!("[{:.2}, {:.2}, {:.2}]", v.x, v.y, v.z);
        if !p.iter().all(|x| x.is_finite()) {
            return Err(SimError::Config(format!(
                "the trajectory is not finite at t = {t:.2} s"
            )));
        }
        if !(0..3).all(|i| p[i] >= free_space.min[i] && p[i] <= free_space.max[i]) {
            return Err(SimError::Config(format!(
                "the trajectory leaves the scene at t = {t:.2} s: position {} m is outside {} .. {} m",
                fmt(&p),
                fmt(&free_space.min),
                fmt(&free_space.max)
            )));
        }
        if let Some(b) = boxes.iter().find(|b| b.contains(&p, 0.0)) {
            return Err(SimError::Config(format!(
                "the trajectory passes through a solid box of the scene at t = {t:.2} s: position {} m is inside {} .. {} m",
                fmt(&p),
                fmt(&b.min),
                fmt(&b.max)
            )));
        }
    }
    Ok(())
}
