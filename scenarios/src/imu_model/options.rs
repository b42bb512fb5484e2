//! What `vio imu-model` is asked to analyse, and the least data it analyses.

/// Fewest samples an Allan deviation is computed from.
pub const MIN_SAMPLES: usize = 100;
/// What to analyse and how.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Options {
    /// Start of the stretch (s from the log's first sample); default the start.
    pub from_s: Option<f64>,
    /// End of the stretch (s from the log's first sample); default the end.
    pub to_s: Option<f64>,
    /// With ground truth: rest is before this time (s from the log's start) instead of detected.
    pub rest_until_s: Option<f64>,
    /// Knot spacing (s) of the spline through the ground truth; default its median period, at
    /// least [`super::residual::MIN_DEFAULT_KNOT_SPACING_S`].
    pub knot_spacing_s: Option<f64>,
    /// With ground truth: the IMU interval (s) the estimator's white densities are matched at;
    /// default [`DEFAULT_ESTIMATOR_INTERVAL_S`].
    pub estimator_interval_s: Option<f64>,
    /// With ground truth: the span (s) of the estimator's window, the longest time scale its
    /// white densities are matched over; default [`DEFAULT_ESTIMATOR_WINDOW_S`].
    pub estimator_window_s: Option<f64>,
}

/// The EuRoC camera period (20 Hz): the shortest interval an estimator's IMU factor spans there.
pub const DEFAULT_ESTIMATOR_INTERVAL_S: f64 = 0.05;

/// The span of the estimator's 10-keyframe window on the EuRoC flights: on the V1_01 preset's
/// stereo+IMU run (seed 1, 30 s) 0.67 s median and 0.93 s mean, keyframes 0.05 s apart median
/// and 0.10 s mean.
pub const DEFAULT_ESTIMATOR_WINDOW_S: f64 = 0.8;
