//! The mapping of a validated scenario onto the simulator's and the estimator's configurations.

use std::path::Path;
use std::sync::Arc;

use estimator::camera::{
    Camera, CameraError, CameraModel, DoubleSphere, KannalaBrandt, Mei, PinholeRadtan,
};
use estimator::geometry::Pose;
use estimator::imu::ImuNoise;
use estimator::{CameraConfig as EstCamera, EstimatorConfig};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};
use sim::camera::{CameraConfig as SimCamera, RigConfig, TrackIds};
use sim::faults::Fault;
use sim::imu::{ImuConfig, ImuWindow};
use sim::motion::recording::{RecordingOptions, RecordingReport, TimeUnit, load_recording};
use sim::motion::{Lissajous, RandomWaypoints, Replay};
use sim::scene::{SceneConfig, ScenePreset};
use sim::{StaticStartConfig, TrajectoryConfig, WorldConfig};

use super::CalibrationTruth;
use super::error::serde_name;
use super::schema::*;
use super::{Origin, Scenario, SpecError};
use crate::catalog;

impl Scenario {
    /// The projection model of camera `i`.
    pub(super) fn camera_model(&self, i: usize) -> Result<Arc<dyn CameraModel>, SpecError> {
        let c = &self.spec.rig.cameras[i];
        self.camera_model_with(i, c.intrinsics, &c.distortion)
    }

    /// The model the estimator starts from for camera `i`: the true one, or with the camera's
    /// `intrinsics_error` applied (focal lengths scaled, principal point shifted, distortion
    /// coefficients offset).
    pub(super) fn estimator_camera_model(
        &self,
        i: usize,
    ) -> Result<Arc<dyn CameraModel>, SpecError> {
        let c = &self.spec.rig.cameras[i];
        let Some(e) = &c.intrinsics_error else {
            return self.camera_model(i);
        };
        let [fx, fy, cx, cy] = c.intrinsics;
        let intrinsics = [
            fx * (1.0 + e.focal_percent[0] * 0.01),
            fy * (1.0 + e.focal_percent[1] * 0.01),
            cx + e.principal_point_px[0],
            cy + e.principal_point_px[1],
        ];
        let mut distortion = c.distortion.clone();
        if !e.distortion.is_empty() {
            if e.distortion.len() != distortion.len() {
                return Err(self.error(
                    &format!("rig.cameras[{i}].intrinsics_error.distortion"),
                    format!(
                        "expected {} offsets (one per distortion coefficient) or none, got {}",
                        distortion.len(),
                        e.distortion.len()
                    ),
                ));
            }
            for (d, de) in distortion.iter_mut().zip(&e.distortion) {
                *d += de;
            }
        }
        self.camera_model_with(i, intrinsics, &distortion)
    }

