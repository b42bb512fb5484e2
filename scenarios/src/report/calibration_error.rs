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
}

fn extrinsic_error(est: &Pose, truth: &Pose) -> ExtrinsicError {
    ExtrinsicError {
        rotation_error_deg: so3_log(&(truth.q.inverse() * est.q)).norm().to_degrees(),
        translation_error_mm: (est.p - truth.p).norm() * 1e3,
    }
}

/// The calibration report of `run` against `truth`; `None` without estimates.
pub fn calibration_report(truth: &CalibrationTruth, run: &RunOutput) -> Option<CalibrationReport> {
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
                td_error_ms: (e.td_s - truth.td_at(e.t_ns)) * 1e3,
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
    Some(CalibrationReport {
        td_true_ms: truth.td_at(last.estimate.t_ns) * 1e3,
        td_error_ms: end.td_error_ms,
        cameras,
        history,
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
