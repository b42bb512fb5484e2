//! Run, evaluate, report: the one sequence every caller of the runner uses (the CLI, the
//! regression catalog, sweeps, benchmarks, NEES studies, the tests).

use std::path::Path;

use super::recorded::replay_euroc;
use super::simulated::simulate;
use super::{EurocOptions, RunControl, RunError, RunOptions, RunOutput};
use crate::report::{self, Evaluation, Report, RunContext};
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
    let (context, output, without_truth) = match input {
        RunInput::Scenario(scenario) => {
            let output = simulate(scenario, options, &mut control)?;
            (RunContext::with_run(scenario, &output), output, 0)
        }
        RunInput::Euroc { mav0, options: e } => {
            let r = replay_euroc(mav0, e, options, &mut control)?;
            let context = RunContext::recorded(
                format!("EuRoC dataset {}", mav0.display()),
                e.suite,
                r.t0_ns,
                r.ground_truth,
            );
            (context, r.output, r.without_truth)
        }
    };
    let evaluation = report::evaluate(&output, context.suite);
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
