//! The IMU error model fitted to a log's residual against its ground truth: what the simulated
//! IMU must add to the datasheet densities so its residual has the real one's spectrum
//! (`error_model.toml`, usable as `rig.imu.error_model`).
//!
//! # Fit
//! - **Bias instability**: the residual's Allan-deviation floor and where it lies (`τ_B`), per
//!   sensor the mean over the axes; the Gauss–Markov correlation time is `τ_B / 1.89` (the
//!   gyroscope's, shared). Absent when the residual's Allan curve shows no floor.
//! - **Lines**: each narrow line of the residual's summed spectrum (at rest the rotors idle at a
//!   steady speed and show lines; in flight their speed follows the thrust and the lines smear
//!   into the bands), its power split over the axes like their power in its octave.
//! - **Bands**, one per octave from 0.1 Hz to half the rate, rest and flight apart, per axis:
//!   first the residual's power in the octave less what the rest of the model already puts
//!   there — the datasheet white noise (`2N²` per Hz, from `sensor.yaml`) and the lines —
//!   floored at zero. An octave the residual does not reach (a rest stretch shorter than its
//!   period) gets no band. Then the bands are **calibrated**: the residual the model predicts
//!   ([`super::synthesis`], driven by the log's own ground-truth speed, seeds 1 and 2) goes
//!   through the same spectral estimate as the real one, and each band's power is scaled by
//!   real ÷ predicted in its octave, [`ITERATIONS`] times. This takes out what the estimate's
//!   window smears between octaves (the 0.1–0.2 Hz octave is one Welch bin wide), so the
//!   simulation's residual, measured the way the real one was, matches it.
//!
//! The bias instability is not in the residual's octaves: a simulated ground truth carries the
//! bias exactly, so the simulator's residual never holds it.
//!
//! Below the ground truth's valid bandwidth (about 7 Hz for a 20 Hz ground truth) the residual
//! also holds the ground truth's own errors; the model keeps them, because a replay under
//! simulated cameras sees them exactly as the IMU's: the cameras follow the ground truth, the
//! real IMU the true motion. Bands below that frequency are marked in the description so a user
//! can drop them for a sensor-only model.
//!
//! The speed proxy between rest and flight is not fitted: rest below the rest rule's 0.02 m/s,
//! flight from 0.05 m/s, a 1 s lag.

use nalgebra::Vector3;

use super::comparison::Comparison;
use super::report::{FittedErrorModel, ImuModel, OctaveCheck, SensorPair, SensorSpectrum};
use super::spectrum::Band;
use super::synthesis;
use crate::spec::ImuErrorModelSpec;
use crate::spec::imu_error_model as ems;

/// Calibration rounds.
pub const ITERATIONS: usize = 8;
/// Seeds the predicted residual is averaged over.
const SEEDS: [u64; 2] = [1, 2];
/// Largest change of a band's power in one round.
const MAX_STEP: f64 = 16.0;

/// Allan-floor time per Gauss–Markov correlation time.
const FLOOR_TAU_PER_CORRELATION: f64 = 1.89;
/// The speed proxy (not fitted).
const SPEED_AT_REST_M_S: f64 = 0.02;
const SPEED_IN_FLIGHT_M_S: f64 = 0.05;
const ACTIVITY_LAG_S: f64 = 1.0;

/// What the model outside the bands puts into one octave of one axis: the power of white
/// noise of `density` (one-sided level `2N²`).
fn white_power(density: f64, b: &Band) -> f64 {
    2.0 * density.powi(2) * (b.hi_hz - b.lo_hz)
}

/// Per-axis line power (x, y, z) of each line of `s`, split like the axes' power in its octave.
fn lines_per_axis(s: &SensorSpectrum) -> Vec<(f64, [f64; 3])> {
    s.lines
        .iter()
        .map(|l| {
            let octave = |axis: &Vec<Band>| {
                axis.iter()
                    .find(|b| l.freq_hz >= b.lo_hz && l.freq_hz < b.hi_hz)
                    .and_then(|b| b.power)
                    .unwrap_or(0.0)
            };
            let p: Vec<f64> = s.octaves_per_axis.iter().map(octave).collect();
            let total: f64 = p.iter().sum();
            let share = |i: usize| {
                if total > 0.0 {
                    l.power * p[i] / total
                } else {
                    l.power / 3.0
                }
            };
            (l.freq_hz, [share(0), share(1), share(2)])
        })
        .collect()
}

/// Band RMS per axis for one sensor's residual spectrum, less white noise of `white` density
/// and the lines.
fn bands(s: &SensorSpectrum, white: f64, lines: &[(f64, [f64; 3])]) -> Vec<(Band, [f64; 3])> {
    let Some(first) = s.octaves_per_axis.first() else {
        return Vec::new();
    };
    first
        .iter()
        .enumerate()
        .filter_map(|(o, band)| {
            let mut rms = [0.0; 3];
            for (axis, r) in rms.iter_mut().enumerate() {
                let p = s.octaves_per_axis[axis][o].power?;
                let in_lines: f64 = lines
                    .iter()
                    .filter(|(f, _)| *f >= band.lo_hz && *f < band.hi_hz)
                    .map(|(_, p)| p[axis])
                    .sum();
                *r = (p - white_power(white, band) - in_lines).max(0.0).sqrt();
            }
            Some((*band, rms))
        })
        .collect()
}

