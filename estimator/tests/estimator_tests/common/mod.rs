//! Shared generators for the estimator's property tests.
#![allow(dead_code)]

pub mod world;

use estimator::geometry::{Pose, so3_exp};
use estimator::gravity_w;
use estimator::imu::ImuSample;
use estimator::problem::{CheckOptions, Factor, Manifold, check_factor_jacobians};
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;

/// Proptest settings for this crate's suites: a fixed seed (the same cases every run, so a test
/// cannot pass or fail by chance) and no failure-persistence files.
pub fn proptest_config(cases: u32, seed: u64) -> ProptestConfig {
    ProptestConfig {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// A rotation angle drawn from the hard cases as well as the bulk: tiny (~1e-9), ordinary,
/// and within 1e-6 of π.
pub fn angle() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => 1e-10..1e-8f64,
        6 => 0.0..std::f64::consts::PI,
        2 => (std::f64::consts::PI - 1e-6)..std::f64::consts::PI,
    ]
}

/// A unit axis (never degenerate).
pub fn axis() -> impl Strategy<Value = Vector3<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
        .prop_filter("non-degenerate axis", |(x, y, z)| {
            x * x + y * y + z * z > 1e-2
        })
        .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize())
}

/// A random rotation including the hard cases.
pub fn rotation() -> impl Strategy<Value = UnitQuaternion<f64>> {
    (axis(), angle()).prop_map(|(a, t)| so3_exp(&(a * t)))
}

/// A bounded random vector.
pub fn vec3(bound: f64) -> impl Strategy<Value = Vector3<f64>> {
    (-bound..bound, -bound..bound, -bound..bound).prop_map(|(x, y, z)| Vector3::new(x, y, z))
}

/// A random pose with translation in a box of half-size `bound`.
pub fn pose(bound: f64) -> impl Strategy<Value = Pose> {
    (rotation(), vec3(bound)).prop_map(|(q, p)| Pose::new(q, p))
}

/// A small random perturbation of rotation (|δ| ≤ max_angle).
pub fn small_rotation(max_angle: f64) -> impl Strategy<Value = UnitQuaternion<f64>> {
    (axis(), 0.0..max_angle).prop_map(|(a, t)| so3_exp(&(a * t)))
}

/// A smooth analytic trajectory: position sinusoids and ZYX Euler angles, with closed-form
/// body rates and specific force.
pub struct Analytic;

impl Analytic {
    pub fn euler(t: f64) -> ([f64; 3], [f64; 3]) {
        let (r, rd) = (0.2 * (0.7 * t).sin(), 0.14 * (0.7 * t).cos());
        let (p, pd) = (0.15 * (0.9 * t).sin(), 0.135 * (0.9 * t).cos());
        let (y, yd) = (
            0.8 * (0.3 * t).sin() + 0.2 * t,
            0.24 * (0.3 * t).cos() + 0.2,
        );
        ([r, p, y], [rd, pd, yd])
    }
    pub fn rotation(t: f64) -> UnitQuaternion<f64> {
        let ([r, p, y], _) = Self::euler(t);
        UnitQuaternion::from_euler_angles(r, p, y)
    }
    pub fn position(t: f64) -> Vector3<f64> {
        Vector3::new(
            2.0 * (0.5 * t).sin(),
            1.5 * (0.8 * t).sin(),
            0.3 * (1.1 * t).sin(),
        )
    }
    pub fn velocity(t: f64) -> Vector3<f64> {
        Vector3::new(
            (0.5 * t).cos(),
            1.2 * (0.8 * t).cos(),
            0.33 * (1.1 * t).cos(),
        )
    }
    pub fn acceleration(t: f64) -> Vector3<f64> {
        Vector3::new(
            -0.5 * (0.5 * t).sin(),
            -0.96 * (0.8 * t).sin(),
            -0.363 * (1.1 * t).sin(),
        )
    }
    pub fn sample(t_ns: i64) -> ImuSample {
        let t = t_ns as f64 * 1e-9;
        let ([r, p, _], [rd, pd, yd]) = Self::euler(t);
        let gyro = Vector3::new(
            rd - yd * p.sin(),
            pd * r.cos() + yd * r.sin() * p.cos(),
            -pd * r.sin() + yd * r.cos() * p.cos(),
        );
        let accel = Self::rotation(t).inverse() * (Self::acceleration(t) - gravity_w());
        ImuSample { t_ns, gyro, accel }
    }
    pub fn pose(t_ns: i64) -> Pose {
        let t = t_ns as f64 * 1e-9;
        Pose::new(Self::rotation(t), Self::position(t))
    }
}

/// The factor tests' Jacobian check: the shared checker at step 1e-6, relative tolerance 1e-5;
/// panics with the worst entry.
pub fn check(factor: &dyn Factor, params: &[Vec<f64>], manifolds: &[&dyn Manifold]) {
    let opts = CheckOptions {
        step: 1e-6,
        rel_tol: 1e-5,
    };
    if let Err(e) = check_factor_jacobians(factor, params, manifolds, opts) {
        panic!("Jacobian check failed: {e}");
    }
}

/// A speed-bias block `[v, ba, bg]`.
pub fn speed_bias(v: Vector3<f64>, ba: Vector3<f64>, bg: Vector3<f64>) -> Vec<f64> {
    v.iter()
        .chain(ba.iter())
        .chain(bg.iter())
        .copied()
        .collect()
}
