//! The sliding-window estimator on synthetic stereo+IMU feature input generated inside the test:
//! convergence against ground truth, bias estimation, determinism, batch consistency, gauge.

use crate::common;

use common::Analytic;
use common::world::{FRAME_NS, IMU_NS, World, align_position_yaw};
use estimator::frontend::FeatureFrame;
use estimator::{Estimate, Estimator, EventKind, Suite};
use nalgebra::Vector3;

/// Runs `seconds` of the world through the estimator; returns every estimate.
/// With `known_start`, the estimator starts from the true state instead of initializing.
fn run_with(
    world: &mut World,
    suite: Suite,
    seconds: f64,
    record: bool,
    known_start: bool,
) -> (Estimator, Vec<Estimate>) {
    let mut config = world.config(suite);
    config.record_history = record;
    run_config(world, config, seconds, known_start)
}

/// Runs `seconds` of the world through an estimator with `config`.
fn run_config(
    world: &mut World,
    config: estimator::EstimatorConfig,
    seconds: f64,
    known_start: bool,
) -> (Estimator, Vec<Estimate>) {
    let mut est = Estimator::new(config).unwrap();
    if known_start {
        est.start_from(
            Analytic::pose(0),
            Analytic::velocity(0.0),
            world.ba,
            world.bg,
        );
    }
    let out = feed(&mut est, world, seconds, |_, _| {});
    (est, out)
}

/// Feeds `seconds` of the world's IMU samples and frames to `est`, each frame through `edit`
/// (with its time) first; returns the estimates.
fn feed(
    est: &mut Estimator,
    world: &mut World,
    seconds: f64,
    mut edit: impl FnMut(i64, &mut FeatureFrame),
) -> Vec<Estimate> {
    let mut out = Vec::new();
    let end = (seconds * 1e9) as i64;
    let (mut t_imu, mut t_frame) = (0, 0);
    while t_frame <= end {
        while t_imu <= t_frame {
            out.extend(est.push_imu(world.imu(t_imu)).unwrap());
            t_imu += IMU_NS;
        }
        let mut frame = world.frame(t_frame);
        edit(t_frame, &mut frame);
        out.extend(est.push_frame(frame).unwrap());
        t_frame += FRAME_NS;
    }
    out
}

fn run(world: &mut World, suite: Suite, seconds: f64, record: bool) -> (Estimator, Vec<Estimate>) {
    run_with(world, suite, seconds, record, false)
}

/// RMSE of aligned positions over the tracking estimates.
fn ate(estimates: &[Estimate]) -> f64 {
    let tracked: Vec<&Estimate> = estimates
        .iter()
        .filter(|e| e.status.initialized())
        .collect();
    let est: Vec<Vector3<f64>> = tracked.iter().map(|e| e.T_w_b.p).collect();
    let gt: Vec<Vector3<f64>> = tracked.iter().map(|e| Analytic::pose(e.t_ns).p).collect();
    let aligned = align_position_yaw(&est, &gt);
    (aligned
        .iter()
        .zip(&gt)
        .map(|(a, g)| (a - g).norm_squared())
        .sum::<f64>()
        / gt.len() as f64)
        .sqrt()
}

#[test]
fn stereo_imu_converges_and_estimates_biases() {
    let mut world = World::new(1, 3000, 1.0);
    let (_, estimates) = run(&mut world, Suite::StereoImu, 20.0, false);
    let tracking = estimates.iter().filter(|e| e.status.initialized()).count();
    assert!(tracking > 350, "only {tracking} tracking frames");
    let ate = ate(&estimates);
    let last = estimates.last().unwrap();
    let (dba, dbg) = ((last.ba - world.ba).norm(), (last.bg - world.bg).norm());
    println!("ATE {ate:.4} m, |ba err| {dba:.4} m/s², |bg err| {dbg:.5} rad/s");
    let median = |f: &dyn Fn(&Estimate) -> f64| {
        let mut v: Vec<f64> = estimates
            .iter()
            .filter(|e| e.status.initialized())
            .map(f)
            .collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2] * 1e3
    };
    println!(
        "median ms: backend {:.2} solve {:.2} marginalization {:.2}; median iterations {}",
        median(&|e| e.backend_s),
        median(&|e| e.solve_s),
        median(&|e| e.marginalization_s),
        median(&|e| e.solver.map_or(0.0, |s| s.iterations as f64)) / 1e3
    );
    // Measured (seed 1): ATE 1.21 cm, |bg err| 4e-5 rad/s, |ba err| 0.0095 m/s² at 20 s (before
    // 3-dof landmarks and without track re-use: 1.74 cm, 5.7e-4, 0.029). Bounds: 1.65× the ATE,
    // 5× the bias errors (a single run's bias errors are one draw each).
    assert!(ate < 0.02, "ATE {ate}");
    assert!(dbg < 2e-4, "gyro bias error {dbg}");
    assert!(dba < 0.05, "accel bias error {dba}");
}

