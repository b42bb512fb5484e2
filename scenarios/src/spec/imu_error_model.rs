//! `rig.imu.error_model`: what a real IMU adds to the datasheet's white noise and random walk —
//! bias instability and platform vibration — from a built-in preset (`"euroc_mav"`) or a TOML
//! file (`vio imu-model --gt` writes one fitted to a recorded log).
//!
//! The file is checked at the door: unknown keys, wrong types, negative RMS values, bands
//! outside `(0, rate/2]` or upside down, lines above half the IMU rate, each refused with the
//! model file, its line and key, and the scenario key that named it.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use sim::bias_instability::BiasInstability;
use sim::vibration::{ActivityProxy, Vibration, VibrationBand, VibrationLine, VibrationProfile};

use super::error::deserialize_toml;
use super::named_model::BuiltIn;
use super::{Scenario, SpecError};
use crate::catalog;

/// The scenario key naming the model.
const KEY: &str = "rig.imu.error_model";

/// An IMU error model file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ImuErrorModelSpec {
    /// What the model is and where it came from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Bias instability (a Gauss–Markov wander of the bias).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias_instability: Option<BiasInstabilitySpec>,
    /// Platform vibration.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub vibration: Option<VibrationSpec>,
}

/// `[bias_instability]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BiasInstabilitySpec {
    /// Gyroscope Allan-deviation floor (rad/s).
    pub gyro_rad_s: f64,
    /// Accelerometer Allan-deviation floor (m/s²).
    pub accel_m_s2: f64,
    /// Correlation time of the wander (s).
    pub correlation_s: f64,
}

/// `[vibration]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct VibrationSpec {
    /// At or below this ground-truth speed the rest profile alone (m/s).
    pub speed_at_rest_m_s: f64,
    /// At or above this speed the flight profile alone (m/s).
    pub speed_in_flight_m_s: f64,
    /// Lag of the blend between the two (s).
    pub time_constant_s: f64,
    /// The platform at rest.
    #[serde(default)]
    pub rest: ProfileSpec,
    /// The platform moving.
    #[serde(default)]
    pub flight: ProfileSpec,
}

/// `[vibration.rest]` / `[vibration.flight]`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ProfileSpec {
    /// Band noise.
    #[serde(default)]
    pub bands: Vec<BandSpec>,
    /// Narrow lines.
    #[serde(default)]
    pub lines: Vec<LineSpec>,
}

/// One band.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct BandSpec {
    /// Lower edge (Hz).
    pub lo_hz: f64,
    /// Upper edge (Hz).
    pub hi_hz: f64,
    /// Gyroscope RMS in the band per axis (rad/s).
    pub gyro_rms_rad_s: [f64; 3],
    /// Accelerometer RMS in the band per axis (m/s²).
    pub accel_rms_m_s2: [f64; 3],
}

/// One line.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LineSpec {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Gyroscope RMS per axis (rad/s).
    pub gyro_rms_rad_s: [f64; 3],
    /// Accelerometer RMS per axis (m/s²).
    pub accel_rms_m_s2: [f64; 3],
}

/// A loaded error model: where it came from and the simulator's parts.
#[derive(Clone, Debug, PartialEq)]
pub struct ImuErrorModel {
    /// The preset name or the file as the scenario names it.
    pub source: String,
    /// The parsed file.
    pub spec: ImuErrorModelSpec,
    /// Bias instability for the simulator.
    pub bias_instability: Option<BiasInstability>,
    /// Vibration for the simulator.
    pub vibration: Option<Vibration>,
}

impl ImuErrorModelSpec {
    /// Parses and checks a model for an IMU at `rate_hz`; errors name `file`, line and key.
    pub fn parse(text: &str, file: &str, rate_hz: f64) -> Result<Self, SpecError> {
        let spec: Self = deserialize_toml(text, file)?;
        spec.check(rate_hz)
            .map_err(|(key, msg)| SpecError::at(file, text, &key, msg))?;
        Ok(spec)
    }

