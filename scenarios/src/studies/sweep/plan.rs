//! `vio sweep --plan`: the runs a sweep (or one shard) would make, with every point's scenario
//! built and checked before any run, and a rough estimate of the wall time from short probes.

use std::time::Instant;

use super::Sweep;
use super::run::Shard;
use crate::pipeline::{RunInput, run_to_report};
use crate::run::{RunControl, RunOptions};
use crate::spec::SpecError;

/// One run of the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct PlannedRun {
    /// Run index (point-major, then seed).
    pub run: usize,
    /// Point index.
    pub point: usize,
    /// Seed.
    pub seed: u64,
    /// Simulated seconds the run covers: the sweep's or the scenario's duration, cut to the
    /// end of a replayed motion.
    pub simulated_s: f64,
}

/// A probe's measure of how fast one point runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// The point probed.
    pub point: usize,
    /// Simulated seconds the probe ran.
    pub simulated_s: f64,
    /// Wall seconds it took (scenario build, simulation, estimation, evaluation).
    pub wall_s: f64,
}

impl Sweep {
    /// The shard's runs in run order, each point's scenario built and its world checked
    /// (a key a value cannot set, a duration beyond a replayed motion) before any run.
    pub fn plan(&self, shard: Shard) -> Result<Vec<PlannedRun>, SpecError> {
        let points = self.points();
        let seeds = &self.spec.seeds;
        let mut runs = Vec::new();
        for (p, point) in points.iter().enumerate() {
            let in_shard: Vec<usize> = (0..seeds.len())
                .map(|si| p * seeds.len() + si)
                .filter(|&r| shard.has(r))
                .collect();
            if in_shard.is_empty() {
                continue;
            }
            let scenario = self.scenario(point)?;
            let at_point = |e: SpecError| SpecError {
                message: format!(
                    "at sweep point {}: {}",
                    self.describe_point(point),
                    e.message
                ),
                ..e
            };
            let config = scenario
                .world_config(None, self.spec.duration_s)
                .map_err(at_point)?;
            let end = sim::reference_motion(&config)
                .map_err(|e| at_point(scenario.error("trajectory", e.to_string())))?
                .duration();
            let simulated_s = end.map_or(config.duration_s, |e| config.duration_s.min(e));
            runs.extend(in_shard.into_iter().map(|r| PlannedRun {
                run: r,
                point: p,
                seed: seeds[r % seeds.len()],
                simulated_s,
            }));
        }
        Ok(runs)
    }

    /// Runs `point` with the sweep's first seed for `simulated_s` simulated seconds and times
    /// it (wall clock: an estimate, not a result).
    pub fn probe(&self, point: usize, simulated_s: f64) -> Result<Probe, String> {
        let started = Instant::now();
        let scenario = self
            .scenario(&self.point(point))
            .map_err(|e| e.to_string())?;
        let options = RunOptions {
            seed: self.spec.seeds.first().copied(),
            duration_s: Some(simulated_s),
            ..Default::default()
        };
        run_to_report(
            RunInput::Scenario(&scenario),
            &options,
            RunControl::default(),
        )
        .map_err(|e| format!("probe of point {point}: {e}"))?;
        Ok(Probe {
            point,
            simulated_s,
            wall_s: started.elapsed().as_secs_f64(),
        })
    }
}

/// The wall time the runs take on `jobs` threads, from the probes' wall time per simulated
/// second (their mean: the points between them are assumed to run alike), the runs spread
/// evenly over the threads.
pub fn estimate_wall_s(runs: &[PlannedRun], probes: &[Probe], jobs: usize) -> Option<f64> {
    if probes.is_empty() || runs.is_empty() {
        return None;
    }
    let per_s = probes.iter().map(|p| p.wall_s / p.simulated_s).sum::<f64>() / probes.len() as f64;
    let simulated: f64 = runs.iter().map(|r| r.simulated_s).sum();
    Some(per_s * simulated / jobs.clamp(1, runs.len()) as f64)
}
