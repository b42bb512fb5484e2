//! `allan.png` and `spectrum.png`, drawn with the crate's plot helpers (embedded font, PNG via
//! `image`).

use plotters::coord::Shift;
use plotters::prelude::*;

use super::fit::NoiseFit;
use super::report::{ImuModel, SensorAllan, SensorSpectrum};
use crate::plot::{DrawResult, render_png};

const AXIS_COLORS: [RGBColor; 3] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(31, 119, 180),
];
const GREY: RGBColor = RGBColor(120, 120, 120);
const PANEL: (u32, u32) = (700, 480);

fn sci(v: &f64) -> String {
    format!("{v:.0e}")
}

/// Lower and upper bounds of the positive finite values, padded by a factor on a log scale.
fn log_bounds(values: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if lo > hi {
        (1e-6, 1.0)
    } else if lo == hi {
        (lo / 10.0, hi * 10.0)
    } else {
        (lo / pad, hi * pad)
    }
}

/// `allan.png`: the Allan deviation of each axis with its fitted model, gyro and accelerometer
/// side by side; a second row for the residual against the ground truth.
pub fn allan_png(m: &ImuModel) -> Result<Vec<u8>, String> {
    let mut rows = vec![("raw", &m.allan.raw)];
    if let Some(r) = &m.allan.residual {
        rows.push(("residual vs ground truth", r));
    }
    let size = (2 * PANEL.0, PANEL.1 * rows.len() as u32 + 50);
    let kalibr = m.sensor_yaml.as_ref().map(|k| {
        let model = |n: f64, rw: f64| NoiseFit {
            white_noise_density: n,
            bias_instability: 0.0,
            random_walk: rw,
            relative_rms_residual: 0.0,
        };
        (
            model(k.gyroscope_noise_density, k.gyroscope_random_walk),
            model(k.accelerometer_noise_density, k.accelerometer_random_walk),
        )
    });
    render_png(size, |buf| {
        let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(
            &format!("Allan deviation: {}", m.log),
            ("sans-serif", 22).into_font(),
        )?;
        let areas = root.split_evenly((rows.len(), 2));
        for (r, (what, pair)) in rows.iter().enumerate() {
            allan_panel(
                &areas[2 * r],
                &format!("{what}: gyro [rad/s]"),
                &pair.gyro,
                kalibr.map(|k| k.0),
            )?;
            allan_panel(
                &areas[2 * r + 1],
                &format!("{what}: accel [m/s²]"),
                &pair.accel,
                kalibr.map(|k| k.1),
            )?;
        }
        root.present()?;
        Ok(())
    })
}