    fn check(&self, rate_hz: f64) -> Result<(), (String, String)> {
        let err = |k: String, m: String| Err((k, m));
        let non_negative = |k: String, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                err(k, format!("{v} must be finite and ≥ 0"))
            }
        };
        let positive = |k: String, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                err(k, format!("{v} must be finite and > 0"))
            }
        };
        if let Some(b) = &self.bias_instability {
            non_negative("bias_instability.gyro_rad_s".into(), b.gyro_rad_s)?;
            non_negative("bias_instability.accel_m_s2".into(), b.accel_m_s2)?;
            positive("bias_instability.correlation_s".into(), b.correlation_s)?;
        }
        let Some(v) = &self.vibration else {
            return Ok(());
        };
        non_negative("vibration.speed_at_rest_m_s".into(), v.speed_at_rest_m_s)?;
        non_negative(
            "vibration.speed_in_flight_m_s".into(),
            v.speed_in_flight_m_s,
        )?;
        if v.speed_in_flight_m_s < v.speed_at_rest_m_s {
            return err(
                "vibration.speed_in_flight_m_s".into(),
                format!(
                    "{} m/s is below speed_at_rest_m_s ({} m/s)",
                    v.speed_in_flight_m_s, v.speed_at_rest_m_s
                ),
            );
        }
        non_negative("vibration.time_constant_s".into(), v.time_constant_s)?;
        // A band's or line's per-axis RMS values, under the entry's keys.
        let rms_non_negative = |key: &dyn Fn(&str) -> String,
                                gyro: [f64; 3],
                                accel: [f64; 3]|
         -> Result<(), (String, String)> {
            for (k, x) in [("gyro_rms_rad_s", gyro), ("accel_rms_m_s2", accel)] {
                for (j, v) in x.iter().enumerate() {
                    non_negative(format!("{}[{j}]", key(k)), *v)?;
                }
            }
            Ok(())
        };
        let nyquist = rate_hz / 2.0;
        for (name, p) in [("rest", &v.rest), ("flight", &v.flight)] {
            for (i, b) in p.bands.iter().enumerate() {
                let key = |k: &str| format!("vibration.{name}.bands[{i}].{k}");
                non_negative(key("lo_hz"), b.lo_hz)?;
                if !(b.hi_hz.is_finite() && b.hi_hz > b.lo_hz && b.hi_hz <= nyquist) {
                    return err(
                        key("hi_hz"),
                        format!(
                            "{} Hz must lie above lo_hz ({} Hz) and at most at half the IMU rate ({nyquist} Hz)",
                            b.hi_hz, b.lo_hz
                        ),
                    );
                }
                rms_non_negative(&key, b.gyro_rms_rad_s, b.accel_rms_m_s2)?;
            }
            for (i, l) in p.lines.iter().enumerate() {
                let key = |k: &str| format!("vibration.{name}.lines[{i}].{k}");
                if !(l.freq_hz.is_finite() && l.freq_hz > 0.0 && l.freq_hz < nyquist) {
                    return err(
                        key("freq_hz"),
                        format!(
                            "{} Hz must lie in (0, {nyquist}) Hz: above zero and below half the IMU rate",
                            l.freq_hz
                        ),
                    );
                }
                rms_non_negative(&key, l.gyro_rms_rad_s, l.accel_rms_m_s2)?;
            }
        }
        Ok(())
    }

    /// The simulator's bias instability.
    pub fn bias_instability(&self) -> Option<BiasInstability> {
        self.bias_instability.as_ref().map(|b| BiasInstability {
            gyro_rad_s: b.gyro_rad_s,
            accel_m_s2: b.accel_m_s2,
            correlation_s: b.correlation_s,
        })
    }

    /// The simulator's vibration.
    pub fn vibration(&self) -> Option<Vibration> {
        let profile = |p: &ProfileSpec| VibrationProfile {
            bands: p
                .bands
                .iter()
                .map(|b| VibrationBand {
                    lo_hz: b.lo_hz,
                    hi_hz: b.hi_hz,
                    gyro_rms: Vector3::from(b.gyro_rms_rad_s),
                    accel_rms: Vector3::from(b.accel_rms_m_s2),
                })
                .collect(),
            lines: p
                .lines
                .iter()
                .map(|l| VibrationLine {
                    freq_hz: l.freq_hz,
                    gyro_rms: Vector3::from(l.gyro_rms_rad_s),
                    accel_rms: Vector3::from(l.accel_rms_m_s2),
                })
                .collect(),
        };
        self.vibration.as_ref().map(|v| Vibration {
            rest: profile(&v.rest),
            flight: profile(&v.flight),
            activity: ActivityProxy {
                speed_at_rest_m_s: v.speed_at_rest_m_s,
                speed_in_flight_m_s: v.speed_in_flight_m_s,
                time_constant_s: v.time_constant_s,
            },
        })
    }
}

impl Scenario {
    /// The IMU error model `rig.imu.error_model` names, read and checked; `None` without one.
    pub(super) fn load_imu_error_model(&self) -> Result<Option<ImuErrorModel>, SpecError> {
        let Some(value) = &self.spec.rig.imu.error_model else {
            return Ok(None);
        };
        if self.spec.rig.imu.noise_free {
            return Err(self.error(
                KEY,
                "a noise-free IMU has no error model: remove `error_model` (or `noise_free`)",
            ));
        }
        if self.spec.rig.imu.recorded.is_some() {
            return Err(self.error(
                KEY,
                "a recorded IMU log is replayed as recorded: remove `error_model` (or `recorded`)",
            ));
        }
        let (file, text) = self.named_model_text(
            KEY,
            value,
            &BuiltIn {
                kind: "IMU error model",
                get: catalog::imu_error_model,
                names: catalog::imu_error_model_names,
            },
        )?;
        let spec = ImuErrorModelSpec::parse(&text, &file, self.spec.rig.imu.rate_hz)
            .map_err(|e| self.error(KEY, format!("in the IMU error model: {e}")))?;
        Ok(Some(ImuErrorModel {
            source: value.clone(),
            bias_instability: spec.bias_instability(),
            vibration: spec.vibration(),
            spec,
        }))
    }

    /// The IMU error model (`rig.imu.error_model`), when the scenario has one.
    pub fn imu_error_model(&self) -> Option<&ImuErrorModel> {
        self.imu_error_model.as_deref()
    }
}
