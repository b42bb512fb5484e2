//! The window against the full-information filter (`vio run --batch-reference`): at
//! checkpoints during the run, the window's estimate of its newest frame and the estimate of
//! the same frame from the batch over every measurement received so far (no marginalization,
//! no fixed lag, the same factors and initial prior). With exact marginalization of a
//! linear-Gaussian problem the two would be equal: the gap is what linearizing early, the point
//! budget and dropped tracks cost — what "marginalization consistency" means. (The batch over
//! the whole run, [`super::window_vs_batch`], also smooths each frame with later measurements,
//! which no causal estimator can.)

use estimator::geometry::Pose;
use serde::Serialize;

use crate::metrics::{self, Alignment};
use crate::run_output::RunOutput;

/// `report.json`'s `filter_reference`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FilterReport {
    /// Checkpoints compared.
    pub checkpoints: usize,
    /// ATE RMSE of the window's newest estimates at the checkpoints (m), aligned to ground
    /// truth on their own as the run's ATE is.
    pub ate_window_m: f64,
    /// ATE RMSE of the filter's estimates of the same frames (m), aligned the same way.
    pub ate_filter_m: f64,
    /// `ate_window_m / ate_filter_m`.
    pub ratio: f64,
    /// Rotation ATE RMSE of the window and the filter (deg).
    pub ate_rot_deg: [f64; 2],
    /// Median and largest distance between the window's and the filter's positions (m).
    pub position_gap_m: [f64; 2],
    /// Median and largest angle between their rotations (deg).
    pub rotation_gap_deg: [f64; 2],
    /// Frames in the last checkpoint's batch.
    pub last_batch_frames: usize,
    /// Wall time of all the filter solves (s; measured for the report, never used to decide).
    pub solve_time_s: f64,
}

/// Median and largest of `v` (evo's statistics: an even count's median is the mean of the two
/// middle values); `v` is never empty here.
fn median_and_max(v: &[f64]) -> [f64; 2] {
    metrics::Stats::from_errors(v).map_or([0.0; 2], |s| [s.median, s.max])
}

/// Compares the run's filter checkpoints with the window; `None` without a batch reference or
/// with fewer than three checkpoints.
pub fn filter_report(run: &RunOutput, alignment: Alignment) -> Option<FilterReport> {
    let checkpoints = &run.batch_reference.as_ref()?.checkpoints;
    if checkpoints.len() < 3 {
        return None;
    }
    let truth: Vec<Pose> = checkpoints.iter().map(|c| c.truth).collect();
    let window: Vec<Pose> = checkpoints.iter().map(|c| c.window).collect();
    let filter: Vec<Pose> = checkpoints.iter().map(|c| c.filter.pose).collect();
    let aw = metrics::ate(&truth, &window, alignment).ok()?;
    let af = metrics::ate(&truth, &filter, alignment).ok()?;
    let position: Vec<f64> = checkpoints
        .iter()
        .map(|c| (c.window.p - c.filter.pose.p).norm())
        .collect();
    let rotation: Vec<f64> = checkpoints
        .iter()
        .map(|c| c.window.q.angle_to(&c.filter.pose.q).to_degrees())
        .collect();
    Some(FilterReport {
        checkpoints: checkpoints.len(),
        ate_window_m: aw.translation.rmse,
        ate_filter_m: af.translation.rmse,
        ratio: aw.translation.rmse / af.translation.rmse,
        ate_rot_deg: [aw.rotation_deg.rmse, af.rotation_deg.rmse],
        position_gap_m: median_and_max(&position),
        rotation_gap_deg: median_and_max(&rotation),
        last_batch_frames: checkpoints.last().map_or(0, |c| c.filter.frames),
        solve_time_s: checkpoints.iter().map(|c| c.time_s).sum(),
    })
}

/// The summary line of a filter reference.
pub fn summary_line(f: &FilterReport) -> String {
    format!(
        "{} checkpoints: ATE window {:.4} m, filter {:.4} m (x{:.2}); rotation {:.3} / {:.3} deg; \
         gap median {:.4} m {:.3} deg, max {:.4} m {:.3} deg; {:.1} s of solves",
        f.checkpoints,
        f.ate_window_m,
        f.ate_filter_m,
        f.ratio,
        f.ate_rot_deg[0],
        f.ate_rot_deg[1],
        f.position_gap_m[0],
        f.rotation_gap_deg[0],
        f.position_gap_m[1],
        f.rotation_gap_deg[1],
        f.solve_time_s
    )
}