#[test]
fn window_is_within_a_stated_factor_of_the_batch_solution() {
    let mut world = World::new(2, 3000, 1.0);
    let (mut est, estimates) = run(&mut world, Suite::StereoImu, 8.0, true);
    let window_ate = ate(&estimates);
    let lagged = est.take_finalized();
    let lp: Vec<Vector3<f64>> = lagged.iter().map(|(_, p)| p.p).collect();
    let lg: Vec<Vector3<f64>> = lagged.iter().map(|(t, _)| Analytic::pose(*t).p).collect();
    let la = align_position_yaw(&lp, &lg);
    let lagged_ate = (la
        .iter()
        .zip(&lg)
        .map(|(a, g)| (a - g).norm_squared())
        .sum::<f64>()
        / lg.len() as f64)
        .sqrt();
    println!("lagged ATE {lagged_ate:.4} over {}", lagged.len());
    let batch = est
        .batch_solve(&estimator::problem::SolverOptions {
            max_iterations: 20,
            ..Default::default()
        })
        .unwrap();
    let est_p: Vec<Vector3<f64>> = batch.iter().map(|(_, p)| p.p).collect();
    let gt_p: Vec<Vector3<f64>> = batch.iter().map(|(t, _)| Analytic::pose(*t).p).collect();
    let aligned = align_position_yaw(&est_p, &gt_p);
    let batch_ate = (aligned
        .iter()
        .zip(&gt_p)
        .map(|(a, g)| (a - g).norm_squared())
        .sum::<f64>()
        / gt_p.len() as f64)
        .sqrt();
    println!(
        "window ATE {window_ate:.4} m, batch ATE {batch_ate:.4} m over {} frames",
        batch.len()
    );
    assert!(batch.len() > 140);
    assert!(
        batch_ate < window_ate * 1.05,
        "batch should not be worse: {batch_ate} vs {window_ate}"
    );
    // Measured (seed 2, 8 s including the 0.5 s start-up): window 1.26 cm (causal estimates),
    // window frames when they leave it 1.28 cm, batch 0.26 cm. The causal estimate of the newest
    // frame has seen no future frames, and the start-up transient weighs on 8 s: a factor of
    // ~4.8, asserted with margin at 8.
    assert!(
        window_ate < 8.0 * batch_ate,
        "window {window_ate} vs batch {batch_ate}"
    );
    assert!(
        window_ate < 0.05 && lagged_ate < 0.05,
        "window {window_ate}, lagged {lagged_ate}"
    );
}

#[test]
fn same_input_gives_bit_identical_estimates() {
    let bits = |e: &Estimate| -> Vec<u64> {
        e.T_w_b
            .to_array()
            .iter()
            .chain(e.v_w.iter())
            .chain(e.ba.iter())
            .chain(e.bg.iter())
            .map(|v| v.to_bits())
            .collect()
    };
    let (_, a) = run(&mut World::new(4, 2000, 1.0), Suite::StereoImu, 3.0, false);
    let (_, b) = run(&mut World::new(4, 2000, 1.0), Suite::StereoImu, 3.0, false);
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.t_ns, y.t_ns);
        assert_eq!(bits(x), bits(y));
    }
}

