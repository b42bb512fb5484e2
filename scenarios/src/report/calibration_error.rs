//! `report.json` → `calibration`: the estimator's camera-IMU time offset and camera extrinsics
//! against the simulated truth, at the end and over time (scenarios that study calibration:
//! see [`crate::spec::Scenario::calibration_truth`]).

use estimator::geometry::{Pose, so3_log};
use serde::Serialize;

use crate::run_output::RunOutput;
use crate::spec::CalibrationTruth;

/// One camera's extrinsic error.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ExtrinsicError {
    /// Angle between the estimated and the true camera rotation (deg).
    pub rotation_error_deg: f64,
    /// Distance between the estimated and the true camera position in the body (mm).
    pub translation_error_mm: f64,
}

/// The calibration errors at one estimate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CalibrationSample {
    /// Time (s).
    pub t_s: f64,
    /// Estimated minus true time offset (ms).
    pub td_error_ms: f64,
    /// The time offset's marginal σ (ms), where the estimator gave one (`compute_covariance`).
    pub td_sigma_ms: Option<f64>,
    /// The largest camera rotation error (deg).
    pub rotation_error_deg: f64,
    /// The largest camera translation error (mm).
    pub translation_error_mm: f64,
}

/// `report.json` → `calibration`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// The true time offset at the last estimate (ms).
    pub td_true_ms: f64,
    /// Final estimated minus true time offset (ms).
    pub td_error_ms: f64,
    /// Final extrinsic errors, camera by camera.
    pub cameras: Vec<ExtrinsicError>,
    /// The errors at the first estimate of every whole second.
    pub history: Vec<CalibrationSample>,
    /// How far the time offset strayed from the truth after the start-up.
    pub td_excursion: Option<TdExcursion>,
}

/// How long after the first estimate the start-up lasts for [`TdExcursion`] (s).
pub const TD_EXCURSION_AFTER_S: f64 = 1.0;

/// The time offset's largest error over every estimate from [`TD_EXCURSION_AFTER_S`] after the
/// first one on: a right offset should stay within a few of its own σ of the truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TdExcursion {
    /// The start-up left out (s after the first estimate).
    pub after_s: f64,
    /// The largest |estimated − true| (ms).
    pub max_error_ms: f64,
    /// When it was reached (s).
    pub at_s: f64,
    /// The largest |estimated − true| / σ over the estimates that carry a σ; `None` without
    /// (a run without `compute_covariance`).
    pub max_error_sigmas: Option<f64>,
    /// The mean of (error / σ)² over the same estimates: about 1 where the σ is honest (the
    /// time offset's NEES; neighbouring estimates are strongly correlated, so one run's mean
    /// spreads widely around 1).
    pub mean_squared_sigmas: Option<f64>,
}

fn extrinsic_error(est: &Pose, truth: &Pose) -> ExtrinsicError {
    ExtrinsicError {
        rotation_error_deg: so3_log(&(truth.q.inverse() * est.q)).norm().to_degrees(),
        translation_error_mm: (est.p - truth.p).norm() * 1e3,
    }
}

/// The calibration report of `run` against `truth`; `None` without estimates.
pub fn calibration_report(truth: &CalibrationTruth, run: &RunOutput) -> Option<CalibrationReport> {
    let td_error_ms = |e: &estimator::Estimate| (e.td_s - truth.td_at(e.t_ns)) * 1e3;
    let sample = |e: &estimator::Estimate| {
        let errors: Vec<ExtrinsicError> = e
            .T_b_c
            .iter()
            .zip(&truth.T_b_c)
            .map(|(est, tru)| extrinsic_error(est, tru))
            .collect();
        let max = |f: fn(&ExtrinsicError) -> f64| errors.iter().map(f).fold(0.0, f64::max);
        (
            CalibrationSample {
                t_s: e.t_ns as f64 * 1e-9,
                td_error_ms: td_error_ms(e),
                td_sigma_ms: e.td_sigma_s.map(|s| s * 1e3),
                rotation_error_deg: max(|x| x.rotation_error_deg),
                translation_error_mm: max(|x| x.translation_error_mm),
            },
            errors,
        )
    };
    let last = run.frames.last()?;
    let (end, cameras) = sample(&last.estimate);
    let mut history = Vec::new();
    let mut next_s = 0.0;
    for f in &run.frames {
        let t = f.estimate.t_ns as f64 * 1e-9;
        if t >= next_s {
            history.push(sample(&f.estimate).0);
            next_s = t.floor() + 1.0;
        }
    }
    let after_ns = run.frames.first()?.estimate.t_ns + (TD_EXCURSION_AFTER_S * 1e9).round() as i64;
    let td_excursion = td_excursion(
        run.frames
            .iter()
            .map(|f| &f.estimate)
            .filter(|e| e.t_ns >= after_ns)
            .map(|e| (e.t_ns as f64 * 1e-9, td_error_ms(e).abs(), e.td_sigma_s)),
    );
    Some(CalibrationReport {
        td_true_ms: truth.td_at(last.estimate.t_ns) * 1e3,
        td_error_ms: end.td_error_ms,
        cameras,
        history,
        td_excursion,
    })
}

/// [`TdExcursion`] over the estimates after the start-up, each `(t_s, |error| ms, σ s)`;
/// `None` without any.
fn td_excursion(samples: impl Iterator<Item = (f64, f64, Option<f64>)>) -> Option<TdExcursion> {
    let samples: Vec<_> = samples.collect();
    // The first of equal largest errors.
    let &(at_s, max_error_ms, _) = samples
        .iter()
        .reduce(|a, b| if b.1 > a.1 { b } else { a })?;
    let sigmas: Vec<f64> = samples
        .iter()
        .filter_map(|&(_, error_ms, s)| s.map(|s| error_ms / (s * 1e3).max(f64::MIN_POSITIVE)))
        .collect();
    let stats = crate::metrics::Stats::from_errors(&sigmas);
    Some(TdExcursion {
        after_s: TD_EXCURSION_AFTER_S,
        max_error_ms,
        at_s,
        max_error_sigmas: stats.map(|s| s.max),
        mean_squared_sigmas: stats.map(|s| s.sse / s.count as f64),
    })
}

/// `calibration.png`: the time-offset error and the worst camera's rotation and translation
/// errors over the run (once per second, as in the report).
pub fn calibration_png(scenario: &str, c: &CalibrationReport) -> Result<Vec<u8>, String> {
    let series = |f: fn(&CalibrationSample) -> f64| -> Vec<(f64, f64)> {
        c.history.iter().map(|s| (s.t_s, f(s))).collect()
    };
    let panels = [
        crate::plot::SeriesPanel {
            title: format!(
                "time offset: estimated minus true (true {:.1} ms)",
                c.td_true_ms
            ),
            y_desc: "td error [ms]".into(),
            series: series(|s| s.td_error_ms),
        },
        crate::plot::SeriesPanel {
            title: "extrinsic rotation error (worst camera)".into(),
            y_desc: "[deg]".into(),
            series: series(|s| s.rotation_error_deg),
        },
        crate::plot::SeriesPanel {
            title: "extrinsic translation error (worst camera)".into(),
            y_desc: "[mm]".into(),
            series: series(|s| s.translation_error_mm),
        },
    ];
    crate::plot::series_png(&format!("{scenario}: calibration errors"), &panels)
}
