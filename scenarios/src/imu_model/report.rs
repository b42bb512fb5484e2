//! `imu_model.json`: what `vio imu-model` found.

use serde::Serialize;

use super::allan::AllanCurve;
use super::fit::{NoiseFit, SlopeReadoff};
use super::motion::MotionCheck;
use super::residual::{ClockLag, FrameCheck};
use super::spectrum::{Band, Line, Psd};
use crate::spec::ImuErrorModelSpec;

/// Schema name and version of `imu_model.json`.
pub const SCHEMA: &str = "vio-imu-model/1";

/// Everything `vio imu-model` computes.
#[derive(Clone, Debug, Serialize)]
pub struct ImuModel {
    /// [`SCHEMA`].
    pub schema: &'static str,
    /// The IMU csv analysed.
    pub log: String,
    /// The stretch of the log analysed.
    pub selection: Selection,
    /// The Kalibr values of the `sensor.yaml` beside the log, if there is one.
    pub sensor_yaml: Option<KalibrReference>,
    /// Whether the raw log moves (1-s block test).
    pub motion: MotionCheck,
    /// Allan deviations and noise-model fits.
    pub allan: AllanSection,
    /// The comparison with the ground-truth-implied IMU (`--gt`).
    pub groundtruth: Option<GroundTruthSection>,
    /// Power spectral densities.
    pub spectrum: SpectrumSection,
    /// With ground truth: the fitted IMU error model and its check.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error_model: Option<FittedErrorModel>,
    /// With ground truth: the noise model an estimator should assume on this platform.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub estimator_noise: Option<EstimatorNoise>,
    /// What the numbers mean and where they cannot be trusted.
    pub notes: Vec<String>,
}

/// The analysed stretch of the log.
#[derive(Clone, Debug, Serialize)]
pub struct Selection {
    /// Start (s from the log's first sample).
    pub from_s: f64,
    /// End (s from the log's first sample).
    pub to_s: f64,
    /// Samples.
    pub samples: usize,
    /// Median sample period (s).
    pub period_s: f64,
    /// `1 / period_s` (Hz).
    pub rate_hz: f64,
    /// Intervals longer than 1.5 periods (the analysis treats the samples as contiguous).
    pub gaps: usize,
    /// Longest interval (s).
    pub longest_interval_s: f64,
}

/// The Kalibr noise values a `sensor.yaml` states.
#[derive(Clone, Debug, Serialize)]
pub struct KalibrReference {
    /// The file.
    pub path: String,
    /// rad/s/√Hz.
    pub gyroscope_noise_density: f64,
    /// rad/s²/√Hz.
    pub gyroscope_random_walk: f64,
    /// m/s²/√Hz.
    pub accelerometer_noise_density: f64,
    /// m/s³/√Hz.
    pub accelerometer_random_walk: f64,
}

/// Allan deviations of the raw log and of the residual against the ground truth.
#[derive(Clone, Debug, Serialize)]
pub struct AllanSection {
    /// The measured signal (motion included).
    pub raw: SensorPair<SensorAllan>,
    /// Measured − ground-truth-implied, over the samples the ground truth covers.
    pub residual: Option<SensorPair<SensorAllan>>,
}

/// One value per sensor.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SensorPair<T> {
    /// Gyroscope (rad/s).
    pub gyro: T,
    /// Accelerometer (m/s²).
    pub accel: T,
}

/// The Allan deviation and fits of one sensor's three axes.
#[derive(Clone, Debug, Serialize)]
pub struct SensorAllan {
    /// x, y, z.
    pub axes: Vec<AxisAllan>,
    /// Mean over the axes of the weighted least-squares fit.
    pub fit_mean: Option<NoiseFit>,
    /// Mean over the axes of the slope read-offs (where all three have one).
    pub readoff_mean: SlopeReadoff,
}

/// The Allan deviation and fits of one axis.
#[derive(Clone, Debug, Serialize)]
pub struct AxisAllan {
    /// `x`, `y` or `z`.
    pub axis: &'static str,
    /// The curve.
    pub curve: AllanCurve,
    /// Weighted least-squares fit of `N`, `B`, `K`.
    pub fit: Option<NoiseFit>,
    /// Classic slope read-offs.
    pub readoff: SlopeReadoff,
}

