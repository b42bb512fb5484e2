//! Online calibration of the camera extrinsics and the time offset, gated by what the window
//! can observe.
//!
//! Each calibrated quantity — the rig's rotation on the IMU, its translation, the time offset —
//! is in one of three states ([`Gate`]). *Fixed*: a constant (not estimated, or no IMU).
//! *Held*: a variable of every solve, but held at its configured value by a tight prior
//! ([`HOLD_FRACTION`] of its prior σ; [`TD_HOLD_SIGMA_S`] for the time offset). *Free*: only the
//! configured priors hold it. A held quantity is released (for good, until a reset) once the
//! warm-up is over and the window's data determine it: the marginal σ it would have if free —
//! from the window's information with the configured priors but without the hold, landmarks
//! eliminated — is below `calibration_release_sigma_*` in every direction.
//!
//! Holding, rather than fixing, matters: a constant does not enter the marginalization prior, so
//! the prior is built as if the configured value were the truth and keeps it after the release
//! (a 2 cm lever-arm error held constant for 3 s came out 6 cm off). A held quantity is a
//! variable of the prior like any other, and the prior keeps its coupling to the poses. The
//! hold factors themselves touch no state that leaves the window and never enter that prior.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::config::EstimatorConfig;
use super::events::{Event, EventKind};
use super::frame::BlockRef;
use super::window_problem::WindowProblem;
use super::{Estimator, Status};
use crate::factors::RelativePosePrior;
use crate::problem::{Euclidean, Linearization, PoseManifold, PriorFactor};

/// The hold's σ as a fraction of the configured prior's σ.
pub const HOLD_FRACTION: f64 = 0.01;
/// The hold's σ on the time offset (s).
pub const TD_HOLD_SIGMA_S: f64 = 5e-5;

/// How one calibrated quantity enters the window's solves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Gate {
    /// A constant.
    #[default]
    Fixed,
    /// A variable held at its configured value by a tight prior.
    Held,
    /// A variable held only by its configured prior.
    Free,
}

impl Gate {
    /// `Fixed` when not estimated; a fixed quantity that is estimated becomes `Held`;
    /// otherwise unchanged (a release lasts until the window is rebuilt).
    fn configure(&mut self, estimated: bool) {
        *self = match (*self, estimated) {
            (_, false) => Gate::Fixed,
            (Gate::Fixed, true) => Gate::Held,
            (g, true) => g,
        };
    }
}

/// The gates of the rig's rotation and translation on the IMU and of the time offset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CalibrationGates {
    /// Every camera's `R_b_c`.
    pub rotation: Gate,
    /// Every camera's `p_b_c`.
    pub translation: Gate,
    /// The camera–IMU time offset.
    pub td: Gate,
}

impl CalibrationGates {
    /// Whether the extrinsic blocks are variables.
    pub fn extrinsics_variable(&self) -> bool {
        self.rotation != Gate::Fixed || self.translation != Gate::Fixed
    }

    /// Whether the time offset is a variable.
    pub fn td_variable(&self) -> bool {
        self.td != Gate::Fixed
    }

    /// Whether a quantity is still held.
    pub fn any_held(&self) -> bool {
        [self.rotation, self.translation, self.td].contains(&Gate::Held)
    }

    /// The σ (rad, m) of the prior on each camera's extrinsic rotation and translation: the
    /// configured one, or the hold ([`HOLD_FRACTION`] of it) while that part is held.
    fn extrinsic_sigmas(&self, config: &EstimatorConfig) -> (f64, f64) {
        let sigma = |gate: Gate, configured: f64| match gate {
            Gate::Held => HOLD_FRACTION * configured,
            _ => configured,
        };
        (
            sigma(self.rotation, config.extrinsic_prior_sigma_deg.to_radians()),
            sigma(self.translation, config.extrinsic_prior_sigma_m),
        )
    }
}

