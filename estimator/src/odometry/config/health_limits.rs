//! The limits of a plausible solved window (`[estimator.health]`).

/// Limits of a plausible solved state (defaults: VINS-Fusion's failure detection).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HealthLimits {
    /// Largest accelerometer bias norm (m/s²; VINS-Fusion: 2.5).
    pub max_accel_bias_m_s2: f64,
    /// Largest gyroscope bias norm (rad/s; VINS-Fusion: 1.0).
    pub max_gyro_bias_rad_s: f64,
    /// Largest distance between the newest frame's predicted and solved positions (m;
    /// VINS-Fusion: 5 m between consecutive frames).
    pub max_jump_m: f64,
    /// Largest angle between the newest frame's predicted and solved attitudes (deg;
    /// VINS-Fusion: 50°).
    pub max_rotation_jump_deg: f64,
    /// χ² test of the window's IMU factors: the window fails when the sum of their squared
    /// whitened residuals at the solution exceeds the χ² quantile of their degrees of freedom
    /// at this many standard normal deviations (Wilson–Hilferty); 4.75 ≈ one false alarm in a
    /// million consistent windows; infinite: off. Visual and inertial measurements that no
    /// state explains together (a diverged scale, a wrong stereo depth) show here first.
    pub imu_chi2_z: f64,
    /// Consecutive solves that must fail the IMU χ² test before the window is reset.
    pub imu_chi2_solves: usize,
    /// Largest distance (s) of the estimated camera–IMU time offset from the configured
    /// `td_s`. Real offsets are a few ms (hardware-synchronized rigs) to a few tens of ms (USB
    /// cameras), and one far beyond means the offset is absorbing a failure: a diverging window
    /// (1 cm stereo baseline, default motion, seed 1) moved it from 0 to 113 ms in the solve
    /// after its release, and kept its IMU χ² under the threshold while doing so. A true offset
    /// beyond the limit makes a reset loop (60 ms against 50: 578 resets on EuRoC V1_01), so
    /// the limit stays well above real offsets, and a rig with a larger one sets `td_s` near it.
    pub max_time_offset_deviation_s: f64,
    /// Largest share of the window's triangulated tracks that its reprojection test may reject
    /// as outliers, summed over the last `rejected_solves` solves; above it the window is reset
    /// and the estimator initializes again from the data (≥ 1: off). A window drifting away
    /// from what its cameras see loses its tracks to that test and is then carried by the IMU
    /// alone, which the χ² test cannot see: mono+IMU on EuRoC V2_02 with an unmodelled 35 ms
    /// offset (seed 1, frames' first estimates never renewed) rejected 12–25 % per solve from
    /// 12 s on and ran to 12 m/s and 13 m ATE.
    /// Healthy windows: at most 1.1 % over 10 solves on the non-rendered catalog, 4.4 % on
    /// the Lissajous calibration run's start with its extrinsics still wrong (1.1 s). 10 % over
    /// 20 solves: twice that, and longer than a start-up transient (20 over 10 solves reset the
    /// 35 ms run with its offset search on, twice, right after its initialization).
    pub max_rejected_fraction: f64,
    /// The number of solves `max_rejected_fraction` is summed over.
    pub rejected_solves: usize,
    /// A window restarted from the last state that passed the checks and failing again within
    /// this time (s) was restarted from a state already on its way to failing: the estimator
    /// then initializes again from the data instead of restarting from the failed window's
    /// states once more (0: never). Without it a diverged window whose accelerometer bias
    /// crept just under `max_accel_bias_m_s2` was restarted from there every 0.15–0.25 s,
    /// twelve times in 2 s (1 cm stereo baseline, time offset released, IMU χ² test off).
    pub restart_trial_s: f64,
}

impl Default for HealthLimits {
    fn default() -> Self {
        Self {
            max_accel_bias_m_s2: 2.5,
            max_gyro_bias_rad_s: 1.0,
            max_jump_m: 5.0,
            max_rotation_jump_deg: 50.0,
            imu_chi2_z: 4.75,
            imu_chi2_solves: 3,
            max_time_offset_deviation_s: 0.1,
            max_rejected_fraction: 0.1,
            rejected_solves: 20,
            restart_trial_s: 1.0,
        }
    }
}
