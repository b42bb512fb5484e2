//! The short human summary `vio imu-model` prints.

use std::fmt::Write as _;

use super::fit::NoiseFit;
use super::report::{ImuModel, ResidualStats, SensorAllan, SensorSpectrum};

fn e(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.3e}")
    }
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(|| "—".into(), e)
}

fn fit_row(out: &mut String, label: &str, f: Option<NoiseFit>) {
    let _ = match f {
        Some(f) => writeln!(
            out,
            "    {label:<22} {:>11} {:>11} {:>11}",
            e(f.white_noise_density),
            e(f.bias_instability),
            e(f.random_walk)
        ),
        None => writeln!(out, "    {label:<22} (no fit)"),
    };
}

fn sensor_block(
    out: &mut String,
    name: &str,
    units: &str,
    s: &SensorAllan,
    kalibr: Option<(f64, f64)>,
) {
    let _ = writeln!(out, "  {name} [{units}]");
    fit_row(out, "fit (mean of x, y, z)", s.fit_mean);
    for a in &s.axes {
        fit_row(out, &format!("  axis {}", a.axis), a.fit);
    }
    let r = &s.readoff_mean;
    let _ = writeln!(
        out,
        "    {:<22} {:>11} {:>11} {:>11}",
        "slope read-offs",
        opt(r.white_noise_density),
        opt(r.bias_instability),
        opt(r.random_walk)
    );
    if let Some((n, k)) = kalibr {
        let ratio = |fit: Option<f64>, yaml: f64| {
            fit.map_or_else(String::new, |f| format!(" ({:.2}×)", f / yaml))
        };
        let _ = writeln!(
            out,
            "    {:<22} {:>11} {:>11} {:>11}   fit/yaml: N{} K{}",
            "sensor.yaml (Kalibr)",
            e(n),
            "",
            e(k),
            ratio(s.fit_mean.map(|f| f.white_noise_density), n),
            ratio(s.fit_mean.map(|f| f.random_walk), k)
        );
    }
}

fn allan_block(out: &mut String, m: &ImuModel, title: &str, residual: bool) {
    let pair = if residual {
        m.allan.residual.as_ref()
    } else {
        Some(&m.allan.raw)
    };
    let Some(pair) = pair else { return };
    let _ = writeln!(out, "{title}:{:>15} {:>11} {:>11}", "N", "B", "K");
    let k = m.sensor_yaml.as_ref();
    sensor_block(
        out,
        "gyro",
        "N rad/s/√Hz, B rad/s, K rad/s²/√Hz",
        &pair.gyro,
        k.map(|k| (k.gyroscope_noise_density, k.gyroscope_random_walk)),
    );
    sensor_block(
        out,
        "accel",
        "N m/s²/√Hz, B m/s², K m/s³/√Hz",
        &pair.accel,
        k.map(|k| (k.accelerometer_noise_density, k.accelerometer_random_walk)),
    );
}

fn rms_row(out: &mut String, label: &str, v: Option<[f64; 3]>) {
    let _ = match v {
        Some(v) => writeln!(
            out,
            "    {label:<26} {:>11} {:>11} {:>11}",
            e(v[0]),
            e(v[1]),
            e(v[2])
        ),
        None => writeln!(out, "    {label:<26} (no samples)"),
    };
}

fn residual_rows(out: &mut String, name: &str, s: &ResidualStats) {
    rms_row(out, &format!("{name} in flight"), s.rms_flight);
    rms_row(out, &format!("{name} at rest"), s.rms_rest);
}

fn lines_row(out: &mut String, name: &str, unit: &str, s: Option<&SensorSpectrum>) {
    let Some(s) = s else { return };
    let list: Vec<String> = s
        .lines
        .iter()
        .map(|l| {
            format!(
                "{:.2} Hz ({} {unit}, +{:.0} dB)",
                l.freq_hz,
                e(l.amplitude),
                l.excess_db
            )
        })
        .collect();
    let _ = writeln!(
        out,
        "    {name}: RMS below {:.1} Hz {}, above {} {unit}; lines: {}",
        s.above_hz,
        e(s.rms_below),
        e(s.rms_above),
        if list.is_empty() {
            "none".into()
        } else {
            list.join(", ")
        }
    );
}