    /// Camera `i`'s model with the given intrinsics and distortion.
    fn camera_model_with(
        &self,
        i: usize,
        [fx, fy, cx, cy]: [f64; 4],
        d: &[f64],
    ) -> Result<Arc<dyn CameraModel>, SpecError> {
        let c = &self.spec.rig.cameras[i];
        let key = |k: &str| format!("rig.cameras[{i}].{k}");
        let [w, h] = c.resolution;
        let need_d = |n: usize, what: &str| -> Result<(), SpecError> {
            if d.len() == n {
                Ok(())
            } else {
                Err(self.error(
                    &key("distortion"),
                    format!("expected {n} coefficients {what}, got {}", d.len()),
                ))
            }
        };
        let need = |v: Option<f64>, k: &str| {
            v.ok_or_else(|| {
                self.error(
                    &key(k),
                    format!("missing: the {} model needs `{k}`", serde_name(c.model)),
                )
            })
        };
        let forbid = |v: Option<f64>, k: &str| -> Result<(), SpecError> {
            match v {
                Some(_) => Err(self.error(
                    &key(k),
                    format!("not used by the {} model: remove it", serde_name(c.model)),
                )),
                None => Ok(()),
            }
        };
        let cam_err = |e: CameraError| self.error(&key("intrinsics"), e.to_string());
        let cam = match c.model {
            ModelSpec::PinholeRadtan => {
                need_d(4, "[k1, k2, p1, p2]")?;
                forbid(c.xi, "xi")?;
                forbid(c.alpha, "alpha")?;
                Camera::PinholeRadtan(
                    PinholeRadtan::new(w, h, fx, fy, cx, cy, d[0], d[1], d[2], d[3])
                        .map_err(cam_err)?,
                )
            }
            ModelSpec::KannalaBrandt => {
                need_d(4, "[k1, k2, k3, k4]")?;
                forbid(c.xi, "xi")?;
                forbid(c.alpha, "alpha")?;
                Camera::KannalaBrandt(
                    KannalaBrandt::new(w, h, fx, fy, cx, cy, d[0], d[1], d[2], d[3])
                        .map_err(cam_err)?,
                )
            }
            ModelSpec::Mei => {
                need_d(4, "[k1, k2, p1, p2]")?;
                forbid(c.alpha, "alpha")?;
                let xi = need(c.xi, "xi")?;
                Camera::Mei(
                    Mei::new(w, h, xi, fx, fy, cx, cy, d[0], d[1], d[2], d[3]).map_err(cam_err)?,
                )
            }
            ModelSpec::DoubleSphere => {
                need_d(0, "(none)")?;
                let xi = need(c.xi, "xi")?;
                let alpha = need(c.alpha, "alpha")?;
                Camera::DoubleSphere(
                    DoubleSphere::new(w, h, fx, fy, cx, cy, xi, alpha).map_err(cam_err)?,
                )
            }
        };
        Ok(Arc::new(cam))
    }