impl CalibrationGates {
    /// The calibration priors, on variable calibration blocks only; none touches a state that
    /// ever leaves the window, so none enters the marginalization prior: each counts once.
    /// - Each camera's `T_b_c` at its configured value (`extrinsic_prior_sigma_deg` / `_m`),
    ///   the rotation or translation part tightened to the hold while it is held.
    /// - Every camera's pose relative to camera 0 ([`RelativePosePrior`]).
    /// - The time offset at its configured value while it is held.
    pub(super) fn add_priors(&self, built: &mut WindowProblem, config: &EstimatorConfig) {
        let gates = *self;
        let (sigma_r, sigma_t) = gates.extrinsic_sigmas(config);
        let (wr, wt) = (1.0 / sigma_r, 1.0 / sigma_t);
        for (i, camera) in config.cameras.iter().enumerate() {
            let Some(b) = built.variable_block(BlockRef::Extrinsic(i)) else {
                continue;
            };
            let mut jac = vec![0.0; 36];
            for k in 0..3 {
                jac[k * 6 + k] = wt;
                jac[(3 + k) * 6 + 3 + k] = wr;
            }
            let prior = PriorFactor::new(
                vec![Arc::new(PoseManifold)],
                vec![camera.T_b_c.to_array().to_vec()],
                jac,
                vec![0.0; 6],
            )
            .expect("a 6x6 prior on a pose");
            built
                .problem
                .add_factor(Arc::new(prior), None, &[b])
                .expect("sizes match");
        }
        if let Some(first) = config.cameras.first() {
            for (i, camera) in config.cameras.iter().enumerate().skip(1) {
                let (Some(a), Some(b)) = (
                    built.variable_block(BlockRef::Extrinsic(0)),
                    built.variable_block(BlockRef::Extrinsic(i)),
                ) else {
                    continue;
                };
                let prior = RelativePosePrior {
                    T_a_b: first.T_b_c.inverse().compose(&camera.T_b_c),
                    sigma_m: config.extrinsic_relative_prior_sigma_m,
                    sigma_rad: config.extrinsic_relative_prior_sigma_deg.to_radians(),
                };
                built
                    .problem
                    .add_factor(Arc::new(prior), None, &[a, b])
                    .expect("sizes match");
            }
        }
        if gates.td == Gate::Held
            && let Some(b) = built.variable_block(BlockRef::Td)
        {
            let prior = PriorFactor::new(
                vec![Arc::new(Euclidean::new(1))],
                vec![vec![config.td_s]],
                vec![1.0 / TD_HOLD_SIGMA_S],
                vec![0.0],
            )
            .expect("a 1x1 prior");
            built
                .problem
                .add_factor(Arc::new(prior), None, &[b])
                .expect("sizes match");
        }
    }
}

/// The marginal σ (largest over directions) each calibrated quantity would have if it were
/// free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeSigmas {
    /// Rig rotation (rad), from camera 0's extrinsic.
    pub rotation_rad: f64,
    /// Rig translation (m), from camera 0's extrinsic.
    pub translation_m: f64,
    /// Time offset (s).
    pub td_s: f64,
}

/// The σ each calibrated quantity would have with every hold lifted, from the solve's kept
/// linearization `lin` of `built` (built with `gates`). The holds touch only calibration blocks,
/// so the information of the calibration coordinates without them is exactly their marginal
/// information with them (the inverse of their joint marginal covariance) minus the holds' own
/// information: no second build and no second factorization. `None` when there are no
/// calibration variables or the window's information is not positive definite. Camera 0's
/// extrinsic speaks for the rig (the relative priors tie the others to it).
fn free_sigmas(
    built: &WindowProblem,
    lin: &Linearization,
    gates: CalibrationGates,
    config: &EstimatorConfig,
) -> Option<FreeSigmas> {
    // Coordinates: every camera's extrinsic `[δp, δθ]`, then td; camera 0 first. The holds'
    // information: what the prior the window was built with adds over the configured one.
    let mut coords = Vec::new();
    let mut held_info = Vec::new();
    let (sigma_r, sigma_t) = gates.extrinsic_sigmas(config);
    let rotation = sigma_r.powi(-2) - config.extrinsic_prior_sigma_deg.to_radians().powi(-2);
    let translation = sigma_t.powi(-2) - config.extrinsic_prior_sigma_m.powi(-2);
    let extrinsics = built.variable_block(BlockRef::Extrinsic(0)).is_some();
    for i in 0..config.cameras.len() {
        let Some(b) = built.variable_block(BlockRef::Extrinsic(i)) else {
            continue;
        };
        coords.extend((0..6).map(|k| (b, k)));
        held_info.extend([translation; 3]);
        held_info.extend([rotation; 3]);
    }
    let td = built.variable_block(BlockRef::Td);
    if let Some(b) = td {
        coords.push((b, 0));
        held_info.push(match gates.td {
            Gate::Held => TD_HOLD_SIGMA_S.powi(-2),
            _ => 0.0,
        });
    }
    let n = coords.len();
    if n == 0 {
        return None;
    }
    let held = lin.marginal_covariance(&coords)?.cholesky()?;
    let mut info = held.inverse();
    for (k, h) in held_info.iter().enumerate() {
        info[(k, k)] -= h;
    }
    // Invert on the eigenbasis: a direction the data leave (numerically) without information
    // gets a huge variance instead of failing the whole computation.
    let eig = SymmetricEigen::new(0.5 * (&info + info.transpose()));
    let top = eig.eigenvalues.iter().fold(0.0f64, |m, v| m.max(*v));
    let inv: DVector<f64> = eig
        .eigenvalues
        .map(|v| 1.0 / v.max(top * 1e-14).max(1e-300));
    let free = &eig.eigenvectors * DMatrix::from_diagonal(&inv) * eig.eigenvectors.transpose();
    let largest = |o: usize, k: usize| {
        SymmetricEigen::new(free.view((o, o), (k, k)).into_owned())
            .eigenvalues
            .iter()
            .fold(0.0f64, |m, v| m.max(*v))
            .sqrt()
    };
    // Quantities that are not variables are reported as known (σ 0): they are fixed.
    let (translation_m, rotation_rad) = if extrinsics {
        (largest(0, 3), largest(3, 3))
    } else {
        (0.0, 0.0)
    };
    Some(FreeSigmas {
        translation_m,
        rotation_rad,
        td_s: if td.is_some() { largest(n - 1, 1) } else { 0.0 },
    })
}

