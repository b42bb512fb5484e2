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
//! eliminated — is below `calibration_release_sigma_*` in every direction. The time offset is
//! also released once the data contradict its configured value: the estimate it would have if
//! free lies `calibration_release_disagreement_sigmas` of its σ or more from that value, with
//! that σ at most `calibration_contradiction_sigma_ms` ([`FreeView`]). The extrinsics are
//! released only once determined.
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
use crate::problem::{Euclidean, Linearization, Manifold, PoseManifold, PriorFactor};

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

/// What the window's data alone say of one calibrated quantity, from a solve that may hold it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeView {
    /// The marginal σ it would have if free (largest over directions; rad, m or s).
    pub sigma: f64,
    /// How far the configured value lies from the estimate it would have if free, in that
    /// estimate's own uncertainty (the Mahalanobis distance `√(eᵀ Σ⁻¹ e)`); 0 when not held.
    pub disagreement_sigmas: f64,
}

/// What the window's data alone say of each calibrated quantity ([`FreeView`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeViews {
    /// Rig rotation (rad), from camera 0's extrinsic.
    pub rotation: FreeView,
    /// Rig translation (m), from camera 0's extrinsic.
    pub translation: FreeView,
    /// Time offset (s).
    pub td: FreeView,
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
    /// window now determines, or whose configured value its data contradict (see the module
    /// documentation), each with a `CalibrationReleased` event. Only while tracking with the
    /// IMU and after the warm-up. Returns what the data alone say of each quantity, where it
    /// was computed (while one is held, after the warm-up).
    pub(super) fn release_calibration(
        &mut self,
        t_ns: i64,
        built: &WindowProblem,
        lin: Option<&Linearization>,
        imu_active: bool,
    ) -> Option<FreeViews> {
        let gates = self.window.calibration;
        if !imu_active || self.status != Status::Tracking || !gates.any_held() {
            return None;
        }
        let warmup_ns = (self.config.calibration_warmup_s * 1e9).round() as i64;
        if self.tracking_since.is_none_or(|t0| t_ns - t0 < warmup_ns) {
            return None;
        }
        let views = lin.and_then(|lin| free_views(built, lin, gates, &self.config))?;
        let c = &self.config;
        // (gate, name, what the data say, released once σ ≤, released once contradicted while
        // σ ≤ (never for the extrinsics), unit).
        let checks = [
            (
                &mut self.window.calibration.rotation,
                "rotation",
                views.rotation,
                c.calibration_release_sigma_deg.to_radians(),
                None,
                (1f64.to_degrees(), "°"),
            ),
            (
                &mut self.window.calibration.translation,
                "translation",
                views.translation,
                c.calibration_release_sigma_m,
                None,
                (1e3, " mm"),
            ),
            (
                &mut self.window.calibration.td,
                "time offset",
                views.td,
                c.calibration_release_sigma_ms * 1e-3,
                Some(c.calibration_contradiction_sigma_ms * 1e-3),
                (1e3, " ms"),
            ),
        ];
        let contradicted = c.calibration_release_disagreement_sigmas;
        for (gate, name, view, determined, contradiction, (scale, unit)) in checks {
            if *gate != Gate::Held {
                continue;
            }
            let why = if view.sigma <= determined {
                "determined"
            } else if contradiction.is_some_and(|limit| view.sigma <= limit)
                && view.disagreement_sigmas >= contradicted
            {
                "contradicted"
            } else {
                continue;
            };
            *gate = Gate::Free;
            self.events.push(Event {
                t_ns,
                kind: EventKind::CalibrationReleased {
                    detail: format!(
                        "{name} {why} (σ {:.3}{unit} if free, the configured value {:.1} σ \
                         from the free estimate)",
                        view.sigma * scale,
                        view.disagreement_sigmas
                    ),
                },
            });
        }
        Some(views)
    }
}