/// Measured against the ground-truth-implied IMU.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroundTruthSection {
    /// The ground-truth csv.
    pub path: String,
    /// Its rows.
    pub rows: usize,
    /// Its median period (s).
    pub period_s: f64,
    /// Its gaps (intervals over five periods: no implied IMU there).
    pub gaps: usize,
    /// Spline knot spacing (s).
    pub knot_spacing_s: f64,
    /// The rest stretches `[from, to]` (s from the log's start).
    pub rest_stretches_s: Vec<[f64; 2]>,
    /// Below this frequency (Hz) the implied IMU is within 10 % of the truth; the residual
    /// above it is sensor noise and vibration.
    pub valid_bandwidth_hz: f64,
    /// Gravity used (m/s², world frame).
    pub gravity: [f64; 3],
    /// Selected samples the ground truth covers.
    pub covered_samples: usize,
    /// Of those, at rest…
    pub rest_samples: usize,
    /// …and in motion.
    pub flight_samples: usize,
    /// How rest was told from flight.
    pub rest_rule: String,
    /// Clock relation from the gyro magnitudes, over the flight (independent of the frames).
    pub clock: Option<ClockLag>,
    /// Clock relation from the rate vectors (the three axes together, biases removed): sharper
    /// where the magnitude varies little, valid when the frame check finds the frames equal.
    pub clock_vector: Option<ClockLag>,
    /// Frame check (implied → measured rate, over the flight).
    pub frame: Option<FrameCheck>,
    /// Residual statistics per sensor.
    pub residual: SensorPair<ResidualStats>,
}

/// Residual mean and RMS per axis (x, y, z), in flight and at rest.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResidualStats {
    /// RMS in flight.
    pub rms_flight: Option<[f64; 3]>,
    /// RMS at rest.
    pub rms_rest: Option<[f64; 3]>,
    /// Mean in flight (a bias the ground truth's does not explain).
    pub mean_flight: Option<[f64; 3]>,
    /// Mean at rest.
    pub mean_rest: Option<[f64; 3]>,
}

/// Spectra of the raw log and of the residual.
#[derive(Clone, Debug, Serialize)]
pub struct SpectrumSection {
    /// The raw log minus its mean, whole selection.
    pub raw: Option<SensorPair<SensorSpectrum>>,
    /// The residual in flight.
    pub residual_flight: Option<SensorPair<SensorSpectrum>>,
    /// The residual at rest.
    pub residual_rest: Option<SensorPair<SensorSpectrum>>,
}

/// One sensor's spectrum: the sum of its three axes' PSDs.
#[derive(Clone, Debug, Serialize)]
pub struct SensorSpectrum {
    /// Sum over x, y, z of the one-sided PSD (unit²/Hz).
    pub psd: Psd,
    /// Power per octave of the sum.
    pub octaves: Vec<Band>,
    /// Power per octave of each axis (x, y, z).
    pub octaves_per_axis: Vec<Vec<Band>>,
    /// RMS (unit, all axes together) from the first bin above 0 Hz up to `above_hz`…
    pub rms_below: f64,
    /// …and from `above_hz` up (for the residual: sensor noise and vibration).
    pub rms_above: f64,
    /// The frequency `rms_above` starts at (Hz).
    pub above_hz: f64,
    /// Narrow lines, strongest first.
    pub lines: Vec<Line>,
}

/// One octave of the fit check: the real residual's power and the calibrated model's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OctaveCheck {
    /// `flight` or `rest`.
    pub profile: &'static str,
    /// `gyro` or `accel`.
    pub sensor: &'static str,
    /// Lower edge (Hz).
    pub lo_hz: f64,
    /// Upper edge (Hz).
    pub hi_hz: f64,
    /// The real residual's power, all axes (unit²).
    pub real_power: f64,
    /// The power the model predicts, all axes, mean over the calibration seeds (unit²).
    pub predicted_power: f64,
}

/// The fitted error model (`error_model.toml`) and how well it predicts the residual.
#[derive(Clone, Debug, Serialize)]
pub struct FittedErrorModel {
    /// The model.
    pub model: ImuErrorModelSpec,
    /// Calibration rounds.
    pub iterations: usize,
    /// Per octave, real and predicted power after calibration.
    pub check: Vec<OctaveCheck>,
}

/// The recommended model and how it was read off.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EstimatorNoise {
    /// The IMU interval (s): the shortest time scale the white densities are matched over.
    pub interval_s: f64,
    /// The estimator window's span (s): the longest (or the curve's end, if shorter).
    pub window_s: f64,
    /// Gyroscope white noise density (rad/s/√Hz).
    pub gyroscope_noise_density: f64,
    /// Accelerometer white noise density (m/s²/√Hz).
    pub accelerometer_noise_density: f64,
    /// Gyroscope bias random walk (rad/s²/√Hz): the sensor.yaml's; `None` without one (the
    /// sensor's own is kept).
    pub gyroscope_random_walk: Option<f64>,
    /// Accelerometer bias random walk (m/s³/√Hz); as the gyroscope's.
    pub accelerometer_random_walk: Option<f64>,
    /// The fitted bias instability for the estimator's Gauss–Markov model: Allan floors
    /// (gyroscope rad/s, accelerometer m/s²) and correlation time (s).
    pub bias_instability: Option<(f64, f64, f64)>,
    /// Per axis (x, y, z), the in-flight residual's white-equivalent density over the band.
    pub per_axis: SensorPair<[f64; 3]>,
    /// Each value's reasoning, written beside it in the file.
    pub reasoning: Vec<String>,
}
