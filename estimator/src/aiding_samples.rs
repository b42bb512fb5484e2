//! Measurements of the aiding sensors the estimator fuses besides the cameras and the IMU: a
//! GNSS-like position receiver and wheel odometry (see [`crate::factors::GnssPositionFactor`]
//! and [`crate::factors::BodyVelocityFactor`]).

use nalgebra::Vector3;

/// One position fix of a GNSS-like receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssSample {
    /// Time of the fix (ns, IMU clock).
    pub t_ns: i64,
    /// Antenna position in the receiver's local frame (m; gravity-aligned, z up, e.g. ENU
    /// around a reference point).
    pub p_g: Vector3<f64>,
    /// The receiver's reported standard deviation per axis (m).
    pub sigma_m: Vector3<f64>,
}

/// One wheel-odometry reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WheelSample {
    /// Time of the reading (ns, IMU clock).
    pub t_ns: i64,
    /// Forward speed of the vehicle (m/s; negative when reversing).
    pub speed_m_s: f64,
}

/// Why an aiding measurement was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum AidingError {
    /// A value is not finite, or a standard deviation is not positive.
    #[error("{sensor} sample at t_ns={t_ns}: {what}")]
    Invalid {
        /// `gnss` or `wheel`.
        sensor: &'static str,
        /// The sample's time.
        t_ns: i64,
        /// What is wrong.
        what: String,
    },
    /// Samples of one sensor must come in increasing time.
    #[error("{sensor} sample at t_ns={t_ns} does not follow the previous one at {prev_t_ns}")]
    NonIncreasing {
        /// `gnss` or `wheel`.
        sensor: &'static str,
        /// The rejected sample's time.
        t_ns: i64,
        /// The previous sample's time.
        prev_t_ns: i64,
    },
}

impl GnssSample {
    /// Checks that the fix is finite and its accuracy positive.
    pub fn validate(&self) -> Result<(), AidingError> {
        let bad = |what: String| AidingError::Invalid {
            sensor: "gnss",
            t_ns: self.t_ns,
            what,
        };
        if !self.p_g.iter().all(|x| x.is_finite()) {
            return Err(bad(format!(
                "non-finite position {:?}",
                self.p_g.as_slice()
            )));
        }
        if !self.sigma_m.iter().all(|s| s.is_finite() && *s > 0.0) {
            return Err(bad(format!(
                "expected standard deviations > 0, got {:?}",
                self.sigma_m.as_slice()
            )));
        }
        Ok(())
    }
}

impl WheelSample {
    /// Checks that the speed is finite.
    pub fn validate(&self) -> Result<(), AidingError> {
        if self.speed_m_s.is_finite() {
            Ok(())
        } else {
            Err(AidingError::Invalid {
                sensor: "wheel",
                t_ns: self.t_ns,
                what: format!("non-finite speed {}", self.speed_m_s),
            })
        }
    }
}
