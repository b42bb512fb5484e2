//! `vio imu-model`'s analysis: the selected stretch of a log → Allan deviations and fits,
//! spectra, and with ground truth the residual against the implied IMU.

use estimator::imu::ImuSample;
use nalgebra::Vector3;

use super::allan::allan_deviation;
use super::comparison::compare;
use super::error_model::fit_error_model;
use super::estimator_noise::recommend;
use super::fit::{NoiseFit, SlopeReadoff, fit_noise_model, slope_readoff};
use super::motion::check_motion;
use super::options::{
    DEFAULT_ESTIMATOR_INTERVAL_S, DEFAULT_ESTIMATOR_WINDOW_S, MIN_SAMPLES, Options,
};
use super::report::{
    AllanSection, AxisAllan, ImuModel, KalibrReference, SCHEMA, Selection, SensorAllan, SensorPair,
    SensorSpectrum, SpectrumSection,
};
use super::spectrum::{Psd, find_lines, octave_bands, runs_of, segment_length, welch};
use crate::dataset::GroundTruthState;

/// Lines reported per spectrum.
const MAX_LINES: usize = 6;
/// Lowest frequency a line is looked for at (Hz).
const LINE_MIN_HZ: f64 = 1.0;
const AXES: [&str; 3] = ["x", "y", "z"];

/// The data to analyse.
#[derive(Clone, Debug, Default)]
pub struct Input {
    /// Name of the log in messages and the report.
    pub log: String,
    /// The IMU samples, time-ordered.
    pub samples: Vec<ImuSample>,
    /// Kalibr values from the log's `sensor.yaml`.
    pub sensor_yaml: Option<KalibrReference>,
    /// Ground truth: its file name and rows.
    pub groundtruth: Option<(String, Vec<GroundTruthState>)>,
}