#[test]
fn noise_free_window_from_a_known_start_stays_on_the_truth() {
    // Exact measurements and the true initial state: the window (prior, marginalization, keyframe
    // policy, IMU interval merging) must not invent motion. No alignment: the start fixes the
    // gauge.
    let mut world = World::new(6, 3000, 0.0);
    world.imu_noise_scale = 0.0;
    let (_, estimates) = run_with(&mut world, Suite::StereoImu, 6.0, false, true);
    let worst = estimates
        .iter()
        .map(|e| (e.T_w_b.p - Analytic::pose(e.t_ns).p).norm())
        .fold(0.0, f64::max);
    let worst_rot = estimates
        .iter()
        .map(|e| e.T_w_b.q.angle_to(&Analytic::pose(e.t_ns).q).to_degrees())
        .fold(0.0, f64::max);
    println!(
        "noise-free known start: worst position error {worst:.2e} m, rotation {worst_rot:.2e} deg"
    );
    // Measured (seed 6, 6 s): 4.1e-7 m, 2.5e-5° (the midpoint rule's discretization error).
    assert!(
        worst < 1e-5 && worst_rot < 1e-3,
        "{worst} m, {worst_rot} deg"
    );
}

#[test]
fn covariance_of_the_newest_state_is_positive_definite_and_consistent_for_the_biases() {
    // The same run with and without covariances: identical estimates. The covariance is a
    // symmetric positive-definite 15×15 in the documented order, and the bias errors against
    // the true biases are consistent with it: their NEES averaged over the frames after
    // start-up lies in the two-sided 95 % band of one χ²(3) draw, [0.216, 9.35] (one run: the
    // bias errors are strongly correlated over time, so the average counts as about one draw).
    // Measured (seed 3): 2.39 and 1.73. Before the anchor observation became a residual
    // (3-dof landmarks) and tracks of marginalized keyframes were re-used, 37.7 and 64.5.
    let mut world = World::new(3, 2500, 1.0);
    let (ba_true, bg_true) = (world.ba, world.bg);
    let mut config = world.config(Suite::StereoImu);
    config.compute_covariance = true;
    let mut with = Estimator::new(config).unwrap();
    let (_, without) = run(&mut World::new(3, 2500, 1.0), Suite::StereoImu, 6.0, false);
    let out = feed(&mut with, &mut world, 6.0, |_, _| {});
    assert_eq!(out.len(), without.len());
    let (mut nees_ba, mut nees_bg, mut n) = (0.0, 0.0, 0.0);
    for (a, b) in out.iter().zip(&without) {
        assert_eq!(
            a.T_w_b, b.T_w_b,
            "computing covariances changed an estimate"
        );
        if !a.status.initialized() || a.t_ns < 2_000_000_000 {
            continue;
        }
        let cov = a.covariance.as_ref().expect("covariance requested");
        assert_eq!(cov.shape(), (15, 15));
        assert!((cov - cov.transpose()).amax() <= 1e-12 * cov.amax());
        assert!(cov.clone().cholesky().is_some(), "not positive definite");
        let nees = |e: Vector3<f64>, k: usize| {
            let p = cov.fixed_view::<3, 3>(k, k).into_owned();
            e.dot(&(p.try_inverse().unwrap() * e))
        };
        nees_ba += nees(a.ba - ba_true, 9);
        nees_bg += nees(a.bg - bg_true, 12);
        n += 1.0;
    }
    assert!(n > 50.0);
    let (nees_ba, nees_bg) = (nees_ba / n, nees_bg / n);
    eprintln!("mean NEES over {n} frames: accel bias {nees_ba:.2}, gyro bias {nees_bg:.2} (dof 3)");
    for (what, v) in [("accel bias", nees_ba), ("gyro bias", nees_bg)] {
        assert!((0.216..9.35).contains(&v), "{what}: mean NEES {v}");
    }
}

