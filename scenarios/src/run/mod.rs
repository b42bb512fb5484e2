//! The runner: one pipeline from a scenario (simulated) or a recording (an EuRoC folder, a ROS 2
//! bag) to an evaluated report ([`run_to_report`]), over one driver loop that feeds either source to the estimator.

mod driver;
mod error;
mod euroc_folder;
mod filter_checkpoints;
mod lookahead;
mod options;
mod pipeline;
mod recorded;
mod recorder;
mod ros2_bag;
mod simulated;
mod stage;

pub use crate::run_output::{
    BatchReference, Event, EventKind, FilterCheckpoint, FrameRecord, FrameTiming, RunOutput,
    WindowScene,
};
pub use error::RunError;
pub use euroc_folder::EurocOptions;
pub use options::{RunControl, RunOptions};
pub use pipeline::{ReportedRun, RunInput, run_scenario, run_to_report};
pub use recorded::DEFAULT_SEED;
pub(crate) use recorder::Recorder;
pub use ros2_bag::{BagOptions, GROUNDTRUTH_TOPIC};
pub use simulated::{image_frontend, measurement_stream, stream_result};
