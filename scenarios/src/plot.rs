//! `trajectory.png`: a top view (x–y, equal scale) of ground truth and the aligned estimate, and
//! the position error over time with fault intervals shaded.
//!
//! Drawn with plotters' bitmap backend into an RGB buffer and encoded with `image`; text uses the
//! embedded Roboto font (`scenarios/assets/fonts`), so no system font library is involved.

use std::io::Cursor;
use std::sync::Once;

use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

/// The embedded font (Apache-2.0, see `scenarios/assets/fonts/README.md`).
const FONT: &[u8] = include_bytes!("../assets/fonts/Roboto-Regular.ttf");

/// Image size (px).
const SIZE: (u32, u32) = (1000, 1150);
/// Height of the top-view panel (px).
const TOP_H: u32 = 760;

/// What the plot shows.
#[derive(Clone, Debug, Default)]
pub struct PlotData {
    /// Title line.
    pub title: String,
    /// Ground truth positions (x, y) at every processed frame (m).
    pub ground_truth_xy: Vec<(f64, f64)>,
    /// Aligned estimate positions (x, y) in tracking state (m).
    pub estimate_xy: Vec<(f64, f64)>,
    /// Position error over time: (t s, error m).
    pub error_m: Vec<(f64, f64)>,
    /// Run length (s).
    pub duration_s: f64,
    /// When tracking began (s).
    pub tracking_from_s: Option<f64>,
    /// Fault intervals (kind, start s, end s).
    pub faults: Vec<(String, f64, f64)>,
    /// ATE RMSE (m), for the legend.
    pub ate_rmse_m: Option<f64>,
    /// Alignment name, for the legend.
    pub alignment: &'static str,
}

pub(crate) fn register() -> Result<(), String> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result = register_font("sans-serif", FontStyle::Normal, FONT)
            .map_err(|_| "the embedded font is invalid".to_string());
    });
    result
}

/// Expands `[lo, hi]` to a span of at least `min_span`, plus a relative margin.
fn padded(lo: f64, hi: f64, min_span: f64, margin: f64) -> (f64, f64) {
    let c = 0.5 * (lo + hi);
    let half = 0.5 * (hi - lo).max(min_span) * (1.0 + 2.0 * margin);
    (c - half, c + half)
}

/// Renders the plot as PNG bytes.
pub fn trajectory_png(data: &PlotData) -> Result<Vec<u8>, String> {
    render_png(SIZE, |buf| draw(data, buf))
}

pub(crate) type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// Draws into a white-initialized RGB buffer of `(w, h)` with the embedded font registered and
/// encodes it as PNG.
pub(crate) fn render_png(
    (w, h): (u32, u32),
    draw: impl FnOnce(&mut [u8]) -> DrawResult,
) -> Result<Vec<u8>, String> {
    register()?;
    let mut buf = vec![0u8; (w * h * 3) as usize];
    draw(&mut buf).map_err(|e| format!("cannot draw the plot: {e}"))?;
    let img = image::RgbImage::from_raw(w, h, buf).ok_or("plot buffer has the wrong size")?;
    let mut png = Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png)
        .map_err(|e| format!("cannot encode the plot: {e}"))?;
    Ok(png.into_inner())
}