/// Regression (`min_track_frames`): with VINS-Fusion's 4 a track entered the window only once
/// seen in 4 frames, so a starting window had no visual factor for its first frames; their
/// poses came out of nothing, the first triangulations used them, and the figure-eight
/// scenario went 2 m off for its first 3 s (ATE 0.245 m over 60 s against 0.010 m). A track
/// now needs `min(min_track_frames, frames in the window)` frames.
#[test]
fn min_track_frames_4_does_not_starve_a_starting_window() {
    let mut world = World::new(1, 3000, 1.0);
    let mut config = world.config(Suite::StereoImu);
    config.min_track_frames = 4;
    let (_, estimates) = run_config(&mut world, config, 8.0, false);
    let ate = ate(&estimates);
    println!("min_track_frames 4: ATE {ate:.4} m");
    assert!(ate < 0.03, "ATE {ate}");
}

/// The outlier test's rejections before the IMU alignment (the vision-only solves of a stereo
/// window waiting for it) do not count against the tracking window. For its first 0.4 s the
/// left camera jitters by ±8 px on nine features in ten, so those solves reject 2–88 % of
/// their tracks; the window then initializes at 0.45 s and tracks cleanly. Counting the
/// earlier solves, the monitor found 16 % rejected over 20 solves at 0.95 s and initialized
/// again (ATE 0.417 m over 4 s); cleared at the alignment it stays quiet: no reset, ATE
/// 0.0174 m (seed 5; bound +50 %).
#[test]
fn rejections_before_the_alignment_do_not_reset_the_tracking_window() {
    let mut world = World::new(5, 3000, 1.0);
    let mut est = Estimator::new(world.config(Suite::StereoImu)).unwrap();
    let out = feed(&mut est, &mut world, 4.0, |t_ns, frame| {
        if t_ns < 400_000_000 {
            let shift = if (t_ns / FRAME_NS) % 2 == 0 {
                8.0
            } else {
                -8.0
            };
            for f in frame.cameras[0].features.iter_mut() {
                if f.feature_id % 10 != 0 {
                    f.uv.x += shift;
                }
            }
        }
    });
    let resets: Vec<_> = est
        .take_events()
        .into_iter()
        .filter(|e| matches!(e.kind, EventKind::Reset { .. }))
        .collect();
    assert!(resets.is_empty(), "{resets:?}");
    let ate = ate(&out);
    assert!(ate < 0.026, "ATE {ate} m");
}

/// The start-up window: for `startup_window_s` of tracking the window keeps up to
/// `startup_window_size` keyframes, then shrinks back to `window_size` (one keyframe a frame)
/// and stays there (seed 1: 16 frames at most while it lasts, 10 from a second after it ends;
/// a window that shrank by marginalizing one frame per frame, as a full one does, stayed at 16).
#[test]
fn startup_window_holds_more_keyframes_then_shrinks_back() {
    let mut world = World::new(1, 3000, 1.0);
    let mut config = world.config(Suite::StereoImu);
    config.startup_window_size = 16;
    config.startup_window_s = 1.5;
    let window_size = config.window_size;
    let mut est = Estimator::new(config).unwrap();
    let (mut t_imu, mut t_frame) = (0, 0);
    let mut sizes = Vec::new();
    let mut out = Vec::new();
    while t_frame <= 4_000_000_000 {
        while t_imu <= t_frame {
            out.extend(est.push_imu(world.imu(t_imu)).unwrap());
            t_imu += IMU_NS;
        }
        out.extend(est.push_frame(world.frame(t_frame)).unwrap());
        sizes.push((t_frame, est.window_poses().len()));
        t_frame += FRAME_NS;
    }
    let tracked_at = out
        .iter()
        .find(|e| e.status.initialized())
        .expect("tracks")
        .t_ns;
    let end_ns = tracked_at + 1_500_000_000;
    let largest = |from: i64, to: i64| {
        sizes
            .iter()
            .filter(|(t, _)| (from..to).contains(t))
            .map(|&(_, n)| n)
            .max()
            .unwrap()
    };
    let during = largest(0, end_ns + FRAME_NS);
    let after = largest(end_ns + 1_000_000_000, i64::MAX);
    println!("tracking from {tracked_at} ns: at most {during} frames, then {after}");
    assert_eq!(
        during, 16,
        "the start-up window held at most {during} frames"
    );
    assert!(
        after <= window_size,
        "{after} frames a second after the start-up phase (window_size {window_size})"
    );
    let ate = ate(&out);
    assert!(ate < 0.03, "ATE {ate}");
}
