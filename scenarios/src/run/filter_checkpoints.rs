//! The full-information filter's checkpoints (`--batch-reference`): every [`period`] of the
//! run, once the estimator tracks, the batch over everything received so far
//! (`Estimator::filter_reference`) beside the window's estimate of the same newest frame.
//!
//! Determinism: the checkpoints fall on the first tracking estimate of each period of camera
//! time (the stamps, so seeds that estimate different time offsets still check the same
//! frames), a function of the input; only
//! [`FilterCheckpoint::time_s`] reads the wall clock.

use std::time::Instant;

use estimator::problem::SolverOptions;
use estimator::{Estimator, Status};

use super::{FilterCheckpoint, FrameRecord};

/// Checkpoints are this far apart (ns of run time) on runs of 20 s and more.
const PERIOD_NS: i64 = 2_000_000_000;
/// Shorter runs get this many checkpoints.
const SHORT_RUN_CHECKPOINTS: i64 = 10;
/// Iterations of each filter solve (it starts from the window's estimates).
const ITERATIONS: usize = 20;

/// The spacing of the checkpoints on a run ending at `end_ns`: [`PERIOD_NS`], or a tenth of a
/// run shorter than 20 s.
pub(crate) fn period(end_ns: i64) -> i64 {
    PERIOD_NS.min(end_ns / SHORT_RUN_CHECKPOINTS).max(1)
}

/// Collects the checkpoints while a run goes on.
#[derive(Debug)]
pub(crate) struct FilterCheckpoints {
    period_ns: i64,
    /// The period of the last checkpoint.
    last_period: Option<i64>,
    /// Frames recorded when last looked at.
    seen: usize,
    /// The checkpoints so far.
    pub list: Vec<FilterCheckpoint>,
}

impl FilterCheckpoints {
    /// Checkpoints every `period_ns` of run time.
    pub(crate) fn new(period_ns: i64) -> Self {
        Self {
            period_ns,
            last_period: None,
            seen: 0,
            list: Vec::new(),
        }
    }

    /// After an estimator call that recorded `frames` so far: a checkpoint when the newest
    /// estimate is a tracking one in a period without a checkpoint yet, and the filter solves
    /// the same newest frame.
    pub(crate) fn after_call(&mut self, estimator: &Estimator, frames: &[FrameRecord]) {
        if frames.len() == self.seen {
            return;
        }
        self.seen = frames.len();
        let Some(newest) = frames.last() else {
            return;
        };
        let e = &newest.estimate;
        // Periods of camera time: the same frames in every seed, whatever offset each estimates.
        let period = e.stamp_ns.div_euclid(self.period_ns);
        if e.status != Status::Tracking || self.last_period == Some(period) {
            return;
        }
        self.last_period = Some(period);
        let options = SolverOptions {
            max_iterations: ITERATIONS,
            ..Default::default()
        };
        let start = Instant::now();
        let Some(filter) = estimator.filter_reference(&options) else {
            return;
        };
        if filter.t_ns != e.t_ns {
            return;
        }
        self.list.push(FilterCheckpoint {
            t_ns: e.t_ns,
            window: e.T_w_b,
            filter,
            truth: newest.truth.pose,
            time_s: start.elapsed().as_secs_f64(),
        });
    }
}
