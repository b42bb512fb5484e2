//! `report.json` → `rest`: how the estimator's zero-velocity detection compares with the truth
//! (frames at rest by the simulated speed), and how far the estimate moved while the body stood
//! still.

use serde::Serialize;

use crate::run_output::RunOutput;

/// The true speeds (m/s) that separate rest from motion in the ground truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestSpeeds {
    /// Below: the frame counts as at rest.
    pub rest_m_s: f64,
    /// Above: a detection is false, the body is plainly moving.
    pub moving_m_s: f64,
}

impl RestSpeeds {
    /// A simulation's: its rests are exact to the controller's tracking, well under a
    /// millimetre per second.
    pub const SIMULATED: RestSpeeds = RestSpeeds {
        rest_m_s: 1e-3,
        moving_m_s: 0.01,
    };

    /// A recording's: motion-capture velocities carry the noise of their differentiation
    /// (EuRoC V1_01 at rest on the floor: 3–6 mm/s on average, up to 15 mm/s), and a
    /// multirotor that takes off passes 0.1 m/s within a frame.
    pub const RECORDED: RestSpeeds = RestSpeeds {
        rest_m_s: crate::imu_model::residual::REST_SPEED_M_S,
        moving_m_s: 0.05,
    };
}

/// One rest of the body: an interval of consecutive evaluated frames at rest.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RestInterval {
    /// First and last frame time (s).
    pub start_s: f64,
    /// Last frame time (s).
    pub end_s: f64,
    /// Distance between the estimated positions at the first and the last frame (m): the
    /// estimate's drift while the body stood still.
    pub drift_m: f64,
    /// Fraction of its frames the estimator detected at rest.
    pub detected_fraction: f64,
}

/// `report.json` → `rest`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RestReport {
    /// Evaluated frames at rest by the truth.
    pub frames_at_rest: usize,
    /// Frames the estimator detected at rest.
    pub frames_detected: usize,
    /// Detections while the body moved faster than [`RestSpeeds::moving_m_s`].
    pub false_detections: usize,
    /// The rests, in time order (at least two frames each).
    pub rests: Vec<RestInterval>,
    /// The largest drift during a rest (m); `null` without rests.
    pub max_drift_m: Option<f64>,
}

/// The rest block of a run: `None` when the body never rests and nothing was detected.
pub fn rest_report(run: &RunOutput, speeds: RestSpeeds) -> Option<RestReport> {
    let frames: Vec<_> = run
        .frames
        .iter()
        .filter(|f| f.estimate.status.initialized())
        .collect();
    let at_rest = |f: &crate::run_output::FrameRecord| f.truth.v_w.norm() < speeds.rest_m_s;
    let frames_at_rest = frames.iter().filter(|f| at_rest(f)).count();
    let frames_detected = frames.iter().filter(|f| f.estimate.at_rest).count();
    if frames_at_rest == 0 && frames_detected == 0 {
        return None;
    }
    let false_detections = frames
        .iter()
        .filter(|f| f.estimate.at_rest && f.truth.v_w.norm() > speeds.moving_m_s)
        .count();
    let mut rests = Vec::new();
    let mut i = 0;
    while i < frames.len() {
        if !at_rest(frames[i]) {
            i += 1;
            continue;
        }
        let start = i;
        while i < frames.len() && at_rest(frames[i]) {
            i += 1;
        }
        let run_of = &frames[start..i];
        if run_of.len() < 2 {
            continue;
        }
        let (a, b) = (run_of[0], run_of[run_of.len() - 1]);
        rests.push(RestInterval {
            start_s: a.estimate.t_ns as f64 * 1e-9,
            end_s: b.estimate.t_ns as f64 * 1e-9,
            drift_m: (b.estimate.T_w_b.p - a.estimate.T_w_b.p).norm(),
            detected_fraction: run_of.iter().filter(|f| f.estimate.at_rest).count() as f64
                / run_of.len() as f64,
        });
    }
    let max_drift_m = rests.iter().map(|r| r.drift_m).reduce(f64::max);
    Some(RestReport {
        frames_at_rest,
        frames_detected,
        false_detections,
        rests,
        max_drift_m,
    })
}
