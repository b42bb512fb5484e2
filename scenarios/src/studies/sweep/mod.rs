//! `vio sweep`: one base scenario run over a grid of parameter values and seeds, to see what a
//! sensor-suite choice buys before buying it.
//!
//! A sweep file (TOML) names the base scenario, the axes and the seeds:
//!
//! ```toml
//! description = "ATE against the stereo baseline"
//! scenario = "room_figure8_stereo_imu"   # catalog name, or a path relative to this file
//! duration_s = 20.0                       # optional: overrides the scenario's
//! seeds = [1, 2, 3]
//! metrics = ["ate_rmse_m", "ate_rot_rmse_deg"]   # optional (default: ATE, rotation, RPE, tracking)
//!
//! [[axes]]
//! name = "baseline_m"
//! # every key is set at each point; a number value is multiplied by each key's scale
//! keys = ["rig.cameras[0].T_b_c.translation_m[1]", "rig.cameras[1].T_b_c.translation_m[1]"]
//! scale = [0.5, -0.5]
//! values = [0.02, 0.05, 0.11, 0.2]
//! ```
//!
//! A value may also be an array with one entry per key (`values = [[1.6e-4, 2e-3], …]`), then
//! `x` gives each point's position on the plot's axis and `labels` its tick names. Values, scales
//! and `x` must be finite; a whole number is scaled like its float twin (`3` as `3.0`); axis
//! names are unique; at most [`MAX_RUNS`] runs, counted without overflow. Points are the
//! Cartesian product of the axes (the last axis varies fastest); runs are points × seeds, in
//! that order. `--shard i/n` (0 ≤ i < n) runs the runs whose index is `i` modulo `n`; `vio sweep-merge`
//! joins shards into what one process would have written, byte for byte. Each finished run is
//! kept in `OUT/partial/` as it finishes; after Ctrl-C (or a killed job) `vio sweep --resume`
//! runs only the rest and writes what an uninterrupted sweep writes.
//!
//! A sweep that asks a question says so: `[target]` (`metric = "ate_rmse_m"`, `max = 0.01`,
//! or `min` for `tracking_fraction`) and, optionally, a `cost` per value of an axis
//! (`cost = [5, 50, 500]`); the sweep then writes `summary.csv` and `summary.md` (each point's
//! mean and worst seed, its runs without a value, pass or FAIL) and names the cheapest passing
//! point ([`summary`]). `vio sweep --plan` lists the runs and estimates their wall time
//! without running them ([`plan`]); `--keep-runs` keeps each run's folder
//! ([`run::SweepControl::runs_dir`]).

mod grid;
pub mod merge;
pub mod partial;
pub mod plan;
mod point;
pub mod run;
pub mod summary;

pub use grid::{AxisSpec, DEFAULT_METRICS, MAX_RUNS, Sweep, SweepSpec};
pub use point::Point;
