//! The runner: one pipeline from a scenario (simulated) or a recorded dataset to an evaluated
//! report ([`run_to_report`]), over one driver loop that feeds either source to the estimator.

mod driver;
mod error;
mod options;
mod pipeline;
mod recorded;
mod recorder;
mod simulated;

pub use crate::run_output::{
    BatchReference, Event, EventKind, FrameRecord, FrameTiming, RunOutput,
};
pub use error::RunError;
pub use options::{RunControl, RunOptions};
pub use pipeline::{ReportedRun, RunInput, run_scenario, run_to_report};
pub use recorded::{DEFAULT_SEED, EurocOptions};
pub(crate) use recorder::Recorder;
pub use simulated::{image_frontend, measurement_stream, stream_result};
