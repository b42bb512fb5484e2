//! GNSS and wheel-odometry settings (`[estimator.gnss]`, `[estimator.wheel]`).

use super::error::{ConfigError, positive};

/// GNSS settings (`[estimator.gnss]`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GnssConfig {
    /// Antenna position in the body frame (m). A scenario sets it from its `[rig.gnss]`.
    pub lever_arm_m: [f64; 3],
    /// Largest time between a fix and the frame it is attached to (s). Two frame periods at
    /// 20 Hz: when the frame a fix fell on leaves the window as a non-keyframe, the fix
    /// re-attaches to a neighbour instead of being lost (30 ms kept about one fix in three, the
    /// keyframes': global RMSE 0.107 / 0.117 m against 0.061 / 0.076 m at 100 ms, seeds 1, 2).
    pub max_dt_s: f64,
    /// The acceleration (m/s²) the constant-velocity carry of a fix to its frame may miss: it
    /// adds `½·a·dt²` in quadrature to the fix's σ (1 cm at 100 ms and 2 m/s²).
    pub carry_accel_m_s2: f64,
    /// Huber threshold of the fixes, in standard deviations (a bias jump or multipath).
    pub huber_sigmas: f64,
    /// Fewest fixes before the alignment is initialized.
    pub align_min_fixes: usize,
    /// Smallest horizontal RMS spread (m) of the estimated antenna positions of those fixes
    /// around their mean: the yaw is known to about `σ / (spread·√N)`.
    pub align_min_spread_m: f64,
    /// The initial alignment's standard deviations are its least-squares ones times this (the
    /// odometry drifts while the fixes are collected).
    pub align_sigma_inflation: f64,
    /// Most fix/estimate pairs kept for the alignment (the oldest go first).
    pub align_max_fixes: usize,
    /// A fix whose whitened error against the window's estimate before the solve exceeds this
    /// norm is not used (5: a 3-dof χ² tail of 1e-5; a bias jump or multipath).
    pub gate_sigmas: f64,
    /// After this many rejected fixes in a row the receiver's frame is taken to have moved (a
    /// bias jump, a new reference station): the alignment is marginalized out of the prior and
    /// initialized again from the fixes that follow.
    pub realign_after_rejections: usize,
}

impl Default for GnssConfig {
    fn default() -> Self {
        Self {
            lever_arm_m: [0.0; 3],
            max_dt_s: 0.1,
            carry_accel_m_s2: 2.0,
            huber_sigmas: 3.0,
            align_min_fixes: 20,
            align_min_spread_m: 5.0,
            align_sigma_inflation: 2.0,
            align_max_fixes: 2000,
            gate_sigmas: 5.0,
            realign_after_rejections: 20,
        }
    }
}

/// Wheel-odometry settings (`[estimator.wheel]`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WheelConfig {
    /// σ of the forward speed (m/s).
    pub speed_sigma_m_s: f64,
    /// σ of the lateral and vertical body velocity, the non-holonomic constraint (m/s).
    pub lateral_sigma_m_s: f64,
    /// Huber threshold, in standard deviations (wheel slip).
    pub huber_sigmas: f64,
    /// Largest gap (s) between the two readings a frame's speed is interpolated from.
    pub max_gap_s: f64,
    /// A frame's wheel factor is left out while its whitened error at the window's current
    /// estimate exceeds this norm (wheel slip: the window's other sensors disagree).
    pub gate_sigmas: f64,
}

impl Default for WheelConfig {
    fn default() -> Self {
        Self {
            speed_sigma_m_s: 0.05,
            lateral_sigma_m_s: 0.05,
            huber_sigmas: 3.0,
            max_gap_s: 0.1,
            gate_sigmas: 5.0,
        }
    }
}

impl GnssConfig {
    /// Range checks, naming the field.
    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        if !self.lever_arm_m.iter().all(|x| x.is_finite()) {
            return Err(ConfigError::new(
                "gnss.lever_arm_m",
                "expected finite numbers",
            ));
        }
        for (k, v) in [
            ("gnss.max_dt_s", self.max_dt_s),
            ("gnss.huber_sigmas", self.huber_sigmas),
            ("gnss.align_min_spread_m", self.align_min_spread_m),
            ("gnss.align_sigma_inflation", self.align_sigma_inflation),
            ("gnss.gate_sigmas", self.gate_sigmas),
            ("gnss.carry_accel_m_s2", self.carry_accel_m_s2),
        ] {
            positive(k, v)?;
        }
        if self.align_min_fixes < 2 || self.align_max_fixes < self.align_min_fixes {
            return Err(ConfigError::new(
                "gnss.align_min_fixes",
                format!(
                    "expected 2 ≤ align_min_fixes ≤ align_max_fixes, got {} and {}",
                    self.align_min_fixes, self.align_max_fixes
                ),
            ));
        }
        if self.realign_after_rejections < 1 {
            return Err(ConfigError::new(
                "gnss.realign_after_rejections",
                "expected at least 1",
            ));
        }
        Ok(())
    }
}

impl WheelConfig {
    /// Range checks, naming the field.
    pub(super) fn validate(&self) -> Result<(), ConfigError> {
        for (k, v) in [
            ("wheel.speed_sigma_m_s", self.speed_sigma_m_s),
            ("wheel.lateral_sigma_m_s", self.lateral_sigma_m_s),
            ("wheel.huber_sigmas", self.huber_sigmas),
            ("wheel.max_gap_s", self.max_gap_s),
            ("wheel.gate_sigmas", self.gate_sigmas),
        ] {
            positive(k, v)?;
        }
        Ok(())
    }
}
