//! The runner: a scenario (simulated) or a recording (an EuRoC folder, a ROS 2 bag) fed to the
//! estimator over one driver loop, to a [`RunOutput`]; [`crate::pipeline`] evaluates and reports it.

mod driver;
mod error;
mod euroc_folder;
mod filter_checkpoints;
mod lookahead;
mod options;
mod recorded;
mod recorder;
mod ros2_bag;
mod simulated;
mod stage;

pub use crate::run_output::{
    BatchReference, Event, EventKind, FilterCheckpoint, FrameRecord, FrameTiming, OutsideRun,
    RunOutput, WindowScene,
};
pub use error::RunError;
pub use euroc_folder::EurocOptions;
pub(crate) use euroc_folder::replay_euroc;
pub use options::{RunControl, RunOptions};
pub use recorded::DEFAULT_SEED;
pub(crate) use recorded::RecordedRun;
pub(crate) use recorder::Recorder;
pub(crate) use ros2_bag::replay_bag;
pub use ros2_bag::{BagOptions, GROUNDTRUTH_TOPIC};
pub(crate) use simulated::simulate;
pub use simulated::{image_frontend, measurement_stream, stream_result};
