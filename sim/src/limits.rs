//! Resource bounds: far above any realistic run, far below what would exhaust a machine. The
//! checks in [`crate::validate`] hold every configuration to them before allocating.

/// Highest IMU rate (Hz): tactical IMUs sample at ≤ 2 kHz internally; the physics runs at
/// least once per IMU period, so this also bounds the physics rate.
pub const MAX_IMU_RATE_HZ: f64 = 10_000.0;
/// Lowest IMU rate (Hz): below it preintegration is no longer an integral of the motion.
pub const MIN_IMU_RATE_HZ: f64 = 10.0;
/// Highest camera rate (Hz) (high-speed machine-vision cameras).
pub const MAX_CAMERA_RATE_HZ: f64 = 1_000.0;
/// Longest run (s): one day of simulated time.
pub const MAX_DURATION_S: f64 = 86_400.0;
/// Most IMU samples in one run (200 Hz for 14 h; each costs ~100 bytes downstream).
pub const MAX_IMU_SAMPLES: f64 = 1.0e7;
/// Most camera frames (captures × cameras) in one run.
pub const MAX_CAMERA_FRAMES: f64 = 2.0e6;
/// Most landmarks a scene may hold (each is ~56 bytes plus its tile share).
pub const MAX_LANDMARKS: f64 = 2.0e7;
/// Most features per camera frame.
pub const MAX_FEATURES_PER_FRAME: usize = 10_000;
/// Most spline knots of a replayed or waypoint trajectory.
pub const MAX_SPLINE_KNOTS: f64 = 2.0e6;
/// Largest camera time offset (s).
pub const MAX_TIME_OFFSET_S: f64 = 1.0;
