//! Motion: the rapier body tracks its references; the ideal IMU is exactly consistent with the
//! integrator.

use nalgebra::Vector3;
use sim::motion::{
    BodyParams, ControllerGains, Lissajous, MotionSim, Reference, StaticStart, Stop, Stops,
    ideal_imu, integrate_step,
};
use std::sync::Arc;

fn run_consistency(reference: Arc<dyn Reference>, seconds: i64) -> (f64, f64, f64) {
    let h_ns = 1_000_000;
    let mut sim = MotionSim::new(
        reference.clone(),
        BodyParams::default(),
        ControllerGains::default(),
        h_ns,
        0,
    );
    let s0 = sim.state();
    let (mut p, mut q, mut v) = (s0.p, s0.q, s0.v);
    let mut prev = s0;
    let mut max_track: f64 = 0.0;
    for _ in 0..seconds * 1000 {
        let s = sim.step();
        let (f, w) = ideal_imu(&prev, &s);
        integrate_step(&mut p, &mut q, &mut v, &f, &w, 1e-3);
        prev = s;
        let r = reference.state(s.t_ns as f64 * 1e-9);
        max_track = max_track.max((r.p - s.p).norm());
    }
    (
        (p - prev.p).norm(),
        q.angle_to(&prev.q).to_degrees(),
        max_track,
    )
}

#[test]
fn noise_free_imu_reintegrates_to_ground_truth_over_60s() {
    let r: Arc<dyn Reference> = Arc::new(Lissajous::aggressive(Vector3::new(0.0, 0.0, 1.5)));
    let (ep, er, track) = run_consistency(r, 60);
    println!(
        "60 s aggressive: position error {ep:.3e} m, attitude error {er:.3e} deg, max tracking {track:.3e} m"
    );
    assert!(ep < 1e-3, "position error {ep}");
    assert!(er < 0.01, "attitude error {er}");
    assert!(track < 1e-3, "tracking error {track}");
}

#[test]
fn static_start_rests_then_moves() {
    let r: Arc<dyn Reference> = Arc::new(StaticStart {
        inner: Box::new(Lissajous::default()),
        hold_s: 2.0,
        ramp_s: 1.0,
    });
    let mut sim = MotionSim::new(
        r,
        BodyParams::default(),
        ControllerGains::default(),
        1_000_000,
        0,
    );
    let p0 = sim.state().p;
    for _ in 0..1900 {
        let s = sim.step();
        assert!((s.p - p0).norm() < 1e-9 && s.v.norm() < 1e-9 && s.omega_w.norm() < 1e-9);
    }
    for _ in 0..3000 {
        sim.step();
    }
    assert!(sim.state().v.norm() > 0.1);
}

#[test]
fn stops_rest_then_resume_where_they_stopped_with_continuous_rates() {
    let inner = Lissajous::figure_eight(Vector3::new(0.0, 0.0, 1.5), 2.0, 1.0, 20.0);
    let stop = Stop {
        at_s: 4.0,
        duration_s: 3.0,
        ramp_s: 1.0,
    };
    let later = Stop {
        at_s: 12.0,
        duration_s: 2.0,
        ramp_s: 0.5,
    };
    let r = Stops {
        inner: Box::new(inner.clone()),
        stops: vec![stop, later],
    };
    // At rest for the whole rest interval, at the place the inner motion reached.
    let (a, b) = stop.rest_s();
    let at_rest = inner.state(4.5).p; // τ = at_s + ramp/2
    for k in 0..=30 {
        let s = r.state(a + (b - a) * k as f64 / 30.0);
        assert!(s.v.norm() < 1e-12 && s.omega_w.norm() < 1e-12 && s.a.norm() < 1e-12);
        assert!((s.p - at_rest).norm() < 1e-12);
    }
    // After both stops the motion runs 3 + 1 + 2 + 0.5 s behind the inner one.
    let lag = stop.duration_s + stop.ramp_s + later.duration_s + later.ramp_s;
    assert!((r.state(20.0).p - inner.state(20.0 - lag).p).norm() < 1e-12);
    assert_eq!(r.duration(), None);
    // Velocity and acceleration are the derivatives of position and velocity (central
    // differences), through the ramps as well.
    let h = 1e-5;
    for k in 0..1600 {
        let t = 3.5 + k as f64 * 0.01;
        let (sm, s, sp) = (r.state(t - h), r.state(t), r.state(t + h));
        let v = (sp.p - sm.p) / (2.0 * h);
        let acc = (sp.v - sm.v) / (2.0 * h);
        assert!((v - s.v).norm() < 1e-6, "t {t}: v {v} against {}", s.v);
        assert!((acc - s.a).norm() < 1e-4, "t {t}: a {acc} against {}", s.a);
    }
    // The body tracks it.
    let mut sim = MotionSim::new(
        Arc::new(r),
        BodyParams::default(),
        ControllerGains::default(),
        1_000_000,
        0,
    );
    let mut max_rest_speed: f64 = 0.0;
    for _ in 0..8000 {
        let s = sim.step();
        let t = s.t_ns as f64 * 1e-9;
        if t > a + 0.1 && t < b {
            max_rest_speed = max_rest_speed.max(s.v.norm());
        }
    }
    assert!(max_rest_speed < 1e-6, "{max_rest_speed}");
}