/// The summary text.
pub fn summary(m: &ImuModel) -> String {
    let mut out = String::new();
    let s = &m.selection;
    let _ = writeln!(
        out,
        "{}: {} samples from {:.3} s to {:.3} s at {:.2} Hz ({} gaps)",
        m.log, s.samples, s.from_s, s.to_s, s.rate_hz, s.gaps
    );
    let mo = &m.motion;
    if mo.moving_blocks > 0 {
        let still = mo.longest_still_s.map_or_else(String::new, |[a, b]| {
            format!("; longest still stretch {a:.1}–{b:.1} s (--from {a:.1} --to {b:.1})")
        });
        let _ = writeln!(
            out,
            "WARNING: the log moves ({} of {} 1-s blocks, from {:.1} s): the raw Allan deviation is dominated by motion, not by the sensor's noise{still}",
            mo.moving_blocks,
            mo.blocks,
            mo.first_moving_s.unwrap_or(0.0)
        );
    } else {
        let _ = writeln!(out, "still: no motion in {} 1-s blocks", mo.blocks);
    }
    allan_block(&mut out, m, "Allan fit, raw log", false);
    if let Some(g) = &m.groundtruth {
        let _ = writeln!(
            out,
            "ground truth {}: {} rows every {:.3} s; implied IMU valid below {:.2} Hz (knots every {:.3} s); {} samples covered: {} at rest, {} in flight ({})",
            g.path,
            g.rows,
            g.period_s,
            g.valid_bandwidth_hz,
            g.knot_spacing_s,
            g.covered_samples,
            g.rest_samples,
            g.flight_samples,
            g.rest_rule
        );
        for (what, c) in [
            ("gyro magnitudes", &g.clock),
            ("rate vectors", &g.clock_vector),
        ] {
            let _ = match c {
                Some(c) => writeln!(
                    out,
                    "  clock by the {what}: the IMU's stamps are {:+.2} ms late against the ground truth (correlation {:.5}, {:.5} at 0 ms){}",
                    c.lag_ms,
                    c.correlation,
                    c.correlation_at_zero,
                    if c.at_search_limit {
                        format!(" — at the ±{:.0} ms search limit", c.search_ms)
                    } else {
                        String::new()
                    }
                ),
                None => writeln!(out, "  clock by the {what}: not determined"),
            };
        }
        match &g.frame {
            Some(f) => {
                let _ = writeln!(
                    out,
                    "  frame: implied → measured rate best rotated by {:.3}° (axis [{:.2}, {:.2}, {:.2}], RMS {} → {} rad/s, conditioning {:.2})",
                    f.angle_deg,
                    f.axis[0],
                    f.axis[1],
                    f.axis[2],
                    e(f.rms_before),
                    e(f.rms_after),
                    f.conditioning
                );
            }
            None => out.push_str("  frame: not determined\n"),
        }
        let _ = writeln!(
            out,
            "  residual RMS (measured − implied){:>7} {:>11} {:>11}",
            "x", "y", "z"
        );
        residual_rows(&mut out, "gyro rad/s", &g.residual.gyro);
        residual_rows(&mut out, "accel m/s²", &g.residual.accel);
        if let Some(k) = &m.sensor_yaml {
            let root = s.rate_hz.sqrt();
            let _ = writeln!(
                out,
                "    (sensor.yaml's white noise alone: {} rad/s, {} m/s² per sample)",
                e(k.gyroscope_noise_density * root),
                e(k.accelerometer_noise_density * root)
            );
        }
        if !g.rest_stretches_s.is_empty() {
            let list: Vec<String> = g
                .rest_stretches_s
                .iter()
                .map(|[a, b]| format!("{a:.2}–{b:.2} s"))
                .collect();
            let _ = writeln!(out, "  rest: {}", list.join(", "));
        }
        allan_block(&mut out, m, "Allan fit, residual", true);
        out.push_str("  residual spectrum in flight:\n");
        let f = m.spectrum.residual_flight.as_ref();
        lines_row(&mut out, "gyro", "rad/s", f.map(|p| &p.gyro));
        lines_row(&mut out, "accel", "m/s²", f.map(|p| &p.accel));
        if let Some(r) = &m.spectrum.residual_rest {
            out.push_str("  residual spectrum at rest:\n");
            lines_row(&mut out, "gyro", "rad/s", Some(&r.gyro));
            lines_row(&mut out, "accel", "m/s²", Some(&r.accel));
        }
        if let Some(f) = &m.error_model {
            error_model_rows(&mut out, f);
        }
        if let Some(n) = &m.estimator_noise {
            estimator_noise_rows(&mut out, n);
        }
    } else if let Some(r) = &m.spectrum.raw {
        out.push_str("spectrum of the raw log minus its mean:\n");
        lines_row(&mut out, "gyro", "rad/s", Some(&r.gyro));
        lines_row(&mut out, "accel", "m/s²", Some(&r.accel));
    }
    out
}

/// The estimator's noise model: the values and their reasoning.
fn estimator_noise_rows(out: &mut String, n: &super::EstimatorNoise) {
    let _ = writeln!(
        out,
        "estimator noise model (estimator_imu_noise.toml, for `[estimator.imu_noise]`), matched over {:.0}–{:.0} ms:",
        n.interval_s * 1e3,
        n.window_s * 1e3
    );
    for r in &n.reasoning {
        let _ = writeln!(out, "  {r}");
    }
}

/// The fitted error model: what it holds and how its predicted residual compares per octave.
fn error_model_rows(out: &mut String, f: &super::report::FittedErrorModel) {
    let bands = f
        .model
        .vibration
        .as_ref()
        .map_or(0, |v| v.rest.bands.len() + v.flight.bands.len());
    let lines = f
        .model
        .vibration
        .as_ref()
        .map_or(0, |v| v.rest.lines.len() + v.flight.lines.len());
    let _ = writeln!(
        out,
        "error model (error_model.toml, for `[rig.imu] error_model`): {bands} bands, {lines} lines, bias instability {}; calibrated in {} rounds",
        if f.model.bias_instability.is_some() {
            "yes"
        } else {
            "no"
        },
        f.iterations
    );
    for profile in ["flight", "rest"] {
        for sensor in ["gyro", "accel"] {
            let ratios: Vec<f64> = f
                .check
                .iter()
                .filter(|c| c.profile == profile && c.sensor == sensor && c.real_power > 0.0)
                .map(|c| c.predicted_power / c.real_power)
                .collect();
            if ratios.is_empty() {
                continue;
            }
            let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ratios.iter().copied().fold(0.0, f64::max);
            let _ = writeln!(
                out,
                "  predicted / real residual power per octave, {profile} {sensor}: {lo:.2}–{hi:.2} ({} octaves)",
                ratios.len()
            );
        }
    }
}
