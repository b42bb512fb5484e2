//! Reports: evaluation of a run against ground truth, `report.json`, the TUM files, the
//! trajectory plot and the human summary `vio run` prints.
//!
//! Evaluation uses every estimate after initialization, tracking or degraded (during
//! initialization the estimate is not yet in a gravity-aligned world frame; a degraded frame,
//! carried by the IMU without visual constraints, is part of the run's error), each paired with the ground truth at its own time,
//! and [`crate::metrics`] (evo's definitions):
//! - Alignment: stereo+IMU estimates are aligned to ground truth by position + yaw
//!   ([`Alignment::PosYaw`](crate::metrics::Alignment::PosYaw), the 4 unobservable degrees of freedom); vision-only estimates by a
//!   rigid SE(3) alignment ([`Alignment::Se3`](crate::metrics::Alignment::Se3): their world frame is the first camera pose, not
//!   gravity-aligned). No scale.
//! - ATE ([`metrics::ate`](crate::metrics::ate)): RMSE of the position error (m) and of the rotation angle (deg) after
//!   that alignment.
//! - RPE ([`metrics::rpe`](crate::metrics::rpe) with [`RpeOptions::meters`](crate::metrics::RpeOptions::meters) of [`RPE_DELTA_M`]): translation RMSE
//!   of relative poses over Δ = 1 m of travelled distance. Pairs come from the ground truth: its
//!   first evaluated pose is an anchor, each later pose at which the ground-truth path since the
//!   last anchor reaches 1 m becomes the next one, and successive anchors form the pairs (evo's
//!   `evo_rpe --delta 1 --delta_unit m --pairs_from_reference`). A rigid alignment does not
//!   change relative poses, so the unaligned estimate is used.
//!
//! Metrics that cannot be computed are `null` in the report (`n/a` in the summary): no tracking
//! frames, too few or degenerate positions for the alignment (fewer than 2 poses or no horizontal
//! spread for position+yaw; fewer than 3 or collinear positions for SE(3)), or, for the RPE, less
//! than 1 m of ground-truth path.
//!
//! With these definitions the report's numbers equal those of
//! `vio eval --gt groundtruth.tum --est estimate.tum --align posyaw` (`se3` for stereo-only)
//! to round-off: the TUM files hold the exact `f64` values.
//!
//! Files written to the output folder:
//! - `estimate.tum`: the estimates after initialization `T_w_b`, unaligned, in the estimator's world;
//! - `groundtruth.tum`: ground truth at every processed frame's time (a superset of the estimate
//!   stamps, so `evo_ape tum groundtruth.tum estimate.tum` associates exactly);
//! - `report.json`: the fields below ([`Report`]);
//! - `trajectory.png`: top view of ground truth vs the aligned estimate, and the position error
//!   over time ([`crate::plot`]);
//! - with `--batch-reference`, `batch.tum` (the batch solution over the keyframes) and
//!   `window.tum` (every frame's pose as it left the window), unaligned like `estimate.tum`;
//!   `filter.tum`, the full-information filter's estimate of each checkpoint's newest frame.
//!
//! The TUM files are written by [`crate::dataset::write_tum`].

mod calibration_error;
mod context;
mod evaluation;
mod gnss;
pub mod recorded_imu;
pub mod recovery;
pub mod replay;
mod report_json;
mod rest;
mod run_bag;
mod static_trajectory;
mod summary;
pub mod window_vs_batch;
pub mod window_vs_filter;
mod write;

pub use calibration_error::{CalibrationReport, CalibrationSample, ExtrinsicError};
pub use context::RunContext;
pub use evaluation::{ALIGNMENT_RULE, Evaluation, RPE_DELTA_M, default_alignment, evaluate};
pub use gnss::{GnssReport, gnss_report};
pub use recorded_imu::RecordedImuReport;
pub use replay::ReplayReport;
pub use report_json::{
    EventReport, ExpectationResult, FaultReport, Report, Stats, TimingReport, build_report,
};
pub use rest::{RestInterval, RestReport, RestSpeeds, rest_report};
pub use run_bag::write_run_bag;
pub use static_trajectory::StaticTrajectoryReport;
pub use summary::summary;
pub use window_vs_batch::BatchReport;
pub use window_vs_filter::FilterReport;
pub use write::{RUN_OUTPUT_FILES, plot_data, write_outputs};
