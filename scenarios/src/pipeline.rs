//! Run, evaluate, report: the one sequence every caller of the runner uses (the CLI, the
//! regression catalog, sweeps, benchmarks, NEES studies, the tests).

use std::path::Path;

use crate::external::run_outside;
use crate::report::{self, Evaluation, Report, RunContext};
use crate::run::{
    BagOptions, EurocOptions, RecordedRun, RunControl, RunError, RunOptions, RunOutput, replay_bag,
    replay_euroc, simulate,
};
use crate::spec::Scenario;

/// What to run.
#[derive(Clone, Copy, Debug)]
pub enum RunInput<'a> {
    /// A scenario, simulated.
    Scenario(&'a Scenario),
    /// A recorded EuRoC dataset: its `mav0` folder and how to run it.
    Euroc {
        /// The `mav0` folder.
        mav0: &'a Path,
        /// The suite, the feature tracks or images, the settings.
        options: &'a EurocOptions,
    },
    /// A recorded ROS 2 bag (MCAP): the file and how to run it.
    Bag {
        /// The `.mcap` file.
        path: &'a Path,
        /// The topics, the rig, the suite, the settings.
        options: &'a BagOptions,
    },
}

/// A finished run with its evaluation and report.
#[derive(Debug)]
pub struct ReportedRun {
    /// What the report knows of the input (description, suite, expectations, ground truth).
    pub context: RunContext,
    /// The run.
    pub output: RunOutput,
    /// Its evaluation against ground truth.
    pub evaluation: Evaluation,
    /// Its report, with the expectations checked.
    pub report: Report,
    /// Estimates left out for want of ground truth (a recorded dataset's outside the span of
    /// its ground truth; 0 for a scenario).
    pub without_truth: usize,
}

impl ReportedRun {
    /// Writes the run's files into `dir` ([`report::write_outputs`]).
    pub fn write_outputs(&self, dir: &Path) -> Result<(), String> {
        report::write_outputs(
            dir,
            &self.context,
            &self.output,
            &self.evaluation,
            &self.report,
        )
    }
}

/// Runs `input` with `options` under `control`, evaluates it and builds its report.
pub fn run_to_report(
    input: RunInput,
    options: &RunOptions,
    mut control: RunControl,
) -> Result<ReportedRun, RunError> {
    let recorded = |r: RecordedRun, description: String, suite| {
        let context = RunContext::recorded(description, suite, r.t0_ns, r.ground_truth);
        (context, r.output, r.without_truth, r.truth_biases)
    };
    let (context, output, without_truth, truth_biases) = match input {
        RunInput::Scenario(scenario) => {
            let output = match scenario.adapter() {
                None => simulate(scenario, options, &mut control)?,
                Some(adapter) => run_outside(scenario, adapter, options, &mut control)?,
            };
            // An outside estimator reports poses only: its biases' errors are unknown.
            let biases = output.outside.is_none();
            let without_truth = output.outside.as_ref().map_or(0, |o| o.without_truth);
            (
                RunContext::with_run(scenario, &output),
                output,
                without_truth,
                biases,
            )
        }
        RunInput::Euroc { mav0, options: e } => recorded(
            replay_euroc(mav0, e, options, &mut control)?,
            format!("EuRoC dataset {}", mav0.display()),
            e.suite,
        ),
        RunInput::Bag { path, options: b } => recorded(
            replay_bag(path, b, options, &mut control)?,
            format!("ROS 2 bag {}", path.display()),
            b.suite,
        ),
    };
    let mut evaluation = report::evaluate(&output, context.suite);
    if output.outside.is_some() && output.frames_in > 0 {
        // An outside estimator's poses are its tracked frames: the fraction is of the frames
        // it was given (one that starts late, or stops, tracks less).
        evaluation.tracking_fraction = output.frames.len() as f64 / output.frames_in as f64;
    }
    if !truth_biases {
        // A ground truth of poses: the biases' errors are unknown, not zero.
        evaluation.gyro_bias_error_rad_s = None;
        evaluation.accel_bias_error_m_s2 = None;
    }
    let report = report::build_report(&context, &output, &evaluation);
    Ok(ReportedRun {
        context,
        output,
        evaluation,
        report,
        without_truth,
    })
}

/// [`run_to_report`] on a scenario, without progress or a stop flag.
pub fn run_scenario(scenario: &Scenario, options: &RunOptions) -> Result<ReportedRun, RunError> {
    run_to_report(RunInput::Scenario(scenario), options, RunControl::default())
}