fn allan_panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    title: &str,
    s: &SensorAllan,
    kalibr: Option<NoiseFit>,
) -> DrawResult {
    let taus = s.axes.iter().flat_map(|a| a.curve.tau_s.iter().copied());
    let (t0, t1) = log_bounds(taus, 1.2);
    let values = s.axes.iter().flat_map(|a| a.curve.adev.iter().copied());
    let reference = kalibr.iter().flat_map(|k| {
        [
            k.adev(t0),
            k.adev(t1),
            k.adev(3f64.sqrt() * k.white_noise_density / k.random_walk.max(f64::MIN_POSITIVE)),
        ]
    });
    let (y0, y1) = log_bounds(values.chain(reference), 2.0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18).into_font())
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((t0..t1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("τ [s]")
        .y_desc("σ(τ)")
        .x_label_formatter(&sci)
        .y_label_formatter(&sci)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for (a, color) in s.axes.iter().zip(AXIS_COLORS) {
        let pts: Vec<(f64, f64)> = a
            .curve
            .tau_s
            .iter()
            .zip(&a.curve.adev)
            .map(|(t, v)| (*t, *v))
            .filter(|p| p.1 > 0.0)
            .collect();
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), color.stroke_width(2)))?
            .label(a.axis)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        chart.draw_series(pts.iter().map(|p| Circle::new(*p, 2, color.filled())))?;
        if let Some(f) = a.fit {
            let model = pts.iter().map(|p| (p.0, f.adev(p.0).clamp(y0, y1)));
            chart.draw_series(DashedLineSeries::new(model, 6, 4, color.stroke_width(1)))?;
        }
    }
    chart
        .draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?
        .label("fit (dashed)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(1)));
    if let Some(k) = kalibr {
        let n = 60;
        let line = (0..=n).map(|i| {
            let t = t0 * (t1 / t0).powf(i as f64 / n as f64);
            (t, k.adev(t).clamp(y0, y1))
        });
        chart
            .draw_series(DashedLineSeries::new(line, 3, 3, GREY.stroke_width(2)))?
            .label("sensor.yaml (N, K)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], GREY.stroke_width(2)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()?;
    Ok(())
}

/// `spectrum.png`: the PSD (sum of the axes) of the raw log and, with ground truth, of the
/// residual in flight and at rest, with the detected lines marked.
pub fn spectrum_png(m: &ImuModel) -> Result<Vec<u8>, String> {
    let size = (2 * PANEL.0, PANEL.1 + 50);
    let bandwidth = m.groundtruth.as_ref().map(|g| g.valid_bandwidth_hz);
    let sp = &m.spectrum;
    let pick = |gyro: bool| {
        let get = |p: &Option<super::report::SensorPair<SensorSpectrum>>| {
            p.as_ref().map(|p| {
                if gyro {
                    p.gyro.clone()
                } else {
                    p.accel.clone()
                }
            })
        };
        [
            ("raw − mean", GREY, get(&sp.raw)),
            (
                "residual in flight",
                AXIS_COLORS[0],
                get(&sp.residual_flight),
            ),
            ("residual at rest", AXIS_COLORS[2], get(&sp.residual_rest)),
        ]
    };
    let panels = [
        ("gyro [(rad/s)²/Hz]", pick(true)),
        ("accel [(m/s²)²/Hz]", pick(false)),
    ];
    render_png(size, |buf| {
        let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
        root.fill(&WHITE)?;
        let root = root.titled(
            &format!("PSD, sum of x, y, z: {}", m.log),
            ("sans-serif", 22).into_font(),
        )?;
        let areas = root.split_evenly((1, 2));
        for ((title, series), area) in panels.iter().zip(&areas) {
            spectrum_panel(area, title, series, bandwidth)?;
        }
        root.present()?;
        Ok(())
    })
}

fn spectrum_panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    title: &str,
    series: &[(&str, RGBColor, Option<SensorSpectrum>); 3],
    bandwidth: Option<f64>,
) -> DrawResult {
    let present: Vec<(&str, RGBColor, &SensorSpectrum)> = series
        .iter()
        .filter_map(|(n, c, s)| s.as_ref().map(|s| (*n, *c, s)))
        .collect();
    let freqs = present.iter().flat_map(|s| s.2.psd.freq_hz.iter().copied());
    let (f0, f1) = log_bounds(freqs, 1.05);
    let dens = present
        .iter()
        .flat_map(|s| s.2.psd.density.iter().skip(1).copied());
    let (y0, y1) = log_bounds(dens, 2.0);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18).into_font())
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((f0..f1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc("f [Hz]")
        .y_desc("PSD")
        .x_label_formatter(&sci)
        .y_label_formatter(&sci)
        .label_style(("sans-serif", 13))
        .axis_desc_style(("sans-serif", 15))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for (name, color, s) in &present {
        let color = *color;
        let pts = s
            .psd
            .freq_hz
            .iter()
            .zip(&s.psd.density)
            .skip(1)
            .map(|(f, d)| (*f, d.clamp(y0, y1)));
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(1)))?
            .label(*name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
    }
    // Lines of the flight residual, or of the raw log without ground truth.
    if let Some((_, color, s)) = present.iter().rev().find(|p| p.0 != "residual at rest") {
        let color = *color;
        for l in &s.lines {
            let p = (l.freq_hz, l.peak_density.clamp(y0, y1));
            chart.draw_series(std::iter::once(Circle::new(p, 6, color.stroke_width(2))))?;
            chart.draw_series(std::iter::once(Text::new(
                format!("{:.1} Hz", l.freq_hz),
                (l.freq_hz * 1.05, (l.peak_density * 1.6).clamp(y0, y1)),
                ("sans-serif", 13).into_font(),
            )))?;
        }
    }
    if let Some(b) = bandwidth.filter(|b| *b > f0 && *b < f1) {
        chart
            .draw_series(DashedLineSeries::new(
                [(b, y0), (b, y1)],
                5,
                4,
                BLACK.stroke_width(1),
            ))?
            .label(format!("implied IMU valid below {b:.1} Hz"))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(1)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .label_font(("sans-serif", 14))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()?;
    Ok(())
}