    /// `T_b_c` of camera `i` (a quaternion as written:
    /// [`estimator::geometry::quat_from_xyzw_as_written`]).
    pub(super) fn extrinsic(&self, i: usize) -> Result<Pose, SpecError> {
        let e = &self.spec.rig.cameras[i].T_b_c;
        let key = format!("rig.cameras[{i}].T_b_c");
        let t = Vector3::from(e.translation_m);
        if !t.iter().all(|v| v.is_finite()) {
            return Err(self.error(&format!("{key}.translation_m"), "expected finite values"));
        }
        let q = match (e.rotation, e.quaternion_xyzw) {
            (Some(r), None) => {
                let m = Matrix3::from_fn(|a, b| r[a][b]);
                let ortho = (m.transpose() * m - Matrix3::identity()).amax();
                if !(ortho < 1e-3 && (m.determinant() - 1.0).abs() < 1e-3) {
                    return Err(self.error(
                        &format!("{key}.rotation"),
                        "expected a rotation matrix (orthonormal rows, determinant +1, to 1e-3)",
                    ));
                }
                UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix(&m))
            }
            (None, Some(q)) => {
                let quat = Quaternion::new(q[3], q[0], q[1], q[2]);
                let unit = (quat.norm() - 1.0).abs() < 1e-3; // false for NaN
                if !unit {
                    return Err(self.error(
                        &format!("{key}.quaternion_xyzw"),
                        "expected a unit quaternion [qx, qy, qz, qw] (norm 1 to 1e-3)",
                    ));
                }
                estimator::geometry::quat_from_xyzw_as_written(&q)
            }
            _ => {
                return Err(self.error(
                    &key,
                    "expected exactly one of `rotation` (3×3 rows) or `quaternion_xyzw`",
                ));
            }
        };
        Ok(Pose::new(q, t))
    }

    /// Fault `i` in sim form.
    pub(super) fn fault(&self, i: usize) -> Result<Fault, SpecError> {
        let f = &self.spec.faults[i];
        let key = |k: &str| format!("faults[{i}].{k}");
        let ns = |s: f64| (s * 1e9).round() as i64;
        // (present, name) of every optional key, to reject keys the kind does not take.
        let present: [(&str, bool); 15] = [
            ("start_s", f.start_s.is_some()),
            ("end_s", f.end_s.is_some()),
            ("at_s", f.at_s.is_some()),
            ("cam_id", f.cam_id.is_some()),
            ("black_frames", f.black_frames.is_some()),
            ("probability", f.probability.is_some()),
            ("gyro_rad_s", f.gyro_rad_s.is_some()),
            ("accel_m_s2", f.accel_m_s2.is_some()),
            ("gyro_range_rad_s", f.gyro_range_rad_s.is_some()),
            ("accel_range_m_s2", f.accel_range_m_s2.is_some()),
            ("imu_sigma_s", f.imu_sigma_s.is_some()),
            ("camera_sigma_s", f.camera_sigma_s.is_some()),
            ("td_s", f.td_s.is_some()),
            ("offset_m", f.offset_m.is_some()),
            ("slip_ratio", f.slip_ratio.is_some()),
        ];
        let (required, optional): (&[&str], &[&str]) = match f.kind {
            FaultKind::CameraBlackout => (&["start_s", "end_s"], &["black_frames"]),
            FaultKind::CameraDeath => (&["cam_id", "at_s"], &[]),
            FaultKind::CameraFreeze => (&["start_s", "end_s"], &["cam_id"]),
            FaultKind::FrameDrops => (&["start_s", "end_s", "probability"], &[]),
            FaultKind::ImuDropout => (&["start_s", "end_s"], &[]),
            FaultKind::ImuSpikes => (
                &[
                    "start_s",
                    "end_s",
                    "probability",
                    "gyro_rad_s",
                    "accel_m_s2",
                ],
                &[],
            ),
            FaultKind::ImuSaturation => (
                &["start_s", "end_s", "gyro_range_rad_s", "accel_range_m_s2"],
                &[],
            ),
            FaultKind::TimestampJitter => {
                (&["start_s", "end_s"], &["imu_sigma_s", "camera_sigma_s"])
            }
            FaultKind::CameraTimeOffset => (&["at_s", "td_s"], &[]),
            FaultKind::GnssOutage => (&["start_s", "end_s"], &[]),
            FaultKind::GnssBiasJump => (&["at_s", "offset_m"], &[]),
            FaultKind::WheelSlip => (&["start_s", "end_s", "slip_ratio"], &[]),
        };
        for (name, p) in present {
            let req = required.contains(&name);
            if req && !p {
                return Err(self.error(
                    &key(name),
                    format!("missing: a {} fault needs `{name}`", serde_name(f.kind)),
                ));
            }
            if p && !req && !optional.contains(&name) {
                return Err(self.error(
                    &key(name),
                    format!(
                        "not used by a {} fault (it takes {})",
                        serde_name(f.kind),
                        required
                            .iter()
                            .chain(optional)
                            .copied()
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                ));
            }
        }
        let (start, end) = (f.start_s.unwrap_or(0.0), f.end_s.unwrap_or(0.0));
        if f.start_s.is_some() && !(start.is_finite() && end.is_finite() && end > start) {
            return Err(self.error(&key("end_s"), "expected finite start_s < end_s"));
        }
        let limit = sim::limits::MAX_DURATION_S;
        for (name, v) in [("start_s", f.start_s), ("end_s", f.end_s), ("at_s", f.at_s)] {
            if let Some(v) = v
                && !(v.is_finite() && (0.0..=limit).contains(&v))
            {
                return Err(self.error(
                    &key(name),
                    format!("expected a time in [0, {limit}] s, got {v}"),
                ));
            }
        }
        if let Some(p) = f.probability
            && !(0.0..=1.0).contains(&p)
        {
            return Err(self.error(&key("probability"), "expected a probability in [0, 1]"));
        }
        for (name, v, lo, hi) in [
            ("gyro_rad_s", f.gyro_rad_s, 0.0, 1e3),
            ("accel_m_s2", f.accel_m_s2, 0.0, 1e4),
            ("imu_sigma_s", f.imu_sigma_s, 0.0, 0.1),
            ("camera_sigma_s", f.camera_sigma_s, 0.0, 0.1),
            ("td_s", f.td_s, -1.0, 1.0),
            ("slip_ratio", f.slip_ratio, -1.0, 10.0),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v >= lo && v <= hi)
            {
                return Err(self.error(
                    &key(name),
                    format!("expected a finite number in [{lo}, {hi}], got {v}"),
                ));
            }
        }
        for name in ["gyro_range_rad_s", "accel_range_m_s2"] {
            let v = if name.starts_with("gyro") {
                f.gyro_range_rad_s
            } else {
                f.accel_range_m_s2
            };
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0)
            {
                return Err(self.error(&key(name), format!("expected a finite range > 0, got {v}")));
            }
        }
        if let Some(c) = f.cam_id
            && c >= self.spec.rig.cameras.len()
        {
            return Err(self.error(
                &key("cam_id"),
                format!("expected a camera index < {}", self.spec.rig.cameras.len()),
            ));
        }
        if let Some(o) = f.offset_m
            && !o.iter().all(|x| x.is_finite() && x.abs() <= 1e4)
        {
            return Err(self.error(
                &key("offset_m"),
                format!("expected finite offsets within ±10 km, got {o:?}"),
            ));
        }
        let (start_ns, end_ns) = (ns(start), ns(end));
        let fault = match f.kind {
            FaultKind::GnssOutage => Fault::GnssOutage { start_ns, end_ns },
            FaultKind::GnssBiasJump => Fault::GnssBiasJump {
                at_ns: ns(f.at_s.unwrap_or(0.0)),
                offset_m: Vector3::from(f.offset_m.unwrap_or_default()),
            },
            FaultKind::WheelSlip => Fault::WheelSlip {
                start_ns,
                end_ns,
                slip_ratio: f.slip_ratio.unwrap_or(0.0),
            },
            FaultKind::CameraBlackout => Fault::CameraBlackout {
                start_ns,
                end_ns,
                black_frames: f.black_frames.unwrap_or(false),
            },
            FaultKind::CameraDeath => Fault::CameraDeath {
                cam_id: f.cam_id.unwrap_or(0),
                at_ns: ns(f.at_s.unwrap_or(0.0)),
            },
            FaultKind::CameraFreeze => Fault::CameraFreeze {
                cam_id: f.cam_id,
                start_ns,
                end_ns,
            },
            FaultKind::FrameDrops => Fault::FrameDrops {
                start_ns,
                end_ns,
                probability: f.probability.unwrap_or(0.0),
            },
            FaultKind::ImuDropout => Fault::ImuDropout { start_ns, end_ns },
            FaultKind::ImuSpikes => Fault::ImuSpikes {
                start_ns,
                end_ns,
                probability: f.probability.unwrap_or(0.0),
                gyro: f.gyro_rad_s.unwrap_or(0.0),
                accel: f.accel_m_s2.unwrap_or(0.0),
            },
            FaultKind::ImuSaturation => Fault::ImuSaturation {
                start_ns,
                end_ns,
                gyro_range: f.gyro_range_rad_s.unwrap_or(f64::INFINITY),
                accel_range: f.accel_range_m_s2.unwrap_or(f64::INFINITY),
            },
            FaultKind::TimestampJitter => Fault::TimestampJitter {
                start_ns,
                end_ns,
                imu_sigma_ns: f.imu_sigma_s.unwrap_or(0.0) * 1e9,
                camera_sigma_ns: f.camera_sigma_s.unwrap_or(0.0) * 1e9,
            },
            FaultKind::CameraTimeOffset => Fault::CameraTimeOffset {
                start_ns: ns(f.at_s.unwrap_or(0.0)),
                td_ns: ns(f.td_s.unwrap_or(0.0)),
            },
        };
        fault
            .validate()
            .map_err(|e| self.error(&format!("faults[{i}]"), e.to_string()))?;
        Ok(fault)
    }

    /// Fault intervals `(kind, start s, end s)` for reports and plots (permanent faults end at
    /// infinity).
    pub fn fault_intervals(&self) -> Vec<(String, f64, f64)> {
        self.spec
            .faults
            .iter()
            .map(|f| {
                let name = serde_name(f.kind);
                match (f.start_s, f.end_s, f.at_s) {
                    (Some(a), Some(b), _) => (name, a, b),
                    (_, _, Some(a)) => (name, a, f64::INFINITY),
                    _ => (name, 0.0, 0.0),
                }
            })
            .collect()
    }

    /// The trajectory configuration (reads and fits a replayed file).
    pub(super) fn trajectory(&self) -> Result<TrajectoryConfig, SpecError> {
        let t = &self.spec.trajectory;
        let v = Vector3::from;
        if let Some(f) = t.figure_eight {
            return Ok(TrajectoryConfig::Lissajous(Lissajous::figure_eight(
                v(f.center),
                f.half_width_m,
                f.half_height_m,
                f.period_s,
            )));
        }
        if let Some(g) = t.ground_vehicle {
            return Ok(TrajectoryConfig::Reference(std::sync::Arc::new(
                sim::motion::GroundVehicle {
                    center: v(g.center),
                    half_width_m: g.half_width_m,
                    half_height_m: g.half_height_m,
                    period_s: g.period_s,
                },
            )));
        }
        if let Some(c) = t.circle {
            return Ok(TrajectoryConfig::Lissajous(Lissajous::circle(
                v(c.center),
                c.radius_m,
                c.period_s,
            )));
        }
        if let Some(l) = t.lissajous {
            return Ok(TrajectoryConfig::Lissajous(Lissajous {
                center: v(l.center),
                amplitude: v(l.amplitude_m),
                freq_hz: v(l.freq_hz),
                phase: v(l.phase_rad),
                yaw0: l.yaw0_rad,
                yaw_rate: l.yaw_rate_rad_s,
                yaw_amplitude: l.yaw_amplitude_rad,
                yaw_freq_hz: l.yaw_freq_hz,
                tilt_amplitude: l.tilt_amplitude_rad,
                tilt_freq_hz: l.tilt_freq_hz,
                duration_s: None,
            }));
        }
        if let Some(w) = t.waypoints {
            return Ok(TrajectoryConfig::Waypoints(RandomWaypoints {
                min: v(w.min),
                max: v(w.max),
                spacing_s: w.spacing_s,
                max_yaw_step: w.max_yaw_step_rad,
                max_tilt: w.max_tilt_rad,
                duration_s: t.duration_s,
            }));
        }
        let r = self
            .recording
            .as_ref()
            .ok_or_else(|| self.error("trajectory", "no motion given"))?;
        Ok(TrajectoryConfig::Reference(Arc::new(r.0.clone())))
    }

    /// Reads, checks and fits a replayed recording (`trajectory.replay`); `None` for generated
    /// motions.
    pub(super) fn load_recording(&self) -> Result<Option<(Replay, RecordingReport)>, SpecError> {
        let Some(r) = &self.spec.trajectory.replay else {
            return Ok(None);
        };
        let key = "trajectory.replay.file";
        let text = self.data_file(key, &r.file)?;
        let d = RecordingOptions::default();
        let options = RecordingOptions {
            time_unit: r.time_unit.map(|u| match u {
                TimeUnitSpec::Seconds => TimeUnit::Seconds,
                TimeUnitSpec::Milliseconds => TimeUnit::Milliseconds,
                TimeUnitSpec::Microseconds => TimeUnit::Microseconds,
                TimeUnitSpec::Nanoseconds => TimeUnit::Nanoseconds,
            }),
            repair: r.repair,
            knot_spacing_s: r.knot_spacing_s.unwrap_or(d.knot_spacing_s),
            fit_tolerance_m: r.fit_tolerance_m.unwrap_or(d.fit_tolerance_m),
            fit_tolerance_rad: r
                .fit_tolerance_deg
                .map_or(d.fit_tolerance_rad, f64::to_radians),
            placement: r.placement.map(|p| {
                (
                    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), p.yaw_deg.to_radians()),
                    Vector3::from(p.translation_m),
                )
            }),
        };
        load_recording(&text, &options)
            .map(Some)
            .map_err(|e| self.error(key, format!("in {}: {e}", r.file)))
    }

    /// Reads a data file named in the scenario: relative to the scenario file, or embedded for
    /// catalog scenarios.
    pub(super) fn data_file(&self, key: &str, rel: &str) -> Result<String, SpecError> {
        self.origin.read(rel).map_err(|m| self.error(key, m))
    }

    /// The simulator configuration; `seed` overrides `world.seed`, `duration_s` the
    /// trajectory's duration.
    pub fn world_config(
        &self,
        seed: Option<u64>,
        duration_s: Option<f64>,
    ) -> Result<WorldConfig, SpecError> {
        let s = &self.spec;
        let imu = &s.rig.imu;
        let scene = self.scene_config();
        let mut cameras = Vec::new();
        for (i, c) in s.rig.cameras.iter().enumerate() {
            let mut sc = SimCamera::new(
                c.name.as_deref().unwrap_or(&format!("cam{i}")),
                self.models[i].clone(),
                self.extrinsic(i)?,
            );
            sc.pixel_sigma = c.pixel_sigma_px;
            sc.tracker_error = self.tracker_error_model(i)?;
            if let Some(v) = c.max_features {
                sc.max_features = v;
            }
            if let Some(v) = c.min_depth_m {
                sc.min_depth = v;
            }
            if let Some(v) = c.max_depth_m {
                sc.max_depth = v;
            }
            sc.max_track_length = c.max_track_length;
            if let Some(r) = &c.rolling_shutter {
                sc.rolling_shutter = r.readout();
            }
            cameras.push(sc);
        }
        let rig = RigConfig {
            cameras,
            rate_hz: s.rig.rate_hz,
            td_ns: (s.rig.time_offset_s * 1e9).round() as i64,
            reseed: s.rig.reseed,
            track_ids: match s.rig.track_ids {
                TrackIdsSpec::Realistic => TrackIds::Realistic,
                TrackIdsSpec::Landmark => TrackIds::Landmark,
            },
        };
        let imu_cfg = ImuConfig {
            name: "imu".into(),
            rate_hz: imu.rate_hz,
            window: ImuWindow::Centered,
            noise: (!imu.noise_free).then(|| self.imu_noise()),
            initial_gyro_bias: Vector3::from(imu.initial_gyro_bias_rad_s),
            initial_accel_bias: Vector3::from(imu.initial_accel_bias_m_s2),
            gyro_matrix: Matrix3::identity(),
            accel_matrix: Matrix3::identity(),
            gyro_range: imu.gyro_range_rad_s,
            accel_range: imu.accel_range_m_s2,
            vibration: self.imu_error_model().and_then(|m| m.vibration.clone()),
            bias_instability: self.imu_error_model().and_then(|m| m.bias_instability),
        };
        let faults = (0..s.faults.len())
            .map(|i| self.fault(i))
            .collect::<Result<Vec<_>, _>>()?;
        let duration = duration_s.unwrap_or(s.trajectory.duration_s);
        // Physics at ≥ 1 kHz with a step that divides the IMU period.
        let period = imu_cfg.period_ns();
        let steps = (1..=20u32)
            .find(|n| period % i64::from(*n) == 0 && period / i64::from(*n) <= 1_000_000)
            .unwrap_or(1);
        let config = WorldConfig {
            seed: seed.unwrap_or(s.world.seed),
            duration_s: duration,
            trajectory: self.trajectory()?,
            static_start: s.trajectory.static_start.map(|ss| StaticStartConfig {
                hold_s: ss.hold_s,
                ramp_s: ss.ramp_s,
            }),
            stops: s
                .trajectory
                .stops
                .iter()
                .map(|st| sim::motion::Stop {
                    at_s: st.at_s,
                    duration_s: st.duration_s,
                    ramp_s: st.ramp_s,
                })
                .collect(),
            physics_steps_per_imu: steps,
            imu: imu_cfg,
            scene,
            rig: Some(rig),
            gnss: s.rig.gnss.map(|g| sim::aiding_sensors::GnssConfig {
                rate_hz: g.rate_hz,
                sigma_m: Vector3::from(g.sigma_m),
                lever_arm_b: Vector3::from(g.lever_arm_m),
                ..Default::default()
            }),
            wheel: s.rig.wheel.map(|w| sim::aiding_sensors::WheelConfig {
                rate_hz: w.rate_hz,
                sigma_m_s: w.sigma_m_s,
                ..Default::default()
            }),
            faults,
            recorded_imu: self.recorded_imu.as_ref().map(|r| r.log.clone()),
            ..WorldConfig::default()
        };
        // A duration asked for beyond the motion's end (a replayed recording, with its static
        // start and stops) would silently be cut to it: refused instead.
        if let Some(asked) = duration_s
            && let Some(end) = sim::reference_motion(&config)
                .map_err(|e| self.error("trajectory", e.to_string()))?
                .duration()
            && asked > end + 1e-6
        {
            return Err(self.error(
                "trajectory.duration_s",
                format!(
                    "a duration of {asked} s was asked for (--duration), beyond the end of the scenario's motion at {end:.3} s (a replayed recording's length, or a generated motion's own duration), which the run would be cut to: ask for at most {end:.3} s, or leave the duration to the scenario"
                ),
            ));
        }
        Ok(config)
    }

    /// The scene preset and landmark density.
    pub fn scene_config(&self) -> SceneConfig {
        let w = &self.spec.world;
        SceneConfig {
            preset: match w.scene {
                SceneSpec::Room => ScenePreset::Room,
                SceneSpec::MachineHall => ScenePreset::MachineHall,
                SceneSpec::Outdoor => ScenePreset::Outdoor,
            },
            landmark_density: w
                .landmark_density
                .unwrap_or(SceneConfig::default().landmark_density),
        }
    }

    /// The IMU noise densities of the file (what the estimator assumes).
    pub fn imu_noise(&self) -> ImuNoise {
        let imu = &self.spec.rig.imu;
        ImuNoise {
            gyroscope_noise_density: imu.gyroscope_noise_density,
            accelerometer_noise_density: imu.accelerometer_noise_density,
            gyroscope_random_walk: imu.gyroscope_random_walk,
            accelerometer_random_walk: imu.accelerometer_random_walk,
        }
    }

    /// The extrinsic the estimator starts from for camera `i`: the true one with the camera's
    /// `calibration_error` applied.
    pub(super) fn estimator_extrinsic(&self, i: usize) -> Result<Pose, SpecError> {
        let t = self.extrinsic(i)?;
        Ok(match &self.spec.rig.cameras[i].calibration_error {
            None => t,
            Some(e) => {
                let phi = nalgebra::Vector3::from(e.rotation_deg).map(f64::to_radians);
                Pose::new(
                    estimator::geometry::so3_exp(&phi) * t.q,
                    t.p + nalgebra::Vector3::from(e.translation_m),
                )
            }
        })
    }

    /// The true calibration the estimator may estimate, when the scenario studies it (a
    /// calibration error, a camera time offset, or online estimation switched on): the
    /// camera-IMU time offset, with the steps of its `camera_time_offset` faults, and each used
    /// camera's `T_b_c`.
    pub fn calibration_truth(&self) -> Option<CalibrationTruth> {
        let s = &self.spec;
        // The offset steps as the simulator applies them.
        let td_steps: Vec<(i64, f64)> = (0..s.faults.len())
            .filter_map(|i| match self.fault(i).ok()? {
                Fault::CameraTimeOffset { start_ns, td_ns } => Some((start_ns, td_ns as f64 / 1e9)),
                _ => None,
            })
            .collect();
        // Without an IMU the offset is never a variable (vision alone cannot tell it).
        let with_imu = s.suite.suite().uses_imu();
        let studied = (self.settings.estimate_td && with_imu)
            || self.settings.estimate_extrinsics
            || s.rig.time_offset_s != 0.0
            || !td_steps.is_empty()
            || s.rig.cameras.iter().any(|c| c.calibration_error.is_some())
            || s.rig.calibration_draw.is_some();
        if !studied {
            return None;
        }
        let used = s.suite.suite().cameras().min(s.rig.cameras.len());
        let t_b_c = (0..used)
            .map(|i| self.extrinsic(i))
            .collect::<Result<_, _>>()
            .ok()?;
        Some(CalibrationTruth {
            td_s: s.rig.time_offset_s,
            td_steps,
            T_b_c: t_b_c,
        })
    }

    /// The estimator configuration: the `[estimator]` settings with the same camera models and
    /// extrinsics the simulator uses, and the rig's IMU noise and ranges.
    pub fn estimator_config(&self) -> Result<EstimatorConfig, SpecError> {
        let s = &self.spec;
        let mut cameras = Vec::new();
        let used = s.suite.suite().cameras();
        for (i, c) in s.rig.cameras.iter().enumerate().take(used) {
            cameras.push(EstCamera {
                model: match c.intrinsics_error {
                    None => self.models[i].clone(),
                    Some(_) => self.estimator_camera_model(i)?,
                },
                T_b_c: self.estimator_extrinsic(i)?,
                // Below half a pixel the noise model would trust the simulated corner more
                // than any real one; `estimator.pixel_sigma_px` overrides it.
                pixel_sigma: c.pixel_sigma_px.max(0.5),
                rolling_shutter: c
                    .rolling_shutter
                    .map_or(estimator::camera::RollingShutter::GLOBAL, |r| r.readout()),
            });
        }
        let mut cfg = EstimatorConfig {
            suite: s.suite.suite(),
            cameras,
            imu_noise: self.imu_noise(),
            ..self.settings.clone()
        };
        // The antenna's lever arm is part of the rig.
        if let Some(g) = s.rig.gnss {
            cfg.gnss.lever_arm_m = g.lever_arm_m;
        }
        // The IMU's datasheet ranges: the estimator treats readings on them as clipped.
        let imu = &s.rig.imu;
        if cfg.imu_range.is_none()
            && (imu.gyro_range_rad_s.is_some() || imu.accel_range_m_s2.is_some())
        {
            cfg.imu_range = Some((
                imu.gyro_range_rad_s.unwrap_or(f64::INFINITY),
                imu.accel_range_m_s2.unwrap_or(f64::INFINITY),
            ));
        }
        Ok(cfg)
    }
}

