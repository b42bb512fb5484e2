//! Replay of a recorded ground-truth file: the rapier body tracks the recorded motion.

use sim::motion::Replay;
use sim::{TrajectoryConfig, World, WorldConfig};
use std::path::{Path, PathBuf};

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/euroc_V2_02_medium_4s.txt")
}

/// Tracking errors of a replay: (max position error vs the recorded samples, max attitude
/// error vs the recorded samples in degrees, max position error vs the spline reference).
fn tracking(path: &Path) -> (f64, f64, f64, usize) {
    let replay = Replay::from_file(path, Replay::DEFAULT_KNOT_SPACING_S).unwrap();
    let world = World::new(WorldConfig {
        duration_s: 1000.0,
        trajectory: TrajectoryConfig::Replay {
            path: path.to_path_buf(),
            knot_spacing_s: Replay::DEFAULT_KNOT_SPACING_S,
        },
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    let (mut ep, mut er, mut eref) = (0.0f64, 0.0f64, 0.0f64);
    let mut n = 0;
    for s in &replay.samples {
        let t_ns = ((s.t - replay.t_file0) * 1e9).round() as i64;
        if t_ns > world.end_ns() {
            break;
        }
        let gt = stream.truth(t_ns).unwrap();
        // Keep the stream moving so the truth buffer stays bounded.
        while stream.next().is_some_and(|m| m.t_ns() < t_ns) {}
        let r = world.reference().state(t_ns as f64 * 1e-9);
        ep = ep.max((gt.pose.p - s.p).norm());
        er = er.max(gt.pose.q.angle_to(&s.q).to_degrees());
        eref = eref.max((gt.pose.p - r.p).norm());
        n += 1;
    }
    (ep, er, eref, n)
}

#[test]
fn body_tracks_the_recorded_euroc_motion() {
    let (ep, er, eref, n) = tracking(&fixture());
    println!(
        "fixture: {n} samples, max |p − p_rec| {ep:.2e} m, max attitude {er:.3} deg, max |p − p_ref| {eref:.2e} m"
    );
    assert!(n > 790);
    assert!(eref < 5e-5, "tracking of the spline: {eref}");
    assert!(ep < 1e-3, "position vs recording: {ep}");
    assert!(er < 0.25, "attitude vs recording: {er}");
}

#[test]
fn asl_csv_and_tum_parse_to_the_same_poses() {
    let text = std::fs::read_to_string(fixture()).unwrap();
    let tum = sim::motion::spline::parse_trajectory(&text).unwrap();
    let mut csv = String::from("#timestamp, p_x, p_y, p_z, q_w, q_x, q_y, q_z\n");
    for s in &tum {
        let q = s.q.quaternion();
        csv += &format!(
            "{},{},{},{},{},{},{},{}\n",
            (s.t * 1e9).round() as i64,
            s.p.x,
            s.p.y,
            s.p.z,
            q.w,
            q.i,
            q.j,
            q.k
        );
    }
    let asl = sim::motion::spline::parse_trajectory(&csv).unwrap();
    assert_eq!(asl.len(), tum.len());
    for (a, b) in asl.iter().zip(&tum) {
        assert!(
            (a.t - b.t).abs() < 1e-6 && (a.p - b.p).norm() < 1e-12 && a.q.angle_to(&b.q) < 1e-12
        );
    }
}

/// Tracking error on a full trajectory file: `SIM_TRAJECTORY=path cargo test --release -p sim
/// --test scenario_tests replay:: -- --ignored --nocapture` (without the variable: the 4 s fixture, so that
/// `cargo test -- --ignored` runs everywhere).
#[test]
#[ignore = "a measurement tool for long recordings"]
fn tracking_error_on_file_from_env() {
    let path = std::env::var("SIM_TRAJECTORY")
        .unwrap_or_else(|_| fixture().to_string_lossy().into_owned());
    let replay = Replay::from_file(Path::new(&path), Replay::DEFAULT_KNOT_SPACING_S).unwrap();
    let (fp, fr) = replay.fit_residual_max();
    let (ep, er, eref, n) = tracking(Path::new(&path));
    println!(
        "{path}: {n} samples; spline fit max {fp:.2e} m / {:.3} deg; body vs recording max {ep:.2e} m / {er:.3} deg; body vs spline max {eref:.2e} m",
        fr.to_degrees()
    );
}