fn check_option(name: &str, v: Option<f64>) -> Result<(), String> {
    match v {
        Some(x) if !(x.is_finite() && x >= 0.0) => Err(format!(
            "{name} must be a finite number of seconds ≥ 0, got {x}"
        )),
        _ => Ok(()),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// Refuses a log whose stamps, read as nanoseconds, space the samples at a rate no IMU has
/// (`sim::limits`' 10 Hz to 10 kHz), naming the unit they look like (microsecond stamps read
/// as nanoseconds put a 200 Hz IMU at 200 kHz).
fn check_rate(log: &str, dt_s: f64) -> Result<(), String> {
    use sim::limits::{MAX_IMU_RATE_HZ, MIN_IMU_RATE_HZ};
    let rate = 1.0 / dt_s;
    let plausible = |r: f64| (MIN_IMU_RATE_HZ..=MAX_IMU_RATE_HZ).contains(&r);
    if dt_s > 0.0 && plausible(rate) {
        return Ok(());
    }
    let unit = [("microseconds", 1e3), ("milliseconds", 1e6), ("seconds", 1e9)]
        .into_iter()
        .find(|(_, f)| plausible(rate / f))
        .map_or(String::new(), |(name, f)| {
            format!(
                ": the stamps look like {name} ({:.1} Hz if they were); the log's stamps must be nanoseconds",
                rate / f
            )
        });
    Err(format!(
        "{log}: the samples' median spacing of {dt_s:e} s (stamps read as nanoseconds) is a rate of {rate:.3e} Hz, outside any IMU's [{MIN_IMU_RATE_HZ}, {MAX_IMU_RATE_HZ}] Hz{unit}"
    ))
}

/// Runs the analysis. `Err` explains what in the input or options is unusable.
pub fn analyze(input: &Input, opts: &Options) -> Result<ImuModel, String> {
    check_option("--from", opts.from_s)?;
    check_option("--to", opts.to_s)?;
    check_option("--rest-until", opts.rest_until_s)?;
    if let Some(t) = opts.estimator_interval_s
        && !(t.is_finite() && (0.001..=1.0).contains(&t))
    {
        return Err(format!(
            "--interval must be an IMU interval in [0.001, 1] s (a camera period), got {t}"
        ));
    }
    if let Some(w) = opts.estimator_window_s {
        let interval = opts
            .estimator_interval_s
            .unwrap_or(DEFAULT_ESTIMATOR_INTERVAL_S);
        if !(w.is_finite() && w >= interval && w <= 10.0) {
            return Err(format!(
                "--window must be the span of the estimator's window in [--interval ({interval} s), 10] s, got {w}"
            ));
        }
    }
    if let Some(k) = opts.knot_spacing_s
        && !(k.is_finite() && (0.01..=2.0).contains(&k))
    {
        return Err(format!("--knot-spacing must be in [0.01, 2] s, got {k}"));
    }
    let log = &input.log;
    let Some(first) = input.samples.first() else {
        return Err(format!("{log}: no IMU samples"));
    };
    let t0 = first.t_ns;
    let rel = |s: &ImuSample| (s.t_ns - t0) as f64 * 1e-9;
    let end = rel(&input.samples[input.samples.len() - 1]);
    let from = opts.from_s.unwrap_or(0.0);
    let to = opts.to_s.unwrap_or(f64::INFINITY);
    if from >= to {
        return Err(format!("--from {from} s is not before --to {to} s"));
    }
    let sel: Vec<ImuSample> = input
        .samples
        .iter()
        .filter(|s| (from..=to).contains(&rel(s)))
        .copied()
        .collect();
    if sel.len() < MIN_SAMPLES {
        return Err(format!(
            "{log}: {} samples between {from} s and {} s of a {end:.3} s log; an Allan deviation needs at least {MIN_SAMPLES}",
            sel.len(),
            to.min(end)
        ));
    }
    let intervals: Vec<f64> = sel
        .windows(2)
        .map(|w| (w[1].t_ns - w[0].t_ns) as f64 * 1e-9)
        .collect();
    let dt = median(intervals.clone());
    check_rate(log, dt)?;
    let selection = Selection {
        from_s: rel(&sel[0]),
        to_s: rel(&sel[sel.len() - 1]),
        samples: sel.len(),
        period_s: dt,
        rate_hz: 1.0 / dt,
        gaps: intervals.iter().filter(|d| **d > 1.5 * dt).count(),
        longest_interval_s: intervals.iter().copied().fold(0.0, f64::max),
    };
    let gyro: Vec<Vector3<f64>> = sel.iter().map(|s| s.gyro).collect();
    let accel: Vec<Vector3<f64>> = sel.iter().map(|s| s.accel).collect();
    let all = vec![true; sel.len()];
    let raw_allan = SensorPair {
        gyro: sensor_allan(&gyro, &all, dt),
        accel: sensor_allan(&accel, &all, dt),
    };
    let raw_spectrum = spectra(&gyro, &accel, &all, dt, LINE_MIN_HZ);
    let motion = check_motion(&sel, dt, selection.from_s);
    let mut notes = base_notes(&selection, dt);
    if motion.moving_blocks > 0 {
        notes.push(format!(
            "the log moves in {} of {} 1-s blocks: its raw Allan deviation measures the motion, not the sensor's noise; select a still stretch with --from/--to or use --gt for the residual's",
            motion.moving_blocks, motion.blocks
        ));
    }
    let mut model = ImuModel {
        schema: SCHEMA,
        log: log.clone(),
        selection,
        sensor_yaml: input.sensor_yaml.clone(),
        motion,
        allan: AllanSection {
            raw: raw_allan,
            residual: None,
        },
        groundtruth: None,
        spectrum: SpectrumSection {
            raw: raw_spectrum,
            residual_flight: None,
            residual_rest: None,
        },
        error_model: None,
        estimator_noise: None,
        notes,
    };
    if let Some((path, gt)) = &input.groundtruth {
        with_groundtruth(&mut model, &sel, path, gt, opts, t0)?;
    }
    Ok(model)
}

fn base_notes(sel: &Selection, dt: f64) -> Vec<String> {
    let mut notes = vec![
        "Allan deviation: overlapping estimator, cluster times log-spaced from one period to T/9; fit σ²(τ) = N²/τ + (2 ln2/π)B² + K²τ/3 by weighted non-negative least squares; N, K are Kalibr's *_noise_density, *_random_walk".into(),
        "spectra: Welch, Hann window, 50 % overlap, one-sided, sum of the three axes; a white noise of density N has the per-axis level 2N²".into(),
    ];
    if sel.gaps > 0 {
        notes.push(format!(
            "{} intervals longer than 1.5 periods (longest {:.4} s, period {dt:.6} s): the samples are treated as contiguous",
            sel.gaps, sel.longest_interval_s
        ));
    }
    notes
}

fn axis_series(v: &[Vector3<f64>], mask: &[bool], axis: usize) -> Vec<f64> {
    v.iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(x, _)| x[axis])
        .collect()
}

fn sensor_allan(v: &[Vector3<f64>], mask: &[bool], dt: f64) -> SensorAllan {
    let axes: Vec<AxisAllan> = (0..3)
        .map(|a| {
            let curve = allan_deviation(&axis_series(v, mask, a), dt);
            AxisAllan {
                axis: AXES[a],
                fit: fit_noise_model(&curve),
                readoff: slope_readoff(&curve),
                curve,
            }
        })
        .collect();
    let fits: Option<Vec<NoiseFit>> = axes.iter().map(|a| a.fit).collect();
    let fit_mean = fits.map(|f| NoiseFit {
        white_noise_density: f.iter().map(|x| x.white_noise_density).sum::<f64>() / 3.0,
        bias_instability: f.iter().map(|x| x.bias_instability).sum::<f64>() / 3.0,
        random_walk: f.iter().map(|x| x.random_walk).sum::<f64>() / 3.0,
        relative_rms_residual: f.iter().map(|x| x.relative_rms_residual).sum::<f64>() / 3.0,
    });
    let mean = |get: fn(&SlopeReadoff) -> Option<f64>| -> Option<f64> {
        let v: Option<Vec<f64>> = axes.iter().map(|a| get(&a.readoff)).collect();
        v.map(|v| v.iter().sum::<f64>() / 3.0)
    };
    let readoff_mean = SlopeReadoff {
        white_noise_density: mean(|r| r.white_noise_density),
        white_noise_tau_s: mean(|r| r.white_noise_tau_s),
        random_walk: mean(|r| r.random_walk),
        random_walk_tau_s: mean(|r| r.random_walk_tau_s),
        bias_instability: mean(|r| r.bias_instability),
        bias_instability_tau_s: mean(|r| r.bias_instability_tau_s),
    };
    SensorAllan {
        axes,
        fit_mean,
        readoff_mean,
    }
}

fn sensor_spectrum(
    v: &[Vector3<f64>],
    mask: &[bool],
    dt: f64,
    line_min_hz: f64,
) -> Option<SensorSpectrum> {
    let runs = runs_of(mask);
    let segment = segment_length(&runs)?;
    let fs = 1.0 / dt;
    let per_axis: Vec<Psd> = (0..3)
        .map(|a| {
            let y: Vec<f64> = v.iter().map(|x| x[a]).collect();
            welch(&y, &runs, fs, segment)
        })
        .collect::<Option<_>>()?;
    let psd = Psd::sum(&per_axis)?;
    let power = |keep: &dyn Fn(f64) -> bool| -> f64 {
        let bins = psd.freq_hz.iter().zip(&psd.density).skip(1);
        bins.filter(|(f, _)| keep(**f))
            .map(|(_, d)| d * psd.df())
            .sum()
    };
    let above = power(&|f| f >= line_min_hz);
    let below = power(&|f| f < line_min_hz);
    Some(SensorSpectrum {
        octaves: octave_bands(&psd),
        octaves_per_axis: per_axis.iter().map(octave_bands).collect(),
        rms_below: below.sqrt(),
        rms_above: above.sqrt(),
        above_hz: line_min_hz,
        lines: find_lines(&psd, line_min_hz, MAX_LINES),
        psd,
    })
}

fn spectra(
    gyro: &[Vector3<f64>],
    accel: &[Vector3<f64>],
    mask: &[bool],
    dt: f64,
    line_min_hz: f64,
) -> Option<SensorPair<SensorSpectrum>> {
    Some(SensorPair {
        gyro: sensor_spectrum(gyro, mask, dt, line_min_hz)?,
        accel: sensor_spectrum(accel, mask, dt, line_min_hz)?,
    })
}

fn with_groundtruth(
    model: &mut ImuModel,
    sel: &[ImuSample],
    path: &str,
    gt: &[GroundTruthState],
    opts: &Options,
    t0: i64,
) -> Result<(), String> {
    let dt = model.selection.period_s;
    let c = compare(sel, dt, &model.log, path, gt, opts, t0)?;
    let (gt_period, knots, bandwidth) = (
        c.section.period_s,
        c.section.knot_spacing_s,
        c.section.valid_bandwidth_hz,
    );
    model.allan.residual = Some(SensorPair {
        gyro: sensor_allan(&c.residual.gyro, &c.covered, dt),
        accel: sensor_allan(&c.residual.accel, &c.covered, dt),
    });
    let line_min = bandwidth.max(LINE_MIN_HZ);
    let (r_gyro, r_accel) = (&c.residual.gyro, &c.residual.accel);
    model.spectrum.residual_flight = spectra(r_gyro, r_accel, &c.flight, dt, line_min);
    model.spectrum.residual_rest = spectra(r_gyro, r_accel, &c.rest, dt, line_min);
    let n_rest = c.section.rest_samples;
    model.groundtruth = Some(c.section.clone());
    let measure =
        |g: &[Vector3<f64>], a: &[Vector3<f64>], mask: &[bool]| spectra(g, a, mask, dt, line_min);
    model.error_model = fit_error_model(model, &c, &measure);
    let interval = opts
        .estimator_interval_s
        .unwrap_or(DEFAULT_ESTIMATOR_INTERVAL_S);
    let flight = SensorPair {
        gyro: sensor_allan(&c.residual.gyro, &c.flight, dt),
        accel: sensor_allan(&c.residual.accel, &c.flight, dt),
    };
    let bias = model
        .error_model
        .as_ref()
        .and_then(|f| f.model.bias_instability.as_ref());
    let window = opts
        .estimator_window_s
        .unwrap_or(DEFAULT_ESTIMATOR_WINDOW_S)
        .max(interval);
    model.estimator_noise = recommend(
        &flight,
        (interval, window),
        model.sensor_yaml.as_ref(),
        bias,
    );
    if model.estimator_noise.is_none() {
        model.notes.push(format!(
            "no estimator noise model: the in-flight residual's Allan deviation does not reach the {interval} s interval (too little flight, or an interval below the sample period)"
        ));
    }
    model.notes.push(format!(
        "ground truth every {gt_period:.4} s through a cubic B-spline with knots every {knots:.4} s: the implied IMU is valid below {bandwidth:.2} Hz; residual content above it is sensor noise and vibration, below it also the ground truth's error"
    ));
    model.notes.push("residual Allan deviation: over the samples the ground truth covers; at long τ it also holds the ground truth's bias and model errors".into());
    if n_rest == 0 {
        model
            .notes
            .push("no rest found in the ground truth: no residual at rest".into());
    }
    Ok(())
}