fn profile(
    gyro: Option<&SensorSpectrum>,
    accel: Option<&SensorSpectrum>,
    white: (f64, f64),
) -> ems::ProfileSpec {
    let (Some(g), Some(a)) = (gyro, accel) else {
        return ems::ProfileSpec::default();
    };
    let (gl, al) = (lines_per_axis(g), lines_per_axis(a));
    let gb = bands(g, white.0, &gl);
    let ab = bands(a, white.1, &al);
    let bands = gb
        .iter()
        .filter_map(|(b, grms)| {
            let (_, arms) = ab.iter().find(|(x, _)| x.lo_hz == b.lo_hz)?;
            Some(ems::BandSpec {
                lo_hz: b.lo_hz,
                hi_hz: b.hi_hz,
                gyro_rms_rad_s: *grms,
                accel_rms_m_s2: *arms,
            })
        })
        .collect();
    // Lines are found per sensor; a line of one sensor has no power in the other.
    let mut lines: Vec<ems::LineSpec> = gl
        .iter()
        .map(|(f, p)| ems::LineSpec {
            freq_hz: *f,
            gyro_rms_rad_s: p.map(f64::sqrt),
            accel_rms_m_s2: [0.0; 3],
        })
        .collect();
    lines.extend(al.iter().map(|(f, p)| ems::LineSpec {
        freq_hz: *f,
        gyro_rms_rad_s: [0.0; 3],
        accel_rms_m_s2: p.map(f64::sqrt),
    }));
    lines.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
    ems::ProfileSpec { bands, lines }
}

/// The first guess at the error model from `m`'s residual, before calibration, with the white
/// noise densities `white` (gyro, accel); `None` without ground truth or a flight residual.
fn first_guess(m: &ImuModel, white: (f64, f64)) -> Option<ImuErrorModelSpec> {
    let gt = m.groundtruth.as_ref()?;
    let flight = m.spectrum.residual_flight.as_ref()?;
    let residual_allan = m.allan.residual.as_ref()?;
    let (gb, ab) = (
        residual_allan.gyro.readoff_mean.bias_instability,
        residual_allan.accel.readoff_mean.bias_instability,
    );
    let tau = residual_allan.gyro.readoff_mean.bias_instability_tau_s;
    let bias_instability = match (gb, ab, tau) {
        (Some(g), Some(a), Some(tau)) => Some(ems::BiasInstabilitySpec {
            gyro_rad_s: g,
            accel_m_s2: a,
            correlation_s: tau / FLOOR_TAU_PER_CORRELATION,
        }),
        _ => None,
    };
    let rest = m.spectrum.residual_rest.as_ref();
    let description = format!(
        "Fitted by `vio imu-model` to {} against {} ({} samples in flight, {} at rest): bands are the residual's octave power less {} and the lines, calibrated until the predicted residual's spectrum matches; the bias instability is the residual's Allan floor. Below {:.1} Hz (the ground truth's valid bandwidth) the bands also hold the ground truth's own error.",
        m.log,
        gt.path,
        gt.flight_samples,
        gt.rest_samples,
        if m.sensor_yaml.is_some() {
            "the sensor.yaml white noise"
        } else {
            "nothing for white noise (no sensor.yaml beside the log: the scenario's densities add to these bands)"
        },
        gt.valid_bandwidth_hz
    );
    Some(ImuErrorModelSpec {
        description: Some(description),
        bias_instability,
        vibration: Some(ems::VibrationSpec {
            speed_at_rest_m_s: SPEED_AT_REST_M_S,
            speed_in_flight_m_s: SPEED_IN_FLIGHT_M_S,
            time_constant_s: ACTIVITY_LAG_S,
            rest: profile(rest.map(|r| &r.gyro), rest.map(|r| &r.accel), white),
            flight: profile(Some(&flight.gyro), Some(&flight.accel), white),
        }),
    })
}

/// The spectral estimate the real residual went through: gyro and accel series and the samples
/// to use → the two sensors' spectra.
pub type Measure<'a> =
    &'a dyn Fn(&[Vector3<f64>], &[Vector3<f64>], &[bool]) -> Option<SensorPair<SensorSpectrum>>;

/// Per-axis power of each octave (`None` where the estimate does not reach).
fn axis_powers(s: &SensorSpectrum) -> AxisPowers {
    let n = s.octaves_per_axis.first().map_or(0, Vec::len);
    (0..n)
        .map(|o| std::array::from_fn(|a| s.octaves_per_axis[a][o].power))
        .collect()
}

/// Per-axis power of each octave.
type AxisPowers = Vec<[Option<f64>; 3]>;
/// Predicted per-axis octave powers (gyro, accel) of each profile's samples (flight, rest),
/// mean over seeds.
type Predicted = [Option<(AxisPowers, AxisPowers)>; 2];

