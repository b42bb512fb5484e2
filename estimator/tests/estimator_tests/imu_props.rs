//! Preintegration properties: merging, bias Jacobians against re-integration, Monte-Carlo
//! covariance, and a noise-free IMU factor on an analytic trajectory.

use crate::common;
use estimator::factors::ImuFactor;

use common::Analytic;
use estimator::geometry::so3_log;
use estimator::imu::{ImuError, ImuNoise, ImuSample, O_R, O_V, Preintegration};
use nalgebra::{Matrix3, SMatrix, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

fn integrate(
    t0_ns: i64,
    dt_ns: i64,
    n: usize,
    ba: Vector3<f64>,
    bg: Vector3<f64>,
) -> Preintegration {
    let mut p = Preintegration::new(Analytic::sample(t0_ns), ba, bg, ImuNoise::euroc()).unwrap();
    for k in 1..=n as i64 {
        p.push(Analytic::sample(t0_ns + k * dt_ns)).unwrap();
    }
    p
}

fn sb(v: Vector3<f64>) -> [f64; 9] {
    let mut s = [0.0; 9];
    s[..3].copy_from_slice(v.as_slice());
    s
}

#[test]
fn noise_free_imu_factor_vanishes_on_the_analytic_trajectory() {
    // Over 0.5 s the midpoint rule's error shrinks as O(dt²): check the residual is tiny and
    // falls by ≥ 10× from 200 Hz to 800 Hz.
    let t0 = 1_300_000_000;
    let mut errors = Vec::new();
    for rate in [200i64, 400, 800] {
        let dt_ns = 1_000_000_000 / rate;
        let n = (rate / 2) as usize;
        let preint = integrate(t0, dt_ns, n, Vector3::zeros(), Vector3::zeros());
        let f = ImuFactor::new(&preint).unwrap();
        let t1 = preint.end_ns();
        let r = f.raw_residual(
            &Analytic::pose(t0),
            &sb(Analytic::velocity(t0 as f64 * 1e-9)),
            &Analytic::pose(t1),
            &sb(Analytic::velocity(t1 as f64 * 1e-9)),
        );
        let (rp, rq, rv) = (
            r.fixed_rows::<3>(0).norm(),
            r.fixed_rows::<3>(3).norm(),
            r.fixed_rows::<3>(6).norm(),
        );
        assert!(
            rp < 2e-5 && rq < 1e-6 && rv < 1e-4,
            "{rate} Hz: {rp:e} {rq:e} {rv:e}"
        );
        errors.push(rp + rv);
    }
    assert!(errors[0] > 10.0 * errors[2], "not second order: {errors:?}");
}

#[test]
fn merged_preintegration_equals_one_interval_and_composes() {
    let bg = Vector3::new(0.01, -0.02, 0.005);
    let ba = Vector3::new(0.1, -0.05, 0.2);
    let whole = integrate(0, 5_000_000, 120, ba, bg);
    let a = integrate(0, 5_000_000, 50, ba, bg);
    let b = integrate(250_000_000, 5_000_000, 70, ba, bg);
    let mut merged = a.clone();
    merged.merge(&b).unwrap();
    assert_eq!(merged.delta_p(), whole.delta_p());
    assert_eq!(merged.delta_v(), whole.delta_v());
    assert_eq!(merged.delta_q(), whole.delta_q());
    assert_eq!(merged.covariance(), whole.covariance());
    assert_eq!(merged.bias_jacobian(), whole.bias_jacobian());
    // Closed-form composition of the deltas agrees with the merged interval.
    let ra = a.delta_q();
    let alpha = a.delta_p() + a.delta_v() * b.dt() + ra * b.delta_p();
    let beta = a.delta_v() + ra * b.delta_v();
    let gamma = ra * b.delta_q();
    assert!((alpha - whole.delta_p()).norm() < 1e-12);
    assert!((beta - whole.delta_v()).norm() < 1e-12);
    assert!(gamma.angle_to(whole.delta_q()) < 1e-12);
    // Merging intervals that do not touch is an error.
    assert!(matches!(
        integrate(0, 5_000_000, 10, ba, bg).merge(&b),
        Err(ImuError::NotContiguous { .. })
    ));
}

/// `[α, Log(γ₀ᵀγ), β]` of `p` relative to reference deltas.
fn delta_error(
    p: &Preintegration,
    alpha: &Vector3<f64>,
    beta: &Vector3<f64>,
    gamma: &UnitQuaternion<f64>,
) -> SMatrix<f64, 9, 1> {
    let mut e = SMatrix::<f64, 9, 1>::zeros();
    e.fixed_rows_mut::<3>(0).copy_from(&(p.delta_p() - alpha));
    e.fixed_rows_mut::<3>(3)
        .copy_from(&so3_log(&(gamma.inverse() * p.delta_q())));
    e.fixed_rows_mut::<3>(6).copy_from(&(p.delta_v() - beta));
    e
}

#[test]
fn bias_jacobians_match_reintegration() {
    for n in [1usize, 20, 200] {
        let ba = Vector3::new(0.2, -0.1, 0.3);
        let bg = Vector3::new(0.02, 0.01, -0.03);
        let base = integrate(0, 5_000_000, n, ba, bg);
        let (a0, b0, g0) = (*base.delta_p(), *base.delta_v(), *base.delta_q());
        let h = 1e-6;
        for d in 0..6 {
            let mut plus = base.clone();
            let mut minus = base.clone();
            let mut e = Vector3::zeros();
            e[d % 3] = h;
            if d < 3 {
                plus.repropagate(ba + e, bg);
                minus.repropagate(ba - e, bg);
            } else {
                plus.repropagate(ba, bg + e);
                minus.repropagate(ba, bg - e);
            }
            let num = (delta_error(&plus, &a0, &b0, &g0) - delta_error(&minus, &a0, &b0, &g0))
                / (2.0 * h);
            let j = base.bias_jacobian();
            let ana = [
                j.fixed_view::<3, 1>(0, d),
                j.fixed_view::<3, 1>(3, d),
                j.fixed_view::<3, 1>(6, d),
            ];
            for (blk, a) in ana.iter().enumerate() {
                let nm = num.fixed_rows::<3>(3 * blk);
                let scale = nm.norm().max(1e-3);
                assert!(
                    (nm - a).norm() < 1e-5 * scale,
                    "n={n} bias {d} block {blk}: {nm} vs {a}"
                );
            }
        }
        // First-order correction error is second order in the bias change.
        let dbg = Vector3::new(0.01, -0.01, 0.005);
        let dba = Vector3::new(0.05, 0.02, -0.05);
        let mut exact = base.clone();
        exact.repropagate(ba + dba, bg + dbg);
        let (ac, bc, gc) = base.corrected_deltas(&(ba + dba), &(bg + dbg));
        let err = delta_error(&exact, &ac, &bc, &gc).norm();
        let uncorrected = delta_error(&exact, &a0, &b0, &g0).norm();
        assert!(
            err < 0.05 * uncorrected || err < 1e-12,
            "n={n}: {err:e} vs {uncorrected:e}"
        );
    }
}

#[test]
fn monte_carlo_covariance_matches_propagation() {
    let noise = ImuNoise::euroc();
    let (dt_ns, n, draws) = (5_000_000i64, 100usize, 3000usize);
    let dt = dt_ns as f64 * 1e-9;
    let nominal = integrate(0, dt_ns, n, Vector3::zeros(), Vector3::zeros());
    let (a0, b0, g0) = (*nominal.delta_p(), *nominal.delta_v(), *nominal.delta_q());
    let mut rng = ChaCha8Rng::seed_from_u64(20261122);
    let mut gauss3 = |s: f64| {
        let mut v = Vector3::zeros();
        for i in 0..3 {
            let z: f64 = StandardNormal.sample(&mut rng);
            v[i] = z * s;
        }
        v
    };
    let mut sum = SMatrix::<f64, 15, 15>::zeros();
    for _ in 0..draws {
        let (mut ba, mut bg) = (Vector3::zeros(), Vector3::zeros());
        let noisy =
            |k: i64, ba: &Vector3<f64>, bg: &Vector3<f64>, na: Vector3<f64>, ng: Vector3<f64>| {
                let s = Analytic::sample(k * dt_ns);
                ImuSample {
                    t_ns: s.t_ns,
                    gyro: s.gyro + bg + ng,
                    accel: s.accel + ba + na,
                }
            };
        let first = noisy(
            0,
            &ba,
            &bg,
            gauss3(noise.accelerometer_noise_density / dt.sqrt()),
            gauss3(noise.gyroscope_noise_density / dt.sqrt()),
        );
        let mut p = Preintegration::new(first, Vector3::zeros(), Vector3::zeros(), noise).unwrap();
        for k in 1..=n as i64 {
            ba += gauss3(noise.accelerometer_random_walk * dt.sqrt());
            bg += gauss3(noise.gyroscope_random_walk * dt.sqrt());
            let na = gauss3(noise.accelerometer_noise_density / dt.sqrt());
            let ng = gauss3(noise.gyroscope_noise_density / dt.sqrt());
            p.push(noisy(k, &ba, &bg, na, ng)).unwrap();
        }
        let d = delta_error(&p, &a0, &b0, &g0);
        let mut e = SMatrix::<f64, 15, 1>::zeros();
        e.fixed_rows_mut::<9>(0).copy_from(&d);
        // The covariance is that of the IMU factor's residual at the true states, r = h(x) − z,
        // whose delta rows are (true − measured) and bias rows (b_j − b_i). `e` holds −r:
        // measured − true deltas, and minus the bias drift over the interval.
        e.fixed_rows_mut::<3>(9).copy_from(&-ba);
        e.fixed_rows_mut::<3>(12).copy_from(&-bg);
        sum += e * e.transpose();
    }
    let mc = sum / draws as f64;
    let model = nominal.covariance();
    for i in 0..15 {
        let ratio = mc[(i, i)] / model[(i, i)];
        assert!(
            (ratio - 1.0).abs() < 0.10,
            "variance {i}: MC/model = {ratio:.3}"
        );
        for j in 0..i {
            let rho_mc = mc[(i, j)] / (mc[(i, i)] * mc[(j, j)]).sqrt();
            let rho = model[(i, j)] / (model[(i, i)] * model[(j, j)]).sqrt();
            assert!(
                (rho_mc - rho).abs() < 0.1,
                "correlation ({i},{j}): MC {rho_mc:.3} vs model {rho:.3}"
            );
        }
    }
}

#[test]
fn repropagation_resets_the_linearization_point() {
    let mut p = integrate(0, 5_000_000, 40, Vector3::zeros(), Vector3::zeros());
    assert!(!p.repropagate_if_needed(Vector3::new(0.01, 0.0, 0.0), Vector3::zeros(), 0.1, 0.01));
    assert!(p.repropagate_if_needed(Vector3::zeros(), Vector3::new(0.0, 0.02, 0.0), 0.1, 0.01));
    let fresh = integrate(
        0,
        5_000_000,
        40,
        Vector3::zeros(),
        Vector3::new(0.0, 0.02, 0.0),
    );
    assert_eq!(p.delta_p(), fresh.delta_p());
    assert_eq!(p.linearized_bg(), fresh.linearized_bg());
}

#[test]
fn bad_input_is_rejected() {
    assert!(matches!(
        ImuNoise::new(-1.0, 1.0, 1.0, 1.0),
        Err(ImuError::InvalidNoise {
            field: "gyroscope_noise_density",
            ..
        })
    ));
    assert!(ImuNoise::new(1.0, f64::NAN, 1.0, 1.0).is_err());
    assert!(ImuNoise::new(1.0, 1.0, 0.0, 1.0).is_err());
    assert!(ImuSample::new(0, Vector3::new(f64::NAN, 0.0, 0.0), Vector3::zeros()).is_err());
    let mut p = integrate(0, 5_000_000, 3, Vector3::zeros(), Vector3::zeros());
    let last = p.end_ns();
    let same_time = ImuSample {
        t_ns: last,
        gyro: Vector3::zeros(),
        accel: Vector3::zeros(),
    };
    assert!(matches!(
        p.push(same_time),
        Err(ImuError::NonIncreasingTime { .. })
    ));
    let nan = ImuSample {
        t_ns: last + 1,
        gyro: Vector3::zeros(),
        accel: Vector3::new(0.0, f64::INFINITY, 0.0),
    };
    assert!(matches!(p.push(nan), Err(ImuError::NonFiniteSample { .. })));
    // An empty interval cannot become a factor.
    let empty = Preintegration::new(
        Analytic::sample(0),
        Vector3::zeros(),
        Vector3::zeros(),
        ImuNoise::euroc(),
    )
    .unwrap();
    assert!(ImuFactor::new(&empty).is_err());
    // State is unchanged by rejected pushes.
    assert_eq!(p.end_ns(), last);
    let _ = Matrix3::<f64>::identity();
}

/// A clipping sensor: steps over a reading at the gyroscope's range get the range as an extra
/// standard deviation on that axis only. A yaw rate of 2.5 rad/s read as 2.0 (clipped) over
/// ten 5 ms steps: the deltas are those of the readings, the rotation variance about z grows
/// by exactly 10 · (2.0 · 0.005)² (a rotation about z leaves the z variance alone) and the
/// x and y rows stay as without clipping; readings inside the range change nothing at all.
#[test]
fn clipped_readings_widen_only_their_axis() {
    let range = (2.0, 100.0);
    let dt_ns = 5_000_000;
    let sample = |k: i64, wz: f64| {
        ImuSample::new(
            k * dt_ns,
            Vector3::new(0.0, 0.0, wz),
            Vector3::new(0.3, -0.2, 9.81),
        )
        .unwrap()
    };
    let z = Vector3::zeros();
    let build = |wz: f64, clipping: bool| {
        let mut p = Preintegration::new(sample(0, wz), z, z, ImuNoise::euroc()).unwrap();
        if clipping {
            p = p.clipping_at(range);
        }
        for k in 1..=10 {
            p.push(sample(k, wz)).unwrap();
        }
        p
    };
    let (plain, clipped) = (build(2.0, false), build(2.0, true));
    assert!(clipped.clipped() && !plain.clipped());
    assert_eq!(plain.delta_p(), clipped.delta_p());
    assert_eq!(plain.delta_q(), clipped.delta_q());
    let (cp, cc) = (plain.covariance(), clipped.covariance());
    let extra = cc[(O_R + 2, O_R + 2)] - cp[(O_R + 2, O_R + 2)];
    let want = 10.0 * (2.0_f64 * 0.005).powi(2);
    assert!((extra - want).abs() < 1e-9 * want, "{extra} vs {want}");
    for (i, j) in [(0, 0), (1, 1), (0, 1)] {
        let (a, b) = (cp[(O_R + i, O_R + j)], cc[(O_R + i, O_R + j)]);
        assert!((a - b).abs() <= 1e-12 * a.abs().max(1e-12), "({i}, {j})");
    }
    // The attitude's new uncertainty reaches the velocity through the specific force.
    assert!(cc[(O_V, O_V)] > cp[(O_V, O_V)] * 1.01);
    // Inside the range: bit for bit the plain interval.
    let (inside, inside_clipping) = (build(1.5, false), build(1.5, true));
    assert!(!inside_clipping.clipped());
    assert_eq!(inside.covariance(), inside_clipping.covariance());
}