/// What the window's data alone say of each calibrated quantity, from the solve's kept
/// linearization `lin` of `built` (built with `gates`) and the solved values.
///
/// The σ: the holds touch only calibration blocks, so the information of the calibration
/// coordinates without them is exactly their marginal information with them (the inverse of
/// their joint marginal covariance) minus the holds' own information: no second build and no
/// second factorization.
///
/// The disagreement: at the held solve's optimum the data's gradient balances the holds', `−H_h d`
/// (`d` the held values' offset from the configured ones, `H_h` the holds' information), so one
/// Gauss-Newton step without the holds moves the calibration coordinates by `Σ_f H_h d`
/// (`Σ_f` their marginal covariance if free): the free estimate lies `e = d + Σ_f H_h d` from
/// the configured value — the score test of the hold. Each quantity reports `√(eᵀ Σ_f⁻¹ e)`
/// over its own coordinates.
///
/// `None` when there are no calibration variables or the window's information is not positive
/// definite. Camera 0's extrinsic speaks for the rig (the relative priors tie the others to it).
fn free_views(
    built: &WindowProblem,
    lin: &Linearization,
    gates: CalibrationGates,
    config: &EstimatorConfig,
) -> Option<FreeViews> {
    // Coordinates: every camera's extrinsic `[δp, δθ]`, then td; camera 0 first. The holds'
    // information: what the prior the window was built with adds over the configured one.
    let mut coords = Vec::new();
    let mut held_info = Vec::new();
    let mut offset = Vec::new();
    let (sigma_r, sigma_t) = gates.extrinsic_sigmas(config);
    let rotation = sigma_r.powi(-2) - config.extrinsic_prior_sigma_deg.to_radians().powi(-2);
    let translation = sigma_t.powi(-2) - config.extrinsic_prior_sigma_m.powi(-2);
    let extrinsics = built.variable_block(BlockRef::Extrinsic(0)).is_some();
    for (i, camera) in config.cameras.iter().enumerate() {
        let Some(b) = built.variable_block(BlockRef::Extrinsic(i)) else {
            continue;
        };
        coords.extend((0..6).map(|k| (b, k)));
        held_info.extend([translation; 3]);
        held_info.extend([rotation; 3]);
        let mut d = [0.0; 6];
        PoseManifold.minus(built.problem.values(b), &camera.T_b_c.to_array(), &mut d);
        offset.extend(d);
    }
    let td = built.variable_block(BlockRef::Td);
    if let Some(b) = td {
        coords.push((b, 0));
        held_info.push(match gates.td {
            Gate::Held => TD_HOLD_SIGMA_S.powi(-2),
            _ => 0.0,
        });
        offset.push(built.problem.values(b)[0] - config.td_s);
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
    let d = DVector::from_vec(offset);
    let pull = DVector::from_iterator(n, held_info.iter().zip(d.iter()).map(|(h, d)| h * d));
    let e = &d + &free * pull;
    let view = |o: usize, k: usize, held: bool| {
        let block = free.view((o, o), (k, k)).into_owned();
        let sigma = SymmetricEigen::new(block.clone())
            .eigenvalues
            .iter()
            .fold(0.0f64, |m, v| m.max(*v))
            .sqrt();
        let e = e.rows(o, k).into_owned();
        let disagreement_sigmas = match block.cholesky() {
            Some(c) if held => e.dot(&c.solve(&e)).max(0.0).sqrt(),
            _ => 0.0,
        };
        FreeView {
            sigma,
            disagreement_sigmas,
        }
    };
    // Quantities that are not variables are reported as known (σ 0): they are fixed.
    let known = FreeView {
        sigma: 0.0,
        disagreement_sigmas: 0.0,
    };
    let (translation, rotation) = if extrinsics {
        (
            view(0, 3, gates.translation == Gate::Held),
            view(3, 3, gates.rotation == Gate::Held),
        )
    } else {
        (known, known)
    };
    Some(FreeViews {
        rotation,
        translation,
        td: if td.is_some() {
            view(n - 1, 1, gates.td == Gate::Held)
        } else {
            known
        },
    })
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
    /// data do not see) whose residual at the configured values is `misfit` times a random
    /// vector (0: the data agree with them), plus the calibration priors for `gates`.
    fn built(gates: CalibrationGates, rank: usize, seed: u64, misfit: f64) -> WindowProblem {
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
        let r0: Vec<f64> = (0..rank)
            .map(|_| misfit * rng.random_range(-1.0..1.0))
            .collect();
        let data = PriorFactor::new(manifolds, points, jac, r0).unwrap();
        problem.add_factor(Arc::new(data), None, &blocks).unwrap();
        let mut built = WindowProblem::new(problem, refs, Vec::new());
        window.calibration.add_priors(&mut built, &config);
        built
    }

    /// Every quantity behind the same gate.
    fn all(gate: Gate) -> CalibrationGates {
        CalibrationGates {
            rotation: gate,
            translation: gate,
            td: gate,
        }
    }

    /// The σ from the held solve's linearization, holds subtracted, equals the σ of the same
    /// problem built without the holds — also when the data leave directions unseen.
    #[test]
    fn free_sigmas_equal_a_build_without_the_holds() {
        let (held, free) = (all(Gate::Held), all(Gate::Free));
        for (rank, seed) in [(25, 1), (19, 2), (12, 3)] {
            let mut b = built(held, rank, seed, 0.0);
            let (_, lin) = solve_keeping_linearization(&mut b.problem, &Default::default());
            let got = free_views(&b, &lin.unwrap(), held, &config()).unwrap();
            let f = built(free, rank, seed, 0.0);
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
            let got = [got.translation.sigma, got.rotation.sigma, got.td.sigma];
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (g - w).abs() <= 1e-6 * w,
                    "rank {rank}: {got:?} vs {want:?}"
                );
            }
        }
    }

    /// The disagreement predicted from the held solve is the distance, in σ, between the
    /// configured values and the estimate of the same problem solved without the holds; 0 when
    /// the data agree with the configured values.
    #[test]
    fn disagreement_is_the_free_estimates_distance_from_the_configured_values() {
        let (held, free) = (all(Gate::Held), all(Gate::Free));
        let config = config();
        for (rank, seed, misfit) in [(25, 1, 3.0), (19, 2, 1.0), (30, 4, 0.0)] {
            let mut h = built(held, rank, seed, misfit);
            let (_, lin) = solve_keeping_linearization(&mut h.problem, &Default::default());
            let got = free_views(&h, &lin.unwrap(), held, &config).unwrap();
            let mut f = built(free, rank, seed, misfit);
            solve_keeping_linearization(&mut f.problem, &Default::default());
            let (e0, td) = (
                f.block(BlockRef::Extrinsic(0)).unwrap(),
                f.block(BlockRef::Td).unwrap(),
            );
            let coords: Vec<_> = (0..6).map(|k| (e0, k)).chain([(td, 0)]).collect();
            let cov = marginal_covariance(&f.problem, &coords).unwrap();
            let mut e = [0.0; 7];
            PoseManifold.minus(
                f.problem.values(e0),
                &config.cameras[0].T_b_c.to_array(),
                &mut e,
            );
            e[6] = f.problem.values(td)[0] - config.td_s;
            let distance = |o: usize, k: usize| {
                let e = DVector::from_column_slice(&e[o..o + k]);
                let c = cov.view((o, o), (k, k)).into_owned().cholesky().unwrap();
                e.dot(&c.solve(&e)).sqrt()
            };
            let want = [distance(0, 3), distance(3, 3), distance(6, 1)];
            let got = [
                got.translation.disagreement_sigmas,
                got.rotation.disagreement_sigmas,
                got.td.disagreement_sigmas,
            ];
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (g - w).abs() <= 1e-3 * w.max(1.0),
                    "rank {rank}, misfit {misfit}: {got:?} vs {want:?}"
                );
            }
            if misfit == 0.0 {
                assert!(got.iter().all(|g| *g < 1e-3), "{got:?}");
            } else {
                assert!(got.iter().any(|g| *g > 0.5), "{got:?}");
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
