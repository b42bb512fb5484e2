//! A scenario run by an outside estimator: the scenario exported as the adapter's input (the
//! ASL folder or the bag, exactly as `vio export` writes it), the program run on it, and its
//! trajectory turned into the run's output, each pose with the simulator's ground truth at its
//! time, for the pipeline to evaluate and report like ours.
//!
//! Files (the workspace: `vio run`'s `OUT/estimator/`, else a temporary folder): `dataset/` or
//! `bag.mcap` (the input), `out/` (`{out}`, what the program writes), `estimator.log` (its
//! stdout and stderr). A program that crashes, is killed past its time limit, writes nothing,
//! or writes a malformed, non-finite, empty or wrongly framed trajectory (or, when the adapter
//! names one, no or a malformed covariance file) leaves an output with no frames and its
//! [`OutsideRun::failure`]: the report fails naming the cause. The covariance file's states
//! join their poses' estimates, for `vio nees`.

use std::path::{Path, PathBuf};
use std::time::Duration;

use estimator::odometry::LiveSuite;
use estimator::{Estimate, Status};
use sim::World;
use sim::stream::GroundTruth;

use super::program::{log_tail, run_program};
use super::stamped_rows::nearest_stamp;
use super::state_covariance::read_state_covariance;
use super::trajectory::{frame_check, read_timing, read_trajectory};
use crate::dataset::StampedPose;
use crate::export::{ExportError, export, export_bag};
use crate::run::{
    FrameRecord, FrameTiming, OutsideRun, RunControl, RunError, RunOptions, RunOutput,
};
use crate::spec::{AdapterInput, AdapterValues, EstimatorAdapter, Scenario, SuiteSpec};

/// The bytes of the log a failed run's report keeps.
const LOG_TAIL_BYTES: usize = 2000;

/// An export error as a run error.
fn export_error(e: ExportError) -> RunError {
    match e {
        ExportError::Run(r) => r,
        ExportError::Dataset(d) => RunError::Dataset(d),
        ExportError::Image(m) | ExportError::Write(m) => {
            RunError::input(PathBuf::from("export"), m)
        }
    }
}

/// An estimate holding only what an outside estimator reports: its pose, stamped on the IMU
/// clock (`t_ns`) and with the camera stamp of the frame it is of (`stamp_ns`).
fn outside_estimate(p: &StampedPose, stamp_ns: i64, suite: SuiteSpec, backend_s: f64) -> Estimate {
    Estimate {
        t_ns: p.t_ns,
        stamp_ns,
        T_w_b: p.pose,
        v_w: nalgebra::Vector3::zeros(),
        ba: nalgebra::Vector3::zeros(),
        bg: nalgebra::Vector3::zeros(),
        td_s: 0.0,
        T_b_c: Vec::new(),
        status: Status::Tracking,
        live: match suite {
            SuiteSpec::StereoImu => LiveSuite::StereoImu,
            SuiteSpec::Stereo => LiveSuite::Stereo,
            SuiteSpec::MonoImu => LiveSuite::MonoImu { cam: 0 },
        },
        keyframe: false,
        landmarks: 0,
        newest_observations: 0,
        solver: None,
        backend_s,
        solve_s: 0.0,
        marginalization_s: 0.0,
        covariance: None,
        td_sigma_s: None,
        at_rest: false,
        relative_pose: None,
        gnss_alignment: None,
    }
}

/// The camera stamps of the exported frames and half their period, for [`FrameStamps::of`].
struct FrameStamps<'a> {
    stamps: &'a [i64],
    half_period_ns: i64,
}

impl<'a> FrameStamps<'a> {
    fn new(stamps: &'a [i64]) -> Self {
        let period = stamps.windows(2).map(|w| w[1] - w[0]).min().unwrap_or(0);
        Self {
            stamps,
            half_period_ns: period / 2,
        }
    }

    /// The camera stamp of the frame a pose stamped `t_ns` (IMU clock: the frame's stamp plus
    /// the estimator's time offset) is of: the nearest exported frame's within half a frame
    /// period, else `t_ns` itself. Seeds with different offset estimates then meet at the same
    /// frames (`vio nees` averages over runs by camera stamp).
    fn of(&self, t_ns: i64) -> i64 {
        nearest_stamp(self.stamps, t_ns, self.half_period_ns).map_or(t_ns, |k| self.stamps[k])
    }
}

/// A folder emptied for the run (what an earlier run left removed).
fn fresh_dir(dir: &Path) -> Result<(), RunError> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)
            .map_err(|e| RunError::input(dir, format!("cannot clear it: {e}")))?;
    }
    std::fs::create_dir_all(dir).map_err(|e| RunError::input(dir, format!("cannot create it: {e}")))
}

