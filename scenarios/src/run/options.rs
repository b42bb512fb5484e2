//! How to run: the overrides of one run, and the caller's progress callback and stop flag.

use std::sync::atomic::{AtomicBool, Ordering};

/// Overrides for one run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunOptions {
    /// Seed instead of the scenario's `world.seed` (a recorded dataset: of the front end's
    /// RANSAC, 1 when not given).
    pub seed: Option<u64>,
    /// Duration (s) instead of the scenario's `trajectory.duration_s` (a recorded dataset: only
    /// its first seconds).
    pub duration_s: Option<f64>,
    /// Also solve the full batch over the window's keyframes at the end
    /// ([`RunOutput::batch_reference`](super::RunOutput::batch_reference)).
    pub batch_reference: bool,
    /// Compute the newest state's covariance with every estimate (`vio nees`).
    pub covariance: bool,
    /// Record the window (frame poses, persistent points) with every estimate, for the run's
    /// MCAP file (`--mcap`).
    pub scene: bool,
}

/// What the caller sees of a run while it goes: its progress, and a flag that stops it.
#[derive(Default)]
pub struct RunControl<'a> {
    /// Called with the fraction of the run's time done (0..=1).
    pub progress: Option<&'a mut dyn FnMut(f64)>,
    /// Once set (Ctrl-C), the input ends there: the estimator processes what it holds, and the
    /// output covers the run so far
    /// ([`RunOutput::interrupted_at_s`](super::RunOutput::interrupted_at_s)).
    pub stop: Option<&'a AtomicBool>,
    /// Where an outside estimator's files go and stay (`estimator_adapter`: the export it reads,
    /// the folder it writes, its log); `None`: a temporary folder, removed after the run.
    pub workspace: Option<&'a std::path::Path>,
}

impl RunControl<'_> {
    /// Reports `fraction` of the run done.
    pub(crate) fn report(&mut self, fraction: f64) {
        if let Some(p) = self.progress.as_mut() {
            p(fraction);
        }
    }

    /// Whether the caller asked the run to stop.
    pub(crate) fn stopped(&self) -> bool {
        self.stop.is_some_and(|s| s.load(Ordering::Relaxed))
    }
}