fn predict(
    spec: &ImuErrorModelSpec,
    white: (f64, f64),
    c: &Comparison,
    dt: f64,
    measure: Measure,
) -> Predicted {
    let runs: Vec<synthesis::Series> = SEEDS
        .iter()
        .map(|s| synthesis::residual(spec, white, &c.speed, dt, *s))
        .collect();
    [&c.flight, &c.rest].map(|mask| {
        let mut sum: Option<(AxisPowers, AxisPowers)> = None;
        for r in &runs {
            let sp = measure(&r.gyro, &r.accel, mask)?;
            let (g, a) = (axis_powers(&sp.gyro), axis_powers(&sp.accel));
            sum = Some(match sum {
                None => (g, a),
                Some((sg, sa)) => (add(&sg, &g), add(&sa, &a)),
            });
        }
        let k = runs.len() as f64;
        sum.map(|(g, a)| (scale(&g, 1.0 / k), scale(&a, 1.0 / k)))
    })
}

fn add(a: &[[Option<f64>; 3]], b: &[[Option<f64>; 3]]) -> AxisPowers {
    a.iter()
        .zip(b)
        .map(|(x, y)| std::array::from_fn(|i| Some(x[i]? + y[i]?)))
        .collect()
}

fn scale(a: &[[Option<f64>; 3]], k: f64) -> AxisPowers {
    a.iter().map(|x| x.map(|v| v.map(|v| v * k))).collect()
}

/// One calibration round of one sensor's bands of one profile.
fn update(
    bands: &mut [ems::BandSpec],
    octaves: &[Band],
    real: &[[Option<f64>; 3]],
    predicted: &[[Option<f64>; 3]],
    rms: fn(&mut ems::BandSpec) -> &mut [f64; 3],
) {
    for b in bands {
        let Some(o) = octaves.iter().position(|x| x.lo_hz == b.lo_hz) else {
            continue;
        };
        let (Some(r), Some(q)) = (real.get(o), predicted.get(o)) else {
            continue;
        };
        for axis in 0..3 {
            let (Some(r), Some(q)) = (r[axis], q[axis]) else {
                continue;
            };
            let x = &mut rms(b)[axis];
            let p = *x * *x;
            let next = if p > 0.0 && q > 0.0 {
                p * (r / q).clamp(1.0 / MAX_STEP, MAX_STEP)
            } else {
                (r - q).max(0.0)
            };
            *x = next.sqrt();
        }
    }
}

/// The error model fitted to `m`'s residual (from `c`, measured with `measure`), calibrated;
/// `None` without ground truth or a flight residual.
pub fn fit_error_model(m: &ImuModel, c: &Comparison, measure: Measure) -> Option<FittedErrorModel> {
    // The white noise the simulator adds anyway: sensor.yaml's densities, none without one.
    let white = m.sensor_yaml.as_ref().map_or((0.0, 0.0), |k| {
        (k.gyroscope_noise_density, k.accelerometer_noise_density)
    });
    let mut spec = first_guess(m, white)?;
    let dt = m.selection.period_s;
    let real = [
        m.spectrum.residual_flight.as_ref(),
        m.spectrum.residual_rest.as_ref(),
    ];
    for _ in 0..ITERATIONS {
        let predicted = predict(&spec, white, c, dt, measure);
        let vib = spec.vibration.as_mut()?;
        for (i, profile) in [&mut vib.flight, &mut vib.rest].into_iter().enumerate() {
            let (Some(r), Some((pg, pa))) = (real[i], &predicted[i]) else {
                continue;
            };
            let octaves = &r.gyro.octaves;
            update(
                &mut profile.bands,
                octaves,
                &axis_powers(&r.gyro),
                pg,
                |b| &mut b.gyro_rms_rad_s,
            );
            update(
                &mut profile.bands,
                octaves,
                &axis_powers(&r.accel),
                pa,
                |b| &mut b.accel_rms_m_s2,
            );
        }
    }
    let predicted = predict(&spec, white, c, dt, measure);
    let mut check = Vec::new();
    for (i, name) in ["flight", "rest"].into_iter().enumerate() {
        let (Some(r), Some((pg, pa))) = (real[i], &predicted[i]) else {
            continue;
        };
        for (sensor, s, p) in [("gyro", &r.gyro, pg), ("accel", &r.accel, pa)] {
            for (o, band) in s.octaves.iter().enumerate() {
                let (Some(real_power), Some(q)) = (band.power, p.get(o)) else {
                    continue;
                };
                let Some(predicted_power) = q.iter().copied().sum::<Option<f64>>() else {
                    continue;
                };
                check.push(OctaveCheck {
                    profile: name,
                    sensor,
                    lo_hz: band.lo_hz,
                    hi_hz: band.hi_hz,
                    real_power,
                    predicted_power,
                });
            }
        }
    }
    Some(FittedErrorModel {
        model: spec,
        iterations: ITERATIONS,
        check,
    })
}
