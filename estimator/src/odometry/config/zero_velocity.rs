//! Zero-velocity detection settings (`[estimator.zero_velocity]`).

/// Zero-velocity detection settings (`[estimator.zero_velocity]`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ZeroVelocityConfig {
    /// Detect rest and add zero-velocity factors (IMU suites). Off by default: on the
    /// catalog's stops it neither helped nor hurt measurably (ATE within 0.1 mm, seeds 1–3), and
    /// a detector that is wrong once costs far more than it gains; turn it on for a platform
    /// known to stop.
    pub enabled: bool,
    /// Time span (s) over which the IMU and the images must show rest.
    pub window_s: f64,
    /// Largest mean bias-corrected gyroscope rate at rest (rad/s).
    pub max_rate_rad_s: f64,
    /// The IMU spread tests' quantile, in standard normal deviations.
    pub chi2_z: f64,
    /// Largest median feature displacement at rest, in pixel σ.
    pub image_motion_sigmas: f64,
    /// Standard deviation of the zero-velocity constraint (m/s).
    pub velocity_sigma_m_s: f64,
    /// Largest speed of the newest frame's predicted state (m/s) at which it may be declared at
    /// rest. Over `window_s` the sensors cannot tell rest from a slow straight creep (3 cm/s at
    /// 3 m moves a 458 px image by 0.8 px in 0.25 s, inside the pixel noise); the window's own
    /// velocity can. Two `velocity_sigma_m_s`: slower than that, a zero-velocity factor is
    /// consistent with the motion anyway. (A 400 s figure-eight, about 3 cm/s, was called at
    /// rest on every frame without this check: 7 resets, ATE 0.20 m against 0.012 m.)
    pub max_speed_m_s: f64,
    /// Declare rest from the IMU alone when no camera delivers features.
    pub imu_only_when_blind: bool,
}

impl Default for ZeroVelocityConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            window_s: 0.25,
            max_rate_rad_s: 0.01,
            chi2_z: 3.0,
            image_motion_sigmas: 2.5,
            velocity_sigma_m_s: 0.005,
            max_speed_m_s: 0.01,
            imu_only_when_blind: false,
        }
    }
}