impl Estimator {
    /// Sets the gates from the configuration before a solve.
    pub(super) fn configure_calibration(&mut self) {
        let g = &mut self.window.calibration;
        g.rotation.configure(self.config.estimate_extrinsics);
        g.translation.configure(self.config.estimate_extrinsics);
        g.td.configure(self.config.estimate_td);
    }

    /// After a solve of `built` (its kept linearization `lin`): releases every held quantity the
    /// window now determines (see the module documentation), each with a
    /// `CalibrationReleased` event. Only while tracking with the IMU and after the warm-up.
    /// Returns the σ each quantity would have if free, where they were computed (while one is
    /// held, after the warm-up).
    pub(super) fn release_calibration(
        &mut self,
        t_ns: i64,
        built: &WindowProblem,
        lin: Option<&Linearization>,
        imu_active: bool,
    ) -> Option<FreeSigmas> {
        let gates = self.window.calibration;
        if !imu_active || self.status != Status::Tracking || !gates.any_held() {
            return None;
        }
        let warmup_ns = (self.config.calibration_warmup_s * 1e9).round() as i64;
        if self.tracking_since.is_none_or(|t0| t_ns - t0 < warmup_ns) {
            return None;
        }
        let sigmas = lin.and_then(|lin| free_sigmas(built, lin, gates, &self.config))?;
        let c = &self.config;
        let checks = [
            (
                &mut self.window.calibration.rotation,
                "rotation",
                sigmas.rotation_rad.to_degrees(),
                c.calibration_release_sigma_deg,
                "°",
            ),
            (
                &mut self.window.calibration.translation,
                "translation",
                sigmas.translation_m * 1e3,
                c.calibration_release_sigma_m * 1e3,
                " mm",
            ),
            (
                &mut self.window.calibration.td,
                "time offset",
                sigmas.td_s * 1e3,
                c.calibration_release_sigma_ms,
                " ms",
            ),
        ];
        for (gate, name, sigma, limit, unit) in checks {
            if *gate == Gate::Held && sigma <= limit {
                *gate = Gate::Free;
                self.events.push(Event {
                    t_ns,
                    kind: EventKind::CalibrationReleased {
                        detail: format!("{name} (σ {sigma:.3}{unit} if free)"),
                    },
                });
            }
        }
        Some(sigmas)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::PinholeRadtan;
    use crate::geometry::Pose;
    use crate::imu::ImuNoise;
    use crate::odometry::config::{CameraConfig, Suite};
    use crate::odometry::window::Window;
    use crate::problem::{BlockKind, Problem, marginal_covariance, solve_keeping_linearization};
    use nalgebra::{UnitQuaternion, Vector3};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn config() -> EstimatorConfig {
        let model = Arc::new(
            PinholeRadtan::new(752, 480, 458.0, 457.0, 367.0, 248.0, 0.0, 0.0, 0.0, 0.0).unwrap(),
        );
        let camera = |y: f64| CameraConfig {
            model: model.clone(),
            T_b_c: Pose::new(
                UnitQuaternion::from_euler_angles(-1.57, 0.0, -1.57),
                Vector3::new(0.0, y, 0.0),
            ),
            pixel_sigma: 1.0,
            rolling_shutter: crate::camera::RollingShutter::GLOBAL,
        };
        let mut c = EstimatorConfig::new(
            Suite::StereoImu,
            vec![camera(0.055), camera(-0.055)],
            ImuNoise::euroc(),
        );
        c.estimate_extrinsics = true;
        c.estimate_td = true;
        c
    }

    /// A window problem in miniature: a pose, both extrinsics and td, tied together by a random
    /// linear "data" factor of rank `rank` (fewer rows than coordinates leave directions the
    /// data do not see), plus the calibration priors for `gates`.
    fn built(gates: CalibrationGates, rank: usize, seed: u64) -> WindowProblem {
        let config = config();
        let mut window = Window::new(config.cameras.iter().map(|c| c.T_b_c).collect(), 0.0);
        window.calibration = gates;
        let mut problem = Problem::new();
        let pose_m: Arc<dyn crate::problem::Manifold> = Arc::new(PoseManifold);
        let pose = problem
            .add_block(
                &Pose::identity().to_array(),
                pose_m.clone(),
                BlockKind::State,
            )
            .unwrap();
        let mut refs = vec![(BlockRef::Pose(0), pose)];
        let mut blocks = vec![pose];
        let mut manifolds = vec![pose_m.clone()];
        let mut points = vec![Pose::identity().to_array().to_vec()];
        for (i, c) in config.cameras.iter().enumerate() {
            let b = problem
                .add_block(&c.T_b_c.to_array(), pose_m.clone(), BlockKind::State)
                .unwrap();
            refs.push((BlockRef::Extrinsic(i), b));
            blocks.push(b);
            manifolds.push(pose_m.clone());
            points.push(c.T_b_c.to_array().to_vec());
        }
        let one: Arc<dyn crate::problem::Manifold> = Arc::new(Euclidean::new(1));
        let td = problem
            .add_block(&[0.0], one.clone(), BlockKind::State)
            .unwrap();
        refs.push((BlockRef::Td, td));
        blocks.push(td);
        manifolds.push(one);
        points.push(vec![0.0]);
        // Data: random rows over all 19 coordinates, scaled like millimetre / 0.1° / ms
        // information.
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let scale = |k: usize| match k % 6 {
            _ if k == 18 => 1e3,
            0..=2 => 3e2,
            _ => 5e2,
        };
        let jac: Vec<f64> = (0..rank * 19)
            .map(|i| rng.random_range(-1.0..1.0) * scale(i % 19))
            .collect();
        let data = PriorFactor::new(manifolds, points, jac, vec![0.0; rank]).unwrap();
        problem.add_factor(Arc::new(data), None, &blocks).unwrap();
        let mut built = WindowProblem::new(problem, refs, Vec::new());
        window.calibration.add_priors(&mut built, &config);
        built
    }

    /// The σ from the held solve's linearization, holds subtracted, equals the σ of the same
    /// problem built without the holds — also when the data leave directions unseen.
    #[test]
    fn free_sigmas_equal_a_build_without_the_holds() {
        let held = CalibrationGates {
            rotation: Gate::Held,
            translation: Gate::Held,
            td: Gate::Held,
        };
        let free = CalibrationGates {
            rotation: Gate::Free,
            translation: Gate::Free,
            td: Gate::Free,
        };
        for (rank, seed) in [(25, 1), (19, 2), (12, 3)] {
            let mut b = built(held, rank, seed);
            let (_, lin) = solve_keeping_linearization(&mut b.problem, &Default::default());
            let got = free_sigmas(&b, &lin.unwrap(), held, &config()).unwrap();
            let f = built(free, rank, seed);
            let coords: Vec<_> = [BlockRef::Extrinsic(0), BlockRef::Td]
                .iter()
                .flat_map(|r| {
                    let id = f.block(*r).unwrap();
                    (0..f.problem.manifold(id).tangent_size()).map(move |k| (id, k))
                })
                .collect();
            let cov = marginal_covariance(&f.problem, &coords).unwrap();
            let largest = |o: usize, k: usize| {
                SymmetricEigen::new(cov.view((o, o), (k, k)).into_owned())
                    .eigenvalues
                    .max()
                    .sqrt()
            };
            let want = [largest(0, 3), largest(3, 3), largest(6, 1)];
            let got = [got.translation_m, got.rotation_rad, got.td_s];
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (g - w).abs() <= 1e-6 * w,
                    "rank {rank}: {got:?} vs {want:?}"
                );
            }
        }
    }

    /// Estimated quantities start held; a release lasts; not estimating fixes them.
    #[test]
    fn gates_start_held_and_stay_released() {
        let mut g = Gate::Fixed;
        g.configure(true);
        assert_eq!(g, Gate::Held);
        g = Gate::Free;
        g.configure(true);
        assert_eq!(g, Gate::Free);
        g.configure(false);
        assert_eq!(g, Gate::Fixed);
    }
}
