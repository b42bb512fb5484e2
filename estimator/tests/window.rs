//! The sliding-window estimator on synthetic stereo+IMU feature input generated inside the test:
//! convergence against ground truth, bias estimation, determinism, batch consistency, gauge.

mod common;

use common::Analytic;
use common::world::{FRAME_NS, IMU_NS, World, align_position_yaw};
use estimator::estimator::{Estimate, Estimator, Status, Suite};
use nalgebra::Vector3;

/// Runs `seconds` of the world through the estimator; returns every estimate.
fn run(world: &mut World, suite: Suite, seconds: f64, record: bool) -> (Estimator, Vec<Estimate>) {
    let mut config = world.config(suite);
    config.record_history = record;
    // Knobs for experiments (unset in CI).
    let knob = |k: &str| std::env::var(k).ok().map(|v| v.parse::<f64>().unwrap());
    if let Some(h) = knob("HUBER") {
        config.huber_sigma = h;
    }
    if let Some(h) = knob("ITERS") {
        config.solver.max_iterations = h as usize;
    }
    if let Some(h) = knob("PARALLAX") {
        config.keyframe_parallax_px = h;
    }
    if let Some(h) = knob("WINDOW") {
        config.window_size = h as usize;
    }
    if let Some(h) = knob("MINFRAMES") {
        config.min_track_frames = h as usize;
    }
    if let Some(h) = knob("REANCHOR") {
        config.reuse_marginalized_tracks = h > 0.0;
    }
    let mut est = Estimator::new(config).unwrap();
    if std::env::var("KNOWNSTART").is_ok() {
        let t0 = 0;
        est.start_from(
            Analytic::pose(t0),
            Analytic::velocity(0.0),
            world.ba,
            world.bg,
        );
    }
    let mut out = Vec::new();
    let end = (seconds * 1e9) as i64;
    let mut t_imu = 0;
    let mut t_frame = 0;
    while t_frame <= end {
        while t_imu <= t_frame {
            out.extend(est.push_imu(world.imu(t_imu)).unwrap());
            t_imu += IMU_NS;
        }
        out.extend(est.push_frame(world.frame(t_frame)).unwrap());
        t_frame += FRAME_NS;
    }
    (est, out)
}

/// RMSE of aligned positions over the tracking estimates.
fn ate(estimates: &[Estimate]) -> f64 {
    let tracked: Vec<&Estimate> = estimates
        .iter()
        .filter(|e| e.status == Status::Tracking)
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
    let seed: u64 = std::env::var("SEED")
        .map(|v| v.parse().unwrap())
        .unwrap_or(1);
    let mut world = World::new(seed, 3000, 1.0);
    let (_, estimates) = run(&mut world, Suite::StereoImu, 20.0, false);
    let tracking = estimates
        .iter()
        .filter(|e| e.status == Status::Tracking)
        .count();
    assert!(tracking > 350, "only {tracking} tracking frames");
    let ate = ate(&estimates);
    let last = estimates.last().unwrap();
    let (dba, dbg) = ((last.ba - world.ba).norm(), (last.bg - world.bg).norm());
    println!("ATE {ate:.4} m, |ba err| {dba:.4} m/s², |bg err| {dbg:.5} rad/s");
    let median = |f: &dyn Fn(&Estimate) -> f64| {
        let mut v: Vec<f64> = estimates
            .iter()
            .filter(|e| e.status == Status::Tracking)
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
    // Measured (seed 1): ATE 1.75 cm, |bg err| 5.5e-4 rad/s, |ba err| 0.031 m/s² at 20 s.
    // The gyroscope bias is pinned by 20 s of visual rotation (the bound is 5% of the true
    // |bg| = 0.02 rad/s); the accelerometer bias trades against tilt and needs rotation about
    // several axes, which this gentle figure-eight (roll/pitch within ±0.2 rad) only partly
    // gives: the bound is half the true |ba| = 0.14 m/s².
    assert!(ate < 0.03, "ATE {ate}");
    assert!(dbg < 1e-3, "gyro bias error {dbg}");
    assert!(dba < 0.07, "accel bias error {dba}");
}

#[test]
fn window_is_within_a_stated_factor_of_the_batch_solution() {
    let px: f64 = std::env::var("PX")
        .map(|v| v.parse().unwrap())
        .unwrap_or(1.0);
    let mut world = World::new(2, 3000, px);
    if let Ok(v) = std::env::var("IMUNOISE") {
        world.imu_noise_scale = v.parse().unwrap();
    }
    if std::env::var("NOBIAS").is_ok() {
        world.ba = Vector3::zeros();
        world.bg = Vector3::zeros();
    }
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
    // Measured (seed 2, 8 s including the 0.5 s start-up): window 3.2 cm (causal estimates),
    // window frames when they leave it 2.7 cm, batch 0.58 cm. The causal estimate of the newest
    // frame has seen no future frames, and the start-up transient weighs on 8 s: a factor of
    // ~5.6, asserted with margin at 8.
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
#[ignore]
fn debug_trace() {
    let suite = if std::env::var("SUITE").as_deref() == Ok("stereo") {
        Suite::Stereo
    } else {
        Suite::StereoImu
    };
    let px: f64 = std::env::var("PX")
        .map(|v| v.parse().unwrap())
        .unwrap_or(1.0);
    let mut world = World::new(1, 3000, px);
    if let Ok(v) = std::env::var("IMUNOISE") {
        world.imu_noise_scale = v.parse().unwrap();
    }
    let secs: f64 = std::env::var("SECS")
        .map(|s| s.parse().unwrap())
        .unwrap_or(6.0);
    let (_, estimates) = run(&mut world, suite, secs, false);
    let p0 = Analytic::pose(estimates[0].t_ns);
    let e0 = estimates[0].T_w_b;
    let step: usize = std::env::var("STEP")
        .map(|v| v.parse().unwrap())
        .unwrap_or(20);
    for e in estimates.iter().step_by(step) {
        let gt = Analytic::pose(e.t_ns);
        // relative to the first frame, in the first frame's body coordinates
        let rel_gt = p0.inverse().compose(&gt);
        let rel_e = e0.inverse().compose(&e.T_w_b);
        let s = e.solver.unwrap();
        let tilt = (e.T_w_b.q.inverse() * Vector3::z())
            .angle(&(gt.q.inverse() * Vector3::z()))
            .to_degrees();
        let yaw_err = {
            let (_, _, ye) = e.T_w_b.q.euler_angles();
            let (_, _, yg) = gt.q.euler_angles();
            (ye - yg).to_degrees()
        };
        print!(
            "tilt={tilt:.2}deg yaw_err={yaw_err:.2} perr={:.3} ba={:.3?} ",
            (e.T_w_b.p - gt.p).norm(),
            e.ba.as_slice()
        );
        println!(
            "t={:.2} {:?} kf={} lm={} err={:.3} rot={:.2}deg cost {:.1}->{:.1} it={} {:?} bg={:.4?} v={:.2?} vgt={:.2?}",
            e.t_ns as f64 * 1e-9,
            e.status,
            e.keyframe,
            e.landmarks,
            (rel_gt.p - rel_e.p).norm(),
            rel_gt.q.angle_to(&rel_e.q).to_degrees(),
            s.initial_cost,
            s.final_cost,
            s.iterations,
            s.termination,
            e.bg.as_slice(),
            e.v_w.as_slice(),
            Analytic::velocity(e.t_ns as f64 * 1e-9).as_slice()
        );
    }
}
