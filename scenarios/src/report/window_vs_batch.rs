//! The window against the full batch (`vio run --batch-reference`): the same measurements, the
//! same keyframes, solved once without marginalization at the end of the run. What the window
//! loses by marginalizing is the gap between its estimates and the batch's.
//!
//! All three trajectories are compared on the keyframes the batch solved, each aligned to
//! ground truth on its own as the run's ATE is (position+yaw with an IMU, SE(3) without):
//! - `window`: each keyframe's pose as it left the window (the fixed-lag estimate);
//! - `causal`: the pose the estimator reported when the keyframe was the newest frame;
//! - `batch`: the batch solution.

use std::collections::BTreeMap;

use estimator::geometry::Pose;
use serde::Serialize;

use crate::metrics::{self, Alignment};
use crate::run_output::RunOutput;

/// `report.json`'s `batch_reference`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BatchReport {
    /// Keyframes compared (every keyframe the batch solved that has a causal and a window
    /// estimate).
    pub keyframes: usize,
    /// ATE RMSE of the batch solution (m).
    pub ate_batch_m: f64,
    /// ATE RMSE of the poses as they left the window (m).
    pub ate_window_m: f64,
    /// ATE RMSE of the causal estimates (m).
    pub ate_causal_m: f64,
    /// `ate_window_m / ate_batch_m`.
    pub ratio_window: f64,
    /// `ate_causal_m / ate_batch_m`.
    pub ratio_causal: f64,
    /// Rotation ATE RMSE of the batch, the window and the causal estimates (deg).
    pub ate_rot_deg: [f64; 3],
    /// Iterations of the batch solve.
    pub batch_iterations: usize,
    /// Wall time of the batch solve (s; measured for the report, never used to decide).
    pub batch_time_s: f64,
}

/// Compares the run's batch reference with its window and causal estimates; `None` without a
/// batch reference or when fewer than three keyframes can be compared.
pub fn batch_report(run: &RunOutput, alignment: Alignment) -> Option<BatchReport> {
    let reference = run.batch_reference.as_ref()?;
    let summary = reference.summary.as_ref()?;
    let causal: BTreeMap<i64, (Pose, Pose)> = run
        .frames
        .iter()
        .filter(|f| f.estimate.status.initialized())
        .map(|f| (f.estimate.t_ns, (f.estimate.T_w_b, f.truth.pose)))
        .collect();
    let window: BTreeMap<i64, Pose> = reference.finalized.iter().copied().collect();
    let (mut gt, mut b, mut w, mut c) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (t, pose) in &reference.batch {
        if let (Some((causal_pose, truth)), Some(window_pose)) = (causal.get(t), window.get(t)) {
            gt.push(*truth);
            b.push(*pose);
            w.push(*window_pose);
            c.push(*causal_pose);
        }
    }
    if gt.len() < 3 {
        return None;
    }
    let ate = |est: &[Pose]| metrics::ate(&gt, est, alignment).ok();
    let (ab, aw, ac) = (ate(&b)?, ate(&w)?, ate(&c)?);
    let (eb, ew, ec) = (
        ab.translation.rmse,
        aw.translation.rmse,
        ac.translation.rmse,
    );
    Some(BatchReport {
        keyframes: gt.len(),
        ate_batch_m: eb,
        ate_window_m: ew,
        ate_causal_m: ec,
        ratio_window: ew / eb,
        ratio_causal: ec / eb,
        ate_rot_deg: [
            ab.rotation_deg.rmse,
            aw.rotation_deg.rmse,
            ac.rotation_deg.rmse,
        ],
        batch_iterations: summary.iterations,
        batch_time_s: summary.time.as_secs_f64(),
    })
}

/// The summary line of a batch reference.
pub fn summary_line(b: &BatchReport) -> String {
    format!(
        "{} keyframes: ATE batch {:.4} m, window {:.4} m (x{:.2}), causal {:.4} m (x{:.2}); \
         rotation {:.3} / {:.3} / {:.3} deg; batch {} iterations, {:.1} s",
        b.keyframes,
        b.ate_batch_m,
        b.ate_window_m,
        b.ratio_window,
        b.ate_causal_m,
        b.ratio_causal,
        b.ate_rot_deg[0],
        b.ate_rot_deg[1],
        b.ate_rot_deg[2],
        b.batch_iterations,
        b.batch_time_s
    )
}