/// Runs `scenario` with the outside estimator `adapter` (see the module documentation).
pub fn run_outside(
    scenario: &Scenario,
    adapter: &EstimatorAdapter,
    options: &RunOptions,
    control: &mut RunControl,
) -> Result<RunOutput, RunError> {
    let temporary;
    let workspace: &Path = match control.workspace {
        Some(w) => w,
        None => {
            temporary = tempfile::tempdir().map_err(|e| {
                RunError::input(
                    std::env::temp_dir(),
                    format!("cannot create a temporary folder: {e}"),
                )
            })?;
            temporary.path()
        }
    };
    std::fs::create_dir_all(workspace)
        .map_err(|e| RunError::input(workspace, format!("cannot create it: {e}")))?;
    let world_cfg = scenario.world_config(options.seed, options.duration_s)?;
    let seed = world_cfg.seed;
    let cameras: Vec<_> = scenario
        .estimator_config_at(seed)?
        .cameras
        .iter()
        .map(|c| c.T_b_c)
        .collect();
    let world = World::new(world_cfg).map_err(|e| RunError::sim(scenario, e))?;
    let dataset = workspace.join("dataset");
    let bag = workspace.join("bag.mcap");
    let out_dir = workspace.join("out");
    control.report(0.0);
    let summary = match adapter.input {
        AdapterInput::Mcap => {
            let _ = std::fs::remove_file(&bag);
            export_bag(scenario, options, &bag)
        }
        AdapterInput::AslImages | AdapterInput::AslFeatures => {
            fresh_dir(&dataset)?;
            export(scenario, options, &dataset)
        }
    }
    .map_err(export_error)?;
    control.report(0.3);
    fresh_dir(&out_dir)?;
    let argv = adapter.argv(&AdapterValues {
        dataset: &dataset,
        bag: &bag,
        out: &out_dir,
        seed,
        suite: scenario.spec.suite.as_str(),
    });
    let log = workspace.join("estimator.log");
    let program = run_program(
        &argv,
        &out_dir,
        &log,
        Duration::from_secs_f64(adapter.time_limit_s),
    );
    control.report(0.9);
    let mut output = RunOutput::new(
        scenario.name.clone(),
        seed,
        world.end_ns() as f64 * 1e-9,
        None,
    );
    output.imu_samples = summary.imu_samples;
    output.frames_in = summary.frames;
    let mut outside = OutsideRun {
        name: adapter.name.clone(),
        adapter: adapter.source.clone(),
        command: argv,
        exit: program.end.describe(adapter.time_limit_s),
        wall_s: program.wall_s,
        log: control.workspace.map(|_| log.clone()),
        failure: None,
        log_tail: None,
        poses: 0,
        without_truth: 0,
    };
    let scored = if program.end.succeeded() {
        score(
            &world,
            adapter,
            &out_dir,
            &cameras,
            &summary.frame_stamps_ns,
            scenario.spec.suite,
            &mut outside,
        )
    } else {
        Err(format!("the estimator {}", outside.exit))
    };
    match scored {
        Ok(frames) => output.frames = frames,
        Err(why) => {
            outside.failure = Some(why);
            outside.log_tail = Some(log_tail(&log, LOG_TAIL_BYTES));
        }
    }
    output.outside = Some(outside);
    control.report(1.0);
    Ok(output)
}

/// The program's trajectory as the run's frames, each with the truth at its time; why not, as
/// the failure the report names.
fn score(
    world: &World,
    adapter: &EstimatorAdapter,
    out_dir: &Path,
    cameras: &[estimator::geometry::Pose],
    frame_stamps: &[i64],
    suite: SuiteSpec,
    outside: &mut OutsideRun,
) -> Result<Vec<FrameRecord>, String> {
    let poses = read_trajectory(&out_dir.join(&adapter.trajectory))?;
    outside.poses = poses.len();
    let timing = match &adapter.timing {
        Some(t) if out_dir.join(t).exists() => read_timing(&out_dir.join(t), &poses)?,
        _ => Default::default(),
    };
    let mut states = match &adapter.covariance {
        Some(c) => read_state_covariance(&out_dir.join(c), &poses)?,
        None => Default::default(),
    };
    let mut truth_stream = world.stream();
    let mut pairs: Vec<(StampedPose, GroundTruth)> = Vec::with_capacity(poses.len());
    for p in &poses {
        match truth_stream
            .truth(p.t_ns)
            .filter(|_| p.t_ns <= world.end_ns())
        {
            Some(gt) => pairs.push((*p, gt)),
            None => outside.without_truth += 1,
        }
    }
    if pairs.is_empty() {
        return Err(format!(
            "wrote {} poses and none within the ground truth's span (0 to {:.3} s, IMU clock)",
            poses.len(),
            world.end_ns() as f64 * 1e-9
        ));
    }
    let est: Vec<StampedPose> = pairs.iter().map(|(p, _)| *p).collect();
    let truth: Vec<_> = pairs.iter().map(|(_, g)| g.pose).collect();
    frame_check(&est, &truth, cameras)?;
    let frame_stamps = FrameStamps::new(frame_stamps);
    Ok(pairs
        .into_iter()
        .map(|(p, gt)| {
            let backend_s = timing.get(&p.t_ns).copied().unwrap_or(0.0);
            let stamp_ns = frame_stamps.of(p.t_ns);
            let mut estimate = outside_estimate(&p, stamp_ns, suite, backend_s);
            if let Some(s) = states.remove(&p.t_ns) {
                estimate.v_w = s.v_w;
                estimate.ba = s.ba;
                estimate.bg = s.bg;
                estimate.covariance = Some(s.covariance);
            }
            FrameRecord {
                estimate,
                truth: gt,
                timing: FrameTiming {
                    frontend_s: 0.0,
                    backend_s,
                    total_s: backend_s,
                    render_s: 0.0,
                },
                scene: None,
            }
        })
        .collect())
}
