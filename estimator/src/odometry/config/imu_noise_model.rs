//! `[estimator.imu_noise]`: the IMU noise model the estimator assumes, apart from the sensor's
//! own description (a datasheet, a `sensor.yaml`, a scenario's `[rig.imu]`).
//!
//! A sensor's datasheet densities describe it on a bench. On a vehicle the same sensor also
//! vibrates and its bias wanders, and an estimator handed the datasheet is overconfident (its
//! IMU χ² test then fires on a consistent estimate). Each key given here replaces the sensor's
//! value in the estimator's model; unset keys keep the sensor's. `vio imu-model --gt` measures
//! the values for a platform from a flight log.

use crate::bias_process::BiasProcess;
use crate::imu::ImuNoise;

/// The estimator's own IMU noise densities, each replacing the sensor's (Kalibr units).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImuNoiseModel {
    /// Gyroscope white noise density (rad/s/√Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyroscope_noise_density: Option<f64>,
    /// Accelerometer white noise density (m/s²/√Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accelerometer_noise_density: Option<f64>,
    /// Gyroscope bias random walk (rad/s²/√Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyroscope_random_walk: Option<f64>,
    /// Accelerometer bias random walk (m/s³/√Hz).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accelerometer_random_walk: Option<f64>,
    /// Gyroscope bias instability, its Allan-deviation floor (rad/s): with the two keys below,
    /// the biases wander as a Gauss–Markov process about a constant the estimator holds
    /// ([`crate::bias_process`]); the random walks above are then the sensor's own, beside it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gyroscope_bias_instability: Option<f64>,
    /// Accelerometer bias instability, its Allan-deviation floor (m/s²).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub accelerometer_bias_instability: Option<f64>,
    /// The bias instability's correlation time (s).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_correlation_time_s: Option<f64>,
}

impl ImuNoiseModel {
    /// The sensor's densities with every key set here replacing its own.
    pub fn applied_to(&self, sensor: ImuNoise) -> ImuNoise {
        ImuNoise {
            gyroscope_noise_density: self
                .gyroscope_noise_density
                .unwrap_or(sensor.gyroscope_noise_density),
            accelerometer_noise_density: self
                .accelerometer_noise_density
                .unwrap_or(sensor.accelerometer_noise_density),
            gyroscope_random_walk: self
                .gyroscope_random_walk
                .unwrap_or(sensor.gyroscope_random_walk),
            accelerometer_random_walk: self
                .accelerometer_random_walk
                .unwrap_or(sensor.accelerometer_random_walk),
        }
    }

    /// The biases' Gauss–Markov wander, when all three of its keys are set (the validation
    /// refuses one or two of them).
    pub fn bias_process(&self) -> Option<BiasProcess> {
        Some(BiasProcess::from_allan_floors(
            self.gyroscope_bias_instability?,
            self.accelerometer_bias_instability?,
            self.bias_correlation_time_s?,
        ))
    }

    /// The bias-instability keys set, of three.
    pub fn bias_process_keys_set(&self) -> usize {
        [
            self.gyroscope_bias_instability,
            self.accelerometer_bias_instability,
            self.bias_correlation_time_s,
        ]
        .iter()
        .filter(|v| v.is_some())
        .count()
    }

    /// No key set: the sensor's model as it is.
    pub fn is_empty(&self) -> bool {
        self.entries().iter().all(|(_, v)| v.is_none())
    }

    /// The keys set, by name, for range checks and messages.
    pub fn entries(&self) -> [(&'static str, Option<f64>); 7] {
        [
            ("gyroscope_noise_density", self.gyroscope_noise_density),
            (
                "accelerometer_noise_density",
                self.accelerometer_noise_density,
            ),
            ("gyroscope_random_walk", self.gyroscope_random_walk),
            ("accelerometer_random_walk", self.accelerometer_random_walk),
            (
                "gyroscope_bias_instability",
                self.gyroscope_bias_instability,
            ),
            (
                "accelerometer_bias_instability",
                self.accelerometer_bias_instability,
            ),
            ("bias_correlation_time_s", self.bias_correlation_time_s),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unset_keys_keep_the_sensors_values() {
        let sensor = ImuNoise::euroc();
        assert_eq!(ImuNoiseModel::default().applied_to(sensor), sensor);
        let m = ImuNoiseModel {
            accelerometer_noise_density: Some(0.02),
            ..ImuNoiseModel::default()
        };
        let got = m.applied_to(sensor);
        assert_eq!(got.accelerometer_noise_density, 0.02);
        assert_eq!(got.gyroscope_noise_density, sensor.gyroscope_noise_density);
        assert_eq!(got.gyroscope_random_walk, sensor.gyroscope_random_walk);
        assert_eq!(
            got.accelerometer_random_walk,
            sensor.accelerometer_random_walk
        );
    }
}
