//! The one driver loop: a source's inputs, in time order, into the estimator, each answer into
//! the recorder. Simulated scenarios and recorded datasets are sources
//! ([`simulated`](super::simulated), [`recorded`](super::recorded)).

use std::time::Instant;

use estimator::frontend::{FeatureFrame, ImageView};
use estimator::imu::ImuSample;
use estimator::problem::SolverOptions;
use estimator::{Estimate, Estimator};
use estimator::{GnssSample, WheelSample};
use sim::stream::GroundTruth;

use super::filter_checkpoints::{FilterCheckpoints, period};
use super::{BatchReference, Recorder, RunControl, RunError, RunOptions, RunOutput};

/// One input for the estimator.
pub(crate) enum Input {
    /// An IMU sample (already given to the source's front end).
    Imu(ImuSample),
    /// A feature frame, and the front end's time to make it (s; ~0 for feature-level input).
    Frame {
        /// The frame.
        frame: FeatureFrame,
        /// The front end's time (s).
        frontend_s: f64,
    },
    /// A GNSS fix.
    Gnss(GnssSample),
    /// A wheel-odometry reading.
    Wheel(WheelSample),
}

impl Input {
    /// The input's stamp (ns, the run's clock).
    fn t_ns(&self) -> i64 {
        match self {
            Input::Imu(s) => s.t_ns,
            Input::Frame { frame, .. } => frame.t_ns,
            Input::Gnss(g) => g.t_ns,
            Input::Wheel(w) => w.t_ns,
        }
    }
}

/// Where a run's inputs and ground truth come from.
pub(crate) trait Source {
    /// The run's end (ns, the run's clock, which starts at 0).
    fn end_ns(&self) -> i64;
    /// The next input in time order; `None` at the end of the data.
    fn next_input(&mut self) -> Result<Option<Input>, RunError>;
    /// The time spent rendering the latest images (s); 0 for input that is not rendered.
    fn render_s(&self) -> f64 {
        0.0
    }
    /// The first camera's image of the frame the source gave last; `None` for input that is
    /// not images (or a frame without the first camera).
    fn latest_image(&self) -> Option<ImageView<'_>> {
        None
    }
    /// Ground truth at an estimate's time; `None` where there is none.
    fn truth(&mut self, estimate: &Estimate) -> Option<GroundTruth>;
    /// What the source adds to the output at the end (the front end's statistics); an error
    /// that ended its data early. `interrupted`: the caller stopped the run.
    fn finish(self, out: &mut RunOutput, interrupted: bool) -> Result<(), RunError>;
}

/// Feeds everything `source` has (until `control` stops it) to `estimator`, then lets the
/// estimator finish; `recorder` collects the output.
pub(crate) fn drive(
    mut source: impl Source,
    mut estimator: Estimator,
    mut recorder: Recorder,
    options: &RunOptions,
    control: &mut RunControl,
) -> Result<(RunOutput, usize), RunError> {
    let end_ns = source.end_ns();
    recorder.scene = options.scene;
    let mut last_progress = -1.0;
    let mut finished = false;
    let mut now_ns: i64 = 0;
    let mut checkpoints = FilterCheckpoints::new(period(end_ns));
    while !finished {
        let input = if control.stopped() {
            recorder
                .out
                .interrupted_at_s
                .get_or_insert(now_ns as f64 * 1e-9);
            None
        } else {
            source.next_input()?
        };
        let t_ns = input.as_ref().map_or(end_ns, Input::t_ns);
        now_ns = now_ns.max(t_ns.min(end_ns));
        let start = Instant::now();
        let result = match input {
            None => {
                // End of the data: the estimator judges its last IMU samples and processes
                // the frames still waiting for them.
                finished = true;
                estimator.finish()
            }
            Some(Input::Imu(s)) => {
                recorder.out.imu_samples += 1;
                estimator.push_imu(s)
            }
            Some(Input::Frame { frame, frontend_s }) => {
                let image = if options.scene {
                    source.latest_image()
                } else {
                    None
                };
                recorder.frame_pushed(&frame, frontend_s, source.render_s(), image);
                estimator.push_frame(frame)
            }
            Some(Input::Gnss(fix)) => estimator.push_gnss(fix),
            Some(Input::Wheel(reading)) => estimator.push_wheel(reading),
        };
        let call_s = start.elapsed().as_secs_f64();
        let render_s = source.render_s();
        recorder.absorb(&mut estimator, result, t_ns, call_s, render_s, |e| {
            source.truth(e)
        })?;
        if options.batch_reference {
            checkpoints.after_call(&estimator, &recorder.out.frames);
        }
        let frac = (t_ns as f64 / end_ns.max(1) as f64).clamp(0.0, 1.0);
        if frac - last_progress >= 0.001 {
            control.report(frac);
            last_progress = frac;
        }
    }
    let mut out = recorder.out;
    if let Some(t) = out.interrupted_at_s {
        out.duration_s = t;
    }
    let interrupted = out.interrupted_at_s.is_some();
    source.finish(&mut out, interrupted)?;
    if options.batch_reference {
        let mut reference = batch_reference(&mut estimator);
        reference.checkpoints = checkpoints.list;
        out.batch_reference = Some(reference);
    }
    control.report(1.0);
    Ok((out, recorder.without_truth))
}

/// Iterations of the batch reference solve: it starts from the window's estimates, so a few
/// Gauss-Newton steps converge (the same cap as the estimator's batch tests).
const BATCH_ITERATIONS: usize = 20;

/// The frames as they left the window and the keyframe batch solved at the end of a run.
fn batch_reference(estimator: &mut Estimator) -> BatchReference {
    let options = SolverOptions {
        max_iterations: BATCH_ITERATIONS,
        ..Default::default()
    };
    let (batch, summary) = estimator
        .batch_solve_keyframes(&options)
        .map_or((Vec::new(), None), |(b, s)| (b, Some(s)));
    BatchReference {
        finalized: estimator.take_finalized(),
        batch,
        summary,
        checkpoints: Vec::new(),
    }
}
