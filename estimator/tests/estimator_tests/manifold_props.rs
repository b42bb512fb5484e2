//! Manifold invariants (Ceres' manifold test suite): x ⊞ 0 = x, (x ⊞ δ) ⊟ x = δ, and both
//! Jacobians against central differences; SO(3) exp/log/Jr identities.

use crate::common;

use common::{pose, rotation, vec3};
use estimator::geometry::{
    quat_minus, quat_plus, right_jacobian, right_jacobian_inv, so3_exp, so3_log,
};
use estimator::problem::{
    CheckOptions, Euclidean, Factor, Manifold, PoseManifold, QuaternionManifold,
    check_factor_jacobians,
};
use nalgebra::{Matrix3, Vector3};
use proptest::prelude::*;

/// `r(y) = y ⊟ x0`: its tangent Jacobian is the manifold's `minus_jacobian`, so the shared
/// checker verifies it.
struct MinusFactor<'a> {
    manifold: &'a dyn Manifold,
    x0: Vec<f64>,
    sizes: [usize; 1],
    tangents: [usize; 1],
}

impl Factor for MinusFactor<'_> {
    fn residual_dim(&self) -> usize {
        self.manifold.tangent_size()
    }
    fn parameter_block_sizes(&self) -> &[usize] {
        &self.sizes
    }
    fn parameter_tangent_sizes(&self) -> &[usize] {
        &self.tangents
    }
    fn evaluate(&self, p: &[&[f64]], r: &mut [f64], j: Option<&mut [Option<&mut [f64]>]>) -> bool {
        self.manifold.minus(p[0], &self.x0, r);
        if let Some(j) = j
            && let Some(b) = j[0].as_deref_mut()
        {
            self.manifold.minus_jacobian(p[0], &self.x0, b);
        }
        true
    }
}

fn invariants(m: &dyn Manifold, x: &[f64], delta: &[f64]) {
    let (a, t) = (m.ambient_size(), m.tangent_size());
    // x ⊞ 0 = x
    let mut out = vec![0.0; a];
    m.plus(x, &vec![0.0; t], &mut out);
    for i in 0..a {
        assert!((out[i] - x[i]).abs() < 1e-15, "x ⊞ 0 ≠ x: {out:?} vs {x:?}");
    }
    // (x ⊞ δ) ⊟ x = δ
    let mut y = vec![0.0; a];
    m.plus(x, delta, &mut y);
    let mut back = vec![0.0; t];
    m.minus(&y, x, &mut back);
    for i in 0..t {
        assert!(
            (back[i] - delta[i]).abs() < 1e-9,
            "(x ⊞ δ) ⊟ x ≠ δ: {back:?} vs {delta:?}"
        );
    }
    // x ⊞ (y ⊟ x) = y
    let mut y2 = vec![0.0; a];
    m.plus(x, &back, &mut y2);
    let mut d = vec![0.0; t];
    m.minus(&y2, &y, &mut d);
    assert!(d.iter().all(|v| v.abs() < 1e-9));
    // Plus-Jacobian by central differences in the ambient space.
    let mut jac = vec![0.0; a * t];
    m.plus_jacobian(x, &mut jac);
    let h = 1e-6;
    for c in 0..t {
        let mut dp = vec![0.0; t];
        dp[c] = h;
        let mut xp = vec![0.0; a];
        m.plus(x, &dp, &mut xp);
        dp[c] = -h;
        let mut xm = vec![0.0; a];
        m.plus(x, &dp, &mut xm);
        for r in 0..a {
            let num = (xp[r] - xm[r]) / (2.0 * h);
            assert!(
                (num - jac[r * t + c]).abs() < 1e-7,
                "plus_jacobian ({r},{c})"
            );
        }
    }
    // Minus-Jacobian through the shared checker, at y and at x itself (identity there).
    for base in [&y, &x.to_vec()] {
        let f = MinusFactor {
            manifold: m,
            x0: x.to_vec(),
            sizes: [a],
            tangents: [t],
        };
        check_factor_jacobians(
            &f,
            std::slice::from_ref(base),
            &[m],
            CheckOptions::default(),
        )
        .unwrap_or_else(|e| panic!("minus_jacobian: {e}"));
    }
}

proptest! {
    #![proptest_config(common::proptest_config(512, 3))]

    #[test]
    fn quaternion_manifold(q in rotation(), delta in vec3(1.5)) {
        invariants(&QuaternionManifold, q.quaternion().coords.as_slice(), delta.as_slice());
    }

    #[test]
    fn pose_manifold(x in pose(100.0), dp in vec3(10.0), dq in vec3(1.5)) {
        let delta = [dp.as_slice(), dq.as_slice()].concat();
        invariants(&PoseManifold, &x.to_array(), &delta);
    }

    #[test]
    fn euclidean_manifold(x in proptest::collection::vec(-1e3..1e3f64, 9),
                          d in proptest::collection::vec(-10.0..10.0f64, 9)) {
        invariants(&Euclidean::new(9), &x, &d);
    }

    #[test]
    fn exp_log_round_trip(q in rotation()) {
        let phi = so3_log(&q);
        prop_assert!(phi.norm() <= std::f64::consts::PI + 1e-12);
        let back = so3_exp(&phi);
        prop_assert!(back.angle_to(&q) < 1e-12);
        // quat ⊕/⊖ are mutual inverses.
        let d = quat_minus(&q, &nalgebra::UnitQuaternion::identity());
        prop_assert!(quat_plus(&nalgebra::UnitQuaternion::identity(), &d).angle_to(&q) < 1e-12);
    }

    #[test]
    fn right_jacobian_is_the_derivative_of_exp(axis in common::axis(), angle in common::angle(),
                                               dir in common::axis()) {
        // Exp(φ + h·d) ≈ Exp(φ) Exp(Jr(φ) h d): central differences of Log(Exp(φ)ᵀ Exp(φ ± h d)).
        let phi = axis * angle.min(3.0);
        let h = 1e-6;
        let r0 = so3_exp(&phi);
        let plus = so3_log(&(r0.inverse() * so3_exp(&(phi + dir * h))));
        let minus = so3_log(&(r0.inverse() * so3_exp(&(phi - dir * h))));
        let numeric = (plus - minus) / (2.0 * h);
        let analytic = right_jacobian(&phi) * dir;
        prop_assert!((numeric - analytic).norm() < 1e-8, "{numeric} vs {analytic}");
        let ident = right_jacobian(&phi) * right_jacobian_inv(&phi) - Matrix3::identity();
        prop_assert!(ident.norm() < 1e-9);
    }
}

#[test]
fn log_is_exact_for_tiny_and_near_pi_angles() {
    for t in [1e-12, 1e-9, 1e-6, 1e-3] {
        let phi = Vector3::new(t, -2.0 * t, 0.5 * t);
        let back = so3_log(&so3_exp(&phi));
        assert!(
            (back - phi).norm() <= 1e-15 * phi.norm().max(1e-300) * 10.0,
            "{t}"
        );
    }
    for eps in [0.0, 1e-12, 1e-9, 1e-6] {
        let phi = Vector3::new(1.0, 2.0, -0.5).normalize() * (std::f64::consts::PI - eps);
        let back = so3_log(&so3_exp(&phi));
        let alt = -back * ((2.0 * std::f64::consts::PI - back.norm()) / back.norm());
        let err = (back - phi).norm().min((alt - phi).norm());
        assert!(err < 1e-9, "π − {eps}: {back} vs {phi}");
    }
}
