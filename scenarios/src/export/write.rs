//! `vio export`'s one pass over a scenario: simulate it, hand every measurement to the chosen
//! format's writer in stream order, and finish with the feature tracks, their ids renumbered.

use std::path::Path;

use estimator::frontend::FeatureFrame;
use sim::World;
use sim::stream::Measurement;

use super::asl_folder::AslFolder;
use super::out_folder::{ClaimedFolder, complete_bag, partial_bag_path};
use super::rig::export_rig;
use super::ros2_bag::Ros2Bag;
use super::sink::{ExportError, ExportSink, ExportSummary};
use crate::dataset::GroundTruthState;
use crate::run::{RunError, RunOptions, measurement_stream, stream_result};
use crate::spec::Scenario;

/// Renumbers feature ids densely from 0, keeping their order (an id's new value is its rank
/// among all ids of the export), so they fit in 31 bits: many tools read them as `int`, and the
/// simulator's realistic track ids carry the landmark id in their low bits and a track counter
/// above. Keeping the order keeps every id-ordered choice of the estimator (which tracks become
/// persistent points, the order of factors), so the exported tracks reproduce the run exactly.
/// One id still means one track (or one landmark with `track_ids = "landmark"`), shared by the
/// cameras that see it.
fn compact_feature_ids(frames: &mut [FeatureFrame]) {
    let all: std::collections::BTreeSet<u64> = frames
        .iter()
        .flat_map(|f| f.cameras.iter())
        .flat_map(|c| c.features.iter().map(|o| o.feature_id))
        .collect();
    let rank: std::collections::BTreeMap<u64, u64> = all.into_iter().zip(0u64..).collect();
    for f in frames {
        for c in &mut f.cameras {
            for o in &mut c.features {
                o.feature_id = rank[&o.feature_id];
            }
        }
    }
}

/// Simulates `scenario` into `sink`.
fn export_into(
    scenario: &Scenario,
    options: &RunOptions,
    make_sink: impl FnOnce(super::rig::ExportRig) -> Result<Box<dyn ExportSink>, ExportError>,
) -> Result<ExportSummary, ExportError> {
    let world_cfg = scenario
        .world_config(options.seed, options.duration_s)
        .map_err(RunError::from)?;
    let est_cfg = scenario
        .estimator_config_at(world_cfg.seed)
        .map_err(RunError::from)?;
    let world = World::new(world_cfg).map_err(|e| RunError::sim(scenario, e))?;
    let (mut stream, _) = measurement_stream(scenario, &world)?;
    let mut sink = make_sink(export_rig(scenario, &est_cfg))?;
    let mut summary = ExportSummary {
        imu_samples: 0,
        frames: 0,
        observations: 0,
        groundtruth: 0,
        images: 0,
        frame_stamps_ns: Vec::new(),
    };
    let mut frames: Vec<FeatureFrame> = Vec::new();
    while let Some(m) = stream.next() {
        match m {
            Measurement::Imu(s) => {
                let truth = stream.truth(s.t_ns).map(|gt| GroundTruthState {
                    t_ns: gt.t_ns,
                    pose: gt.pose,
                    velocity: gt.v_w,
                    gyro_bias: gt.gyro_bias,
                    accel_bias: gt.accel_bias,
                });
                sink.imu(&s, truth.as_ref())?;
                summary.imu_samples += 1;
                summary.groundtruth += usize::from(truth.is_some());
            }
            Measurement::Images(frame) => {
                sink.images(&frame)?;
                summary.images += frame.cameras.len();
                summary.frame_stamps_ns.push(frame.t_ns);
            }
            Measurement::Frame(f) => frames.push(f),
            Measurement::Gnss(g) => sink.gnss(&g)?,
            Measurement::Wheel(w) => sink.wheel(&w)?,
        }
    }
    stream_result(scenario, &stream)?;
    compact_feature_ids(&mut frames);
    summary.frames = frames.len();
    summary
        .frame_stamps_ns
        .extend(frames.iter().map(|f| f.t_ns));
    summary.frame_stamps_ns.sort_unstable();
    summary.frame_stamps_ns.dedup();
    summary.observations = frames
        .iter()
        .flat_map(|f| f.cameras.iter())
        .map(|c| c.features.len())
        .sum();
    sink.finish(&frames)?;
    Ok(summary)
}

/// Simulates `scenario` and writes its measurements and ground truth under `out` as an EuRoC ASL
/// folder (see the module documentation): one export at a time, the folder marked incomplete
/// until it ends ([`ClaimedFolder`]).
pub fn export(
    scenario: &Scenario,
    options: &RunOptions,
    out: &Path,
) -> Result<ExportSummary, ExportError> {
    let claimed = ClaimedFolder::claim(out)?;
    let summary = export_into(scenario, options, |rig| {
        Ok(Box::new(AslFolder::new(out.to_path_buf(), rig)))
    })?;
    claimed.complete()?;
    Ok(summary)
}

/// Simulates `scenario` and writes its measurements and ground truth as a ROS 2 bag (MCAP) at
/// `path` (see [`super::ros2_bag`] for its topics): written beside it, renamed onto it once
/// complete, so `path` is a whole bag or not there.
pub fn export_bag(
    scenario: &Scenario,
    options: &RunOptions,
    path: &Path,
) -> Result<ExportSummary, ExportError> {
    let partial = partial_bag_path(path);
    let written = export_into(scenario, options, |rig| {
        Ok(Box::new(Ros2Bag::create(&partial, rig)?))
    });
    match written {
        Ok(summary) => complete_bag(&partial, path).map(|()| summary),
        Err(e) => {
            // Best effort: the error is the export's.
            let _ = std::fs::remove_file(&partial);
            Err(e)
        }
    }
}
