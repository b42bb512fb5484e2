//! `vio selfcheck`: preintegrates a synthetic IMU interval, evaluates the IMU factor at the
//! predicted state, and runs the shared Jacobian checker on every factor kind.

use std::fmt::Write as _;
use std::sync::Arc;

use estimator::factors::{
    AnchorBearing, FeatureMeasurement, ImuFactor, ProjectionOneFrameTwoCam,
    ProjectionTwoFrameOneCam, ProjectionTwoFrameTwoCam,
};
use estimator::geometry::{Pose, so3_exp};
use estimator::imu::{ImuNoise, ImuSample, Preintegration};
use estimator::problem::{
    CheckOptions, Euclidean, Factor, Manifold, PoseManifold, PriorFactor, check_factor_jacobians,
};
use nalgebra::{Vector2, Vector3};

/// A factor to check: name, factor, parameter values, block manifolds.
type FactorCase<'a> = (
    &'a str,
    Box<dyn Factor>,
    Vec<Vec<f64>>,
    Vec<&'a dyn Manifold>,
);

/// Outcome of the self check: the printed report and whether every check passed.
pub struct SelfCheck {
    /// Human-readable report.
    pub report: String,
    /// True when every Jacobian check passed and the IMU residual vanished.
    pub ok: bool,
}

fn imu_sample(k: i64) -> ImuSample {
    let t = k as f64 * 0.005;
    ImuSample {
        t_ns: k * 5_000_000,
        gyro: Vector3::new(0.3 * (2.0 * t).sin(), 0.2, -0.1 * t),
        accel: Vector3::new((3.0 * t).cos(), 0.5, 9.81 + 0.2 * (5.0 * t).sin()),
    }
}