fn draw(d: &PlotData, buf: &mut [u8]) -> DrawResult {
    let root = BitMapBackend::with_buffer(buf, SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(TOP_H);
    let gt_color = RGBColor(40, 40, 40);
    let est_color = RGBColor(214, 39, 40);
    let fault_color = RGBColor(255, 160, 60);

    // Top view with equal scale on both axes.
    let pts = d.ground_truth_xy.iter().chain(&d.estimate_xy);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (-1.0, 1.0, -1.0, 1.0);
    }
    let (margin, label_y, label_x, caption) = (20u32, 70u32, 50u32, 40u32);
    let plot_w = f64::from(SIZE.0 - 2 * margin - label_y);
    let plot_h = f64::from(TOP_H - 2 * margin - label_x - caption);
    // Equal scale (m per px) on both axes; the data stays below the legend's band at the top.
    let legend_px = 100.0;
    let (ax0, ax1) = padded(x0, x1, 0.5, 0.05);
    let (dy0, dy1) = padded(y0, y1, 0.5, 0.05);
    let scale = ((ax1 - ax0) / plot_w).max((dy1 - dy0) / (plot_h - legend_px));
    let (ax0, ax1) = padded(0.5 * (ax0 + ax1), 0.5 * (ax0 + ax1), scale * plot_w, 0.0);
    let free = (plot_h - legend_px) * scale - (dy1 - dy0);
    let ay0 = dy0 - 0.5 * free;
    let ay1 = ay0 + plot_h * scale;
    let mut chart = ChartBuilder::on(&top)
        .caption(&d.title, ("sans-serif", 26).into_font())
        .margin(margin)
        .x_label_area_size(label_x)
        .y_label_area_size(label_y)
        .build_cartesian_2d(ax0..ax1, ay0..ay1)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    chart
        .draw_series(LineSeries::new(
            d.ground_truth_xy.iter().copied(),
            gt_color.stroke_width(2),
        ))?
        .label("ground truth")
        .legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 24, y)], gt_color.stroke_width(2))
        });
    let est_label = match d.ate_rmse_m {
        Some(a) => format!(
            "estimate ({} aligned), ATE {:.3} m",
            d.alignment.replace('_', "+"),
            a
        ),
        None => "estimate (no tracking frames)".into(),
    };
    chart
        .draw_series(LineSeries::new(
            d.estimate_xy.iter().copied(),
            est_color.stroke_width(2),
        ))?
        .label(est_label)
        .legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 24, y)], est_color.stroke_width(2))
        });
    if let Some(&p) = d.ground_truth_xy.first() {
        chart
            .draw_series(std::iter::once(Circle::new(p, 6, gt_color.filled())))?
            .label("start")
            .legend(move |(x, y)| Circle::new((x + 12, y), 5, gt_color.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font(("sans-serif", 17))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()?;

    // Position error over time.
    let t_max = d.duration_s.max(1e-3);
    let e_max = d
        .error_m
        .iter()
        .map(|p| p.1)
        .fold(0.0f64, f64::max)
        .max(1e-3)
        * 1.15;
    let mut err = ChartBuilder::on(&bottom)
        .caption(
            "position error after alignment",
            ("sans-serif", 20).into_font(),
        )
        .margin(margin)
        .x_label_area_size(label_x)
        .y_label_area_size(label_y)
        .build_cartesian_2d(0.0..t_max, 0.0..e_max)?;
    err.configure_mesh()
        .x_desc("t [s]")
        .y_desc("error [m]")
        .label_style(("sans-serif", 16))
        .axis_desc_style(("sans-serif", 18))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    if let Some(t0) = d.tracking_from_s
        && t0 > 0.0
    {
        err.draw_series(std::iter::once(Rectangle::new(
            [(0.0, 0.0), (t0.min(t_max), e_max)],
            RGBColor(225, 225, 225).filled(),
        )))?
        .label("initializing")
        .legend(|(x, y)| {
            Rectangle::new(
                [(x, y - 6), (x + 24, y + 6)],
                RGBColor(225, 225, 225).filled(),
            )
        });
    }
    for (i, (kind, a, b)) in d.faults.iter().enumerate() {
        let s = err.draw_series(std::iter::once(Rectangle::new(
            [(a.clamp(0.0, t_max), 0.0), (b.clamp(0.0, t_max), e_max)],
            fault_color.mix(0.35).filled(),
        )))?;
        if i == 0 {
            s.label(format!("fault: {}", kind.replace('_', " ")))
                .legend(move |(x, y)| {
                    Rectangle::new(
                        [(x, y - 6), (x + 24, y + 6)],
                        fault_color.mix(0.35).filled(),
                    )
                });
        }
    }
    err.draw_series(LineSeries::new(
        d.error_m.iter().copied(),
        est_color.stroke_width(2),
    ))?
    .label("|p_est - p_gt|")
    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], est_color.stroke_width(2)));
    err.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(("sans-serif", 17))
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(180, 180, 180))
        .draw()?;
    root.present()?;
    Ok(())
}

/// One panel of `nees.png`: a metric's run-averaged NEES over time and its 95 % band.
#[derive(Clone, Debug)]
pub struct NeesPanel {
    /// Panel caption.
    pub title: String,
    /// `(t s, NEES)`.
    pub series: Vec<(f64, f64)>,
    /// The band `[lo, hi]`.
    pub band: [f64; 2],
}

