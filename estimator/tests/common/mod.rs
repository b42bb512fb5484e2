//! Shared generators for the estimator's property tests.
#![allow(dead_code)]

use estimator::geometry::{Pose, so3_exp};
use nalgebra::{UnitQuaternion, Vector3};
use proptest::prelude::*;

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