/// Runs the self check (deterministic: no randomness, no clock).
pub fn run() -> SelfCheck {
    let mut out = String::new();
    let mut ok = true;
    let noise = ImuNoise::euroc();
    let mut preint = Preintegration::new(imu_sample(0), Vector3::zeros(), Vector3::zeros(), noise)
        .expect("valid first sample");
    for k in 1..=20 {
        preint
            .push(imu_sample(k))
            .expect("increasing, finite samples");
    }
    let cov = preint.covariance();
    let _ = writeln!(
        out,
        "preintegration: {} samples over {:.3} s (EuRoC ADIS16448 noise)",
        preint.samples().len(),
        preint.dt()
    );
    let _ = writeln!(
        out,
        "  alpha = {:+.6} {:+.6} {:+.6} m   beta = {:+.6} {:+.6} {:+.6} m/s",
        preint.delta_p().x,
        preint.delta_p().y,
        preint.delta_p().z,
        preint.delta_v().x,
        preint.delta_v().y,
        preint.delta_v().z
    );
    let _ = writeln!(
        out,
        "  sigma(alpha) = {:.3e} m   sigma(theta) = {:.3e} rad   sigma(beta) = {:.3e} m/s",
        cov[(0, 0)].sqrt(),
        cov[(3, 3)].sqrt(),
        cov[(6, 6)].sqrt()
    );

    let pose_i = Pose::new(
        so3_exp(&Vector3::new(0.1, -0.2, 0.3)),
        Vector3::new(1.0, 2.0, 0.5),
    );
    let v_i = Vector3::new(0.5, 0.0, 0.1);
    let (pose_j, v_j) = preint.predict(&pose_i, &v_i, &Vector3::zeros(), &Vector3::zeros());
    let imu = ImuFactor::new(&preint).expect("positive-definite covariance");
    let sb = |v: Vector3<f64>| [v.as_slice(), &[0.0; 6]].concat();
    let imu_params = vec![
        pose_i.to_array().to_vec(),
        sb(v_i),
        pose_j.to_array().to_vec(),
        sb(v_j),
    ];
    let mut r = vec![0.0; 15];
    let views: Vec<&[f64]> = imu_params.iter().map(|p| p.as_slice()).collect();
    imu.evaluate(&views, &mut r, None);
    let norm = r.iter().map(|v| v * v).sum::<f64>().sqrt();
    ok &= norm < 1e-6;
    let _ = writeln!(
        out,
        "IMU factor at the predicted state: |whitened residual| = {norm:.2e}"
    );

    let pose = PoseManifold;
    let r1 = Euclidean::new(1);
    let r3 = Euclidean::new(3);
    let r9 = Euclidean::new(9);
    let ex0 = Pose::new(
        so3_exp(&Vector3::new(-1.2, 0.1, -1.5)),
        Vector3::new(0.02, -0.05, 0.01),
    );
    let ex1 = Pose::new(ex0.q, Vector3::new(0.02, 0.06, 0.01));
    let pose_j2 = Pose::new(
        pose_i.q * so3_exp(&Vector3::new(0.02, 0.05, -0.01)),
        pose_i.p + Vector3::new(0.1, -0.05, 0.02),
    );
    let obs = |x: f64, y: f64| FeatureMeasurement {
        point: Vector2::new(x, y),
        velocity: Vector2::new(0.2, -0.1),
        td: 0.0,
    };
    let w = 458.0 / 1.5;
    let ps = |p: &Pose| p.to_array().to_vec();
    let prior_manifolds: Vec<Arc<dyn Manifold>> = vec![Arc::new(PoseManifold)];
    let prior_x0 = pose_i.to_array().to_vec();
    let prior_jac: Vec<f64> = (0..36).map(|k| ((k * 7 % 11) as f64 - 5.0) * 0.3).collect();
    let prior = PriorFactor::new(prior_manifolds, vec![prior_x0], prior_jac, vec![0.1; 6])
        .expect("consistent prior");
    let checks: Vec<FactorCase> = vec![
        (
            "imu",
            Box::new(imu),
            imu_params,
            vec![&pose, &r9, &pose, &r9],
        ),
        (
            "reprojection, 2 frames 1 camera",
            Box::new(ProjectionTwoFrameOneCam {
                obs_i: obs(0.1, 0.2),
                obs_j: obs(0.15, 0.1),
                weight: w,
            }),
            vec![
                ps(&pose_i),
                ps(&pose_j2),
                ps(&ex0),
                vec![0.25, 0.002, -0.001],
                vec![0.004],
            ],
            vec![&pose, &pose, &pose, &r3, &r1],
        ),
        (
            "reprojection, 2 frames 2 cameras",
            Box::new(ProjectionTwoFrameTwoCam {
                obs_i: obs(0.1, 0.2),
                obs_j: obs(0.05, 0.1),
                weight: w,
            }),
            vec![
                ps(&pose_i),
                ps(&pose_j2),
                ps(&ex0),
                ps(&ex1),
                vec![0.25, 0.002, -0.001],
                vec![0.004],
            ],
            vec![&pose, &pose, &pose, &pose, &r3, &r1],
        ),
        (
            "reprojection, 1 frame 2 cameras",
            Box::new(ProjectionOneFrameTwoCam {
                obs_a: obs(0.1, 0.2),
                obs_b: obs(0.07, 0.2),
                weight: w,
            }),
            vec![ps(&ex0), ps(&ex1), vec![0.25, 0.002, -0.001], vec![0.004]],
            vec![&pose, &pose, &r3, &r1],
        ),
        (
            "anchor bearing",
            Box::new(AnchorBearing { weight: w }),
            vec![vec![0.25, 0.002, -0.001]],
            vec![&r3],
        ),
        ("prior", Box::new(prior), vec![ps(&pose_j2)], vec![&pose]),
    ];
    let _ = writeln!(
        out,
        "Jacobian checks (central differences on the manifold):"
    );
    for (name, factor, params, manifolds) in &checks {
        match check_factor_jacobians(factor.as_ref(), params, manifolds, CheckOptions::default()) {
            Ok(worst) => {
                let _ = writeln!(out, "  {name:<34} ok   (worst relative error {worst:.1e})");
            }
            Err(e) => {
                ok = false;
                let _ = writeln!(out, "  {name:<34} FAIL {e}");
            }
        }
    }
    let _ = writeln!(
        out,
        "{}",
        if ok {
            "selfcheck: OK"
        } else {
            "selfcheck: FAILED"
        }
    );
    SelfCheck { report: out, ok }
}

#[cfg(test)]
mod tests {
    #[test]
    fn selfcheck_passes() {
        let r = super::run();
        assert!(r.ok, "{}", r.report);
    }
}