impl Origin {
    /// The name errors use for the file of a scenario called `name`: `catalog:NAME`, or the
    /// file's path.
    pub(super) fn label(&self, name: &str) -> String {
        match self {
            Origin::Catalog | Origin::CatalogBeside(_) => format!("catalog:{name}"),
            Origin::File(p) => p.display().to_string(),
        }
    }

    /// Where a data file named `rel` in the scenario lives: relative to the scenario file, or
    /// as the catalog's embedded path.
    pub(super) fn path_of(&self, rel: &str) -> std::path::PathBuf {
        match self {
            Origin::Catalog => std::path::PathBuf::from(rel),
            Origin::CatalogBeside(_) if catalog::data(rel).is_some() => {
                std::path::PathBuf::from(rel)
            }
            Origin::File(p) | Origin::CatalogBeside(p) => {
                p.parent().unwrap_or(Path::new(".")).join(rel)
            }
        }
    }

    /// The text of data file `rel` ([`Origin::path_of`]; embedded for catalog scenarios); the
    /// error says which file and why.
    pub(super) fn read(&self, rel: &str) -> Result<String, String> {
        let embedded = match self {
            Origin::Catalog | Origin::CatalogBeside(_) => catalog::data(rel),
            Origin::File(_) => None,
        };
        if let Some(text) = embedded {
            return Ok(text);
        }
        let beside = match self {
            Origin::Catalog => return Err(format!("no embedded catalog data file `{rel}`")),
            Origin::File(_) => "the scenario file",
            Origin::CatalogBeside(_) => "the sweep file, not being catalog data",
        };
        let path = self.path_of(rel);
        // Bytes that are not UTF-8 (a Latin-1 comment) are replaced, not refused: the data
        // files' numbers are ASCII.
        sim::input_file::read(&path)
            .map(|b| String::from_utf8_lossy(&b).into_owned())
            .map_err(|e| format!("cannot read {} (relative to {beside}): {e}", path.display()))
    }
}