/// `nees.png`: one panel per metric, the NEES over time with the band's bounds.
pub fn nees_png(title: &str, panels: &[NeesPanel]) -> Result<Vec<u8>, String> {
    let size = (1000u32, 260 * panels.len().max(1) as u32 + 60);
    render_png(size, |buf| draw_nees(title, panels, size, buf))
}

fn draw_nees(title: &str, panels: &[NeesPanel], size: (u32, u32), buf: &mut [u8]) -> DrawResult {
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 24).into_font())?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    let band_color = RGBColor(60, 120, 200);
    let nees_color = RGBColor(214, 39, 40);
    for (p, area) in panels.iter().zip(&areas) {
        let t1 = p.series.last().map_or(1.0, |s| s.0).max(1e-3);
        let t0 = p.series.first().map_or(0.0, |s| s.0).min(t1 - 1e-3);
        // Linear from 0 (a log axis inside one decade gets no or unreadable tick labels); the
        // top at least 1.5× the band, at most 4×, so a start-up transient cannot squash it.
        let peak = p
            .series
            .iter()
            .map(|s| s.1)
            .filter(|v| v.is_finite())
            .fold(0.0, f64::max);
        let hi = 1.05 * peak.clamp(1.5 * p.band[1], 4.0 * p.band[1]);
        let mut chart = ChartBuilder::on(area)
            .caption(&p.title, ("sans-serif", 18).into_font())
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1, 0.0..hi)?;
        chart
            .configure_mesh()
            .x_desc("t [s]")
            .y_desc("NEES")
            .y_label_formatter(&|v| format!("{v:.1}"))
            .label_style(("sans-serif", 13))
            .draw()?;
        for b in p.band {
            chart.draw_series(LineSeries::new(
                [(t0, b), (t1, b)],
                band_color.stroke_width(2),
            ))?;
        }
        chart.draw_series(LineSeries::new(
            p.series.iter().map(|&(t, v)| (t, v.min(hi))),
            nees_color.stroke_width(1),
        ))?;
    }
    root.present()?;
    Ok(())
}

/// One panel of a time-series plot: a caption, the y axis label and `(t s, value)` points.
#[derive(Clone, Debug)]
pub struct SeriesPanel {
    /// Panel caption.
    pub title: String,
    /// Y axis label.
    pub y_desc: String,
    /// `(t s, value)`.
    pub series: Vec<(f64, f64)>,
}

/// `calibration.png` and similar: one panel per series over time, with the zero line.
pub fn series_png(title: &str, panels: &[SeriesPanel]) -> Result<Vec<u8>, String> {
    let size = (1000u32, 240 * panels.len().max(1) as u32 + 60);
    render_png(size, |buf| draw_series(title, panels, size, buf))
}

fn draw_series(
    title: &str,
    panels: &[SeriesPanel],
    size: (u32, u32),
    buf: &mut [u8],
) -> DrawResult {
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 24).into_font())?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    let color = RGBColor(214, 39, 40);
    for (p, area) in panels.iter().zip(&areas) {
        let t1 = p.series.last().map_or(1.0, |s| s.0).max(1e-3);
        let t0 = p.series.first().map_or(0.0, |s| s.0).min(t1 - 1e-3);
        let finite = p.series.iter().map(|s| s.1).filter(|v| v.is_finite());
        let (lo, hi) = finite.fold((0.0f64, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
        let pad = 0.05 * (hi - lo).max(1e-9);
        let mut chart = ChartBuilder::on(area)
            .caption(&p.title, ("sans-serif", 18).into_font())
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1, (lo - pad)..(hi + pad))?;
        chart
            .configure_mesh()
            .x_desc("t [s]")
            .y_desc(p.y_desc.as_str())
            .label_style(("sans-serif", 13))
            .draw()?;
        chart.draw_series(LineSeries::new(
            [(t0, 0.0), (t1, 0.0)],
            BLACK.stroke_width(1),
        ))?;
        chart.draw_series(LineSeries::new(
            p.series.iter().copied().filter(|s| s.1.is_finite()),
            color.stroke_width(2),
        ))?;
    }
    root.present()?;
    Ok(())
}
