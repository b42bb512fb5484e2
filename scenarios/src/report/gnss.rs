//! `report.json` → `gnss`: the estimate in the GNSS receiver's frame (the simulator's world
//! frame) through the estimator's own alignment `T_g_w`, against the truth, with no trajectory
//! alignment: what a user of the fused position would see.

use serde::Serialize;

use crate::run_output::RunOutput;

/// `report.json` → `gnss`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GnssReport {
    /// Time (s) of the first estimate with an alignment.
    pub aligned_at_s: f64,
    /// Frames evaluated (initialized, aligned).
    pub frames: usize,
    /// RMS of the global position error over those frames (m).
    pub global_rmse_m: f64,
    /// Largest global position error (m).
    pub global_max_m: f64,
    /// Global position error of the last frame (m).
    pub global_final_m: f64,
    /// `[t_s, error_m]` once per second (the first aligned frame of each second).
    pub global_error_series: Vec<[f64; 2]>,
}

/// The GNSS block of a run: `None` when the estimator never aligned with a receiver.
pub fn gnss_report(run: &RunOutput) -> Option<GnssReport> {
    let errors: Vec<(f64, f64)> = run
        .frames
        .iter()
        .filter(|f| f.estimate.status.initialized())
        .filter_map(|f| {
            let a = f.estimate.gnss_alignment?;
            let e = (a.to_gnss(&f.estimate.T_w_b.p) - f.truth.pose.p).norm();
            Some((f.estimate.t_ns as f64 * 1e-9, e))
        })
        .collect();
    let (first, last) = (errors.first()?, errors.last()?);
    let n = errors.len() as f64;
    let mut series = Vec::new();
    for &(t, e) in &errors {
        if series
            .last()
            .is_none_or(|[s, _]: &[f64; 2]| t.floor() > s.floor())
        {
            series.push([t, e]);
        }
    }
    Some(GnssReport {
        aligned_at_s: first.0,
        frames: errors.len(),
        global_rmse_m: (errors.iter().map(|(_, e)| e * e).sum::<f64>() / n).sqrt(),
        global_max_m: errors.iter().map(|(_, e)| *e).fold(0.0, f64::max),
        global_final_m: last.1,
        global_error_series: series,
    })
}

/// `gnss.png`: the fused position's error in the receiver's frame over time (once per second,
/// as in the report), no trajectory alignment.
pub fn gnss_png(scenario: &str, g: &GnssReport) -> Result<Vec<u8>, String> {
    let panels = [crate::plot::SeriesPanel {
        title: format!(
            "position error in the GNSS frame through the estimated alignment (aligned at {:.1} s)",
            g.aligned_at_s
        ),
        y_desc: "[m]".into(),
        series: g
            .global_error_series
            .iter()
            .map(|[t, e]| (*t, *e))
            .collect(),
    }];
    crate::plot::series_png(&format!("{scenario}: global position error"), &panels)
}
