//! Failure detection and reset: after each window solve the newest state is checked against
//! physical plausibility and against its own prediction (the thresholds of VINS-Fusion's
//! `failureDetection`); a failed window is discarded and the estimator restarts from the last
//! state that passed, keeping the world frame. Also the per-sensor monitors: silence (the live
//! suite), and the IMU samples excluded as spikes or found saturated.

use std::collections::VecDeque;
use std::fmt;

use nalgebra::Vector3;

use super::chi2::chi2_quantile;
use super::config::HealthLimits;
use super::events::{Event, EventKind};
use super::frame::WindowFrame;
use super::window::Window;
use super::window_problem::WindowProblem;
use super::{Estimator, KnownStart, Status};
use crate::geometry::{Pose, so3_log};
use crate::problem::SolverSummary;

/// The window's IMU factors at the solution: `Σ ‖r‖²` and their degrees of freedom.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuChi2 {
    /// Sum of the squared whitened residuals.
    pub chi2: f64,
    /// Total residual dimension.
    pub dof: usize,
}

/// The failure the biases `(ba, bg)` show under `limits`, if any.
fn bias_failure(
    limits: &HealthLimits,
    ba: &Vector3<f64>,
    bg: &Vector3<f64>,
) -> Option<FailureReason> {
    let (ba, bg) = (ba.norm(), bg.norm());
    if ba > limits.max_accel_bias_m_s2 {
        Some(FailureReason::AccelBias(ba))
    } else if bg > limits.max_gyro_bias_rad_s {
        Some(FailureReason::GyroBias(bg))
    } else {
        None
    }
}

/// Why a solved window was judged failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FailureReason {
    /// The solver's cost or a state of the window is not finite.
    NonFinite,
    /// The accelerometer bias norm (m/s²) is implausible.
    AccelBias(f64),
    /// The gyroscope bias norm (rad/s) is implausible.
    GyroBias(f64),
    /// The solved position moved this far (m) from the prediction.
    Jump(f64),
    /// The solved attitude turned this far (deg) from the prediction.
    RotationJump(f64),
    /// The estimated time offset is this far (s) from the configured one.
    TimeOffset(f64),
    /// The window's IMU factors fail their χ² test.
    ImuInconsistent {
        /// `Σ ‖r‖²`.
        chi2: f64,
        /// The test's threshold.
        threshold: f64,
    },
    /// The reprojection test rejected this share of the window's triangulated tracks over
    /// the last `solves` solves: the cameras contradict the window.
    TracksRejected {
        /// Rejected over checked tracks.
        fraction: f64,
        /// Solves summed over.
        solves: usize,
    },
}

impl fmt::Display for FailureReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NonFinite => write!(f, "non-finite solution"),
            Self::AccelBias(n) => write!(f, "accelerometer bias {n:.2} m/s²"),
            Self::GyroBias(n) => write!(f, "gyroscope bias {n:.2} rad/s"),
            Self::Jump(d) => write!(f, "position jump {d:.2} m against the prediction"),
            Self::RotationJump(a) => write!(f, "rotation jump {a:.1}° against the prediction"),
            Self::TimeOffset(d) => {
                write!(f, "time offset {:.1} ms from the configured one", d * 1e3)
            }
            Self::ImuInconsistent { chi2, threshold } => write!(
                f,
                "IMU factors inconsistent: χ² {chi2:.0} above {threshold:.0}"
            ),
            Self::TracksRejected { fraction, solves } => write!(
                f,
                "cameras contradict the window: {:.0} % of its tracks rejected as outliers \
                 over {solves} solves",
                fraction * 100.0
            ),
        }
    }
}

/// Checks a solved window: every state finite, then the newest frame's biases, the time
/// offset's distance from `td_configured_s` and the IMU factors' χ² (when `imu` is given), and
/// the newest frame's distance and angle from `predicted`, its pose before the solve.
pub(super) fn check_window(
    window: &Window,
    summary: &SolverSummary,
    predicted: &Pose,
    imu: Option<ImuChi2>,
    limits: &HealthLimits,
    td_configured_s: f64,
) -> Option<FailureReason> {
    let finite = |f: &WindowFrame| {
        f.pose.p.iter().all(|v| v.is_finite())
            && f.pose.q.coords.iter().all(|v| v.is_finite())
            && f.v
                .iter()
                .chain(f.ba.iter())
                .chain(f.bg.iter())
                .all(|v| v.is_finite())
    };
    if !summary.final_cost.is_finite()
        || !window.frames.iter().all(finite)
        || !window.td.is_finite()
    {
        return Some(FailureReason::NonFinite);
    }
    let newest = window.frames.back()?;
    if let Some(chi) = imu {
        if let Some(failure) = bias_failure(limits, &newest.ba, &newest.bg) {
            return Some(failure);
        }
        let td_deviation = (window.td - td_configured_s).abs();
        if td_deviation > limits.max_time_offset_deviation_s {
            return Some(FailureReason::TimeOffset(td_deviation));
        }
        let threshold = chi2_quantile(chi.dof, limits.imu_chi2_z);
        // A NaN χ² fails too.
        if chi.dof > 0 && (chi.chi2.is_nan() || chi.chi2 > threshold) {
            return Some(FailureReason::ImuInconsistent {
                chi2: chi.chi2,
                threshold,
            });
        }
    }
    let jump = (newest.pose.p - predicted.p).norm();
    if jump > limits.max_jump_m {
        return Some(FailureReason::Jump(jump));
    }
    let angle = so3_log(&(predicted.q.inverse() * newest.pose.q))
        .norm()
        .to_degrees();
    (angle > limits.max_rotation_jump_deg).then_some(FailureReason::RotationJump(angle))
}

/// The χ² of `built`'s IMU factors at its current values.
fn imu_chi2(built: &WindowProblem) -> ImuChi2 {
    let factors = || built.imu.iter().map(|(r, _)| *r);
    ImuChi2 {
        chi2: factors()
            .filter_map(|r| built.problem.residual_squared_norm(r))
            .sum(),
        dof: factors()
            .map(|r| built.problem.factor(r).residual_dim())
            .sum(),
    }
}

/// The reprojection test's verdicts over the last solves (see
/// [`HealthLimits::max_rejected_fraction`]).
#[derive(Clone, Debug, Default)]
pub(super) struct RejectionMonitor {
    /// `(checked, rejected)` tracks of each of the last solves, oldest first.
    recent: VecDeque<(usize, usize)>,
}

impl RejectionMonitor {
    /// Records one solve's test; the failure once the last `limits.rejected_solves` solves
    /// rejected more than `limits.max_rejected_fraction` of the tracks they checked.
    pub(super) fn push(
        &mut self,
        checked: usize,
        rejected: usize,
        limits: &HealthLimits,
    ) -> Option<FailureReason> {
        let solves = limits.rejected_solves;
        self.recent.push_back((checked, rejected));
        while self.recent.len() > solves {
            self.recent.pop_front();
        }
        let (c, r) = self
            .recent
            .iter()
            .fold((0, 0), |(c, r), (ci, ri)| (c + ci, r + ri));
        let fraction = r as f64 / c.max(1) as f64;
        (self.recent.len() == solves && fraction > limits.max_rejected_fraction)
            .then_some(FailureReason::TracksRejected { fraction, solves })
    }

    /// Forgets the solves recorded (a new window).
    pub(super) fn clear(&mut self) {
        self.recent.clear();
    }
}

impl Estimator {
    /// Judges the solved window `built` (written back) with [`check_window`], its IMU factors
    /// included when `imu_active`. The IMU χ² test must fail in `imu_chi2_solves` consecutive
    /// solves before it counts: a window whose states were carried by vision alone (an IMU
    /// gap) fails it once or twice while they converge.
    pub(super) fn window_failure(
        &mut self,
        built: &WindowProblem,
        summary: &SolverSummary,
        predicted: &Pose,
        imu_active: bool,
    ) -> Option<FailureReason> {
        let chi2 = imu_active.then(|| imu_chi2(built));
        let failure = check_window(
            &self.window,
            summary,
            predicted,
            chi2,
            &self.config.health,
            self.config.td_s,
        );
        match failure {
            Some(FailureReason::ImuInconsistent { .. }) => {
                self.imu_chi2_failures += 1;
                failure.filter(|_| self.imu_chi2_failures >= self.config.health.imu_chi2_solves)
            }
            other => {
                self.imu_chi2_failures = 0;
                other
            }
        }
    }

    /// Re-evaluates which sensors deliver at time `now_ns` (a sensor silent for longer than
    /// `sensor_timeout_s` is out) and reports a switch when that changed.
    pub(super) fn monitor_sensors(&mut self, now_ns: i64) {
        // A monotonic clock: a frame pushed at IMU time `t + td` may lie before the newest IMU
        // sample (`td < 0`), and judging at that earlier time would call a silent camera back.
        let now_ns = self.monitor_t.map_or(now_ns, |t| t.max(now_ns));
        self.monitor_t = Some(now_ns);
        let timeout = (self.config.sensor_timeout_s * 1e9) as i64;
        let first = *self.first_t.get_or_insert(now_ns);
        let fresh = |t: Option<i64>| now_ns - t.unwrap_or(first) <= timeout;
        let n_cameras = self.config.cameras.len();
        let frozen = self.frozen.frozen;
        let cameras = [0, 1].map(|c| c < n_cameras && fresh(self.last_features_t[c]) && !frozen[c]);
        let imu = self.config.suite.uses_imu() && fresh(self.last_imu_t);
        if (cameras, imu) == (self.live_cameras, self.live_imu) {
            return;
        }
        let change = |was: bool, now: bool, name: String, lost: &str| match (was, now) {
            (true, false) => Some(format!("{name} {lost}")),
            (false, true) => Some(format!("{name} back")),
            _ => None,
        };
        let why: Vec<String> = (0..2)
            .filter_map(|c| {
                let lost = if frozen[c] { "frozen" } else { "silent" };
                change(
                    self.live_cameras[c],
                    cameras[c],
                    format!("camera {c}"),
                    lost,
                )
            })
            .chain(change(self.live_imu, imu, "IMU".to_string(), "silent"))
            .collect();
        let from = self.live_suite();
        (self.live_cameras, self.live_imu) = (cameras, imu);
        self.events.push(Event {
            t_ns: now_ns,
            kind: EventKind::SuiteSwitch {
                from,
                to: self.live_suite(),
                reason: why.join(", "),
            },
        });
    }

    /// Reports the IMU samples excluded since the last call.
    pub(super) fn report_excluded(&mut self) {
        let excluded = self.imu.take_excluded();
        if let Some(&t) = excluded.first() {
            self.events.push(Event {
                t_ns: t,
                kind: EventKind::ImuSamplesExcluded { t_ns: excluded },
            });
        }
        let saturated = self.imu.take_saturated();
        if saturated > 0 {
            self.events.push(Event {
                t_ns: self.imu.newest_t_ns().unwrap_or(0),
                kind: EventKind::ImuSamplesSaturated { count: saturated },
            });
        }
    }

    /// Discards the failed window and restarts from `last_good` (the newest state that passed
    /// the checks; not after [`FailureReason::TracksRejected`], nor when the window restarted
    /// from such a state fails within `restart_trial_s`), keeping the world frame: the
    /// next frame starts at that pose, velocity and biases with the initial prior around them,
    /// the way [`Estimator::start_from`] does. Without a good state (a rejected initialization)
    /// the estimator initializes again from the data. Records a [`EventKind::Reset`] at `t_ns`.
    pub(super) fn reset(&mut self, t_ns: i64, reason: FailureReason) {
        self.imu_chi2_failures = 0;
        self.rejections.clear();
        // A window its cameras contradict drifted there over many solves, and a restarted
        // window that fails again at once started from a failing state: either way the state
        // that last passed is suspect too, and the estimator initializes again from the data.
        let drifted = matches!(reason, FailureReason::TracksRejected { .. });
        let trial_ns = (self.config.health.restart_trial_s * 1e9) as i64;
        let relapsed = self.restarted_at.is_some_and(|t| t_ns - t < trial_ns);
        let reason = match self.last_good.take_if(|_| drifted || relapsed) {
            Some(_) if relapsed => {
                format!("{reason} again after the restart: initializing again")
            }
            Some(_) => format!("{reason}: initializing again"),
            None if self.last_good.is_some() => reason.to_string(),
            None => format!("{reason}; no state passed the checks: initializing again"),
        };
        self.restarted_at = self.last_good.as_ref().map(|_| t_ns);
        self.events.push(Event {
            t_ns,
            kind: EventKind::Reset { reason },
        });
        // Estimated extrinsics and time offset return to their configured values: a failure
        // may come from them. (A time offset that is not estimated stays at `td_s`.)
        let extrinsics = if self.config.estimate_extrinsics {
            self.config.cameras.iter().map(|c| c.T_b_c).collect()
        } else {
            self.window.extrinsics.clone()
        };
        // The aiding buffers and the GNSS alignment with its initialization prior survive (the
        // world frame is kept); what the window had learnt about the alignment is lost.
        let aiding = std::mem::take(&mut self.window.aiding);
        self.window = Window::new(extrinsics, self.config.td_s);
        self.window.aiding = aiding;
        self.tracking_since = None;
        self.known_start = None;
        self.pending_bias_prior = false;
        self.status = Status::Initializing;
        if let Some(good) = self.last_good.take() {
            let uses_imu = self.config.suite.uses_imu();
            let plausible = bias_failure(&self.config.health, &good.ba, &good.bg).is_none();
            let zero = Vector3::zeros();
            self.known_start = Some(KnownStart {
                pose: good.pose,
                v: good.v,
                ba: if plausible { good.ba } else { zero },
                bg: if plausible { good.bg } else { zero },
            });
            if uses_imu {
                self.status = Status::Tracking;
                self.pending_bias_prior = true;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::problem::Termination;
    use nalgebra::UnitQuaternion;
    use std::collections::VecDeque;

    fn window_with(newest: WindowFrame) -> Window {
        let mut w = Window::new(vec![Pose::identity()], 0.0);
        w.frames = VecDeque::from(vec![newest]);
        w
    }

    fn frame(p: Vector3<f64>, yaw: f64, ba: f64, bg: f64) -> WindowFrame {
        WindowFrame {
            seq: 0,
            t_ns: 0,
            pose: Pose::new(UnitQuaternion::from_euler_angles(0.0, 0.0, yaw), p),
            v: Vector3::zeros(),
            ba: Vector3::new(ba, 0.0, 0.0),
            bg: Vector3::new(0.0, bg, 0.0),
            preint: None,
        }
    }

    fn summary(cost: f64) -> SolverSummary {
        SolverSummary {
            iterations: 1,
            successful_steps: 1,
            initial_cost: cost,
            final_cost: cost,
            termination: Termination::Converged,
            reduced_size: 0,
            landmarks: 0,
            time: std::time::Duration::ZERO,
        }
    }

    /// Each detector fires just past its limit and stays silent just inside it.
    #[test]
    fn detectors_fire_past_their_limits_only() {
        let limits = HealthLimits::default();
        let at = Pose::identity();
        let quiet = Some(ImuChi2 {
            chi2: 100.0,
            dof: 150,
        });
        let check = |f: WindowFrame, cost: f64| {
            check_window(&window_with(f), &summary(cost), &at, quiet, &limits, 0.0)
        };
        let z = Vector3::zeros();
        assert_eq!(check(frame(z, 0.0, 2.4, 0.9), 1.0), None);
        assert_eq!(
            check(frame(z, 0.0, 2.6, 0.0), 1.0),
            Some(FailureReason::AccelBias(2.6))
        );
        assert_eq!(
            check(frame(z, 0.0, 0.0, 1.1), 1.0),
            Some(FailureReason::GyroBias(1.1))
        );
        assert_eq!(check(frame(Vector3::x() * 4.9, 0.0, 0.0, 0.0), 1.0), None);
        assert!(matches!(
            check(frame(Vector3::x() * 5.1, 0.0, 0.0, 0.0), 1.0),
            Some(FailureReason::Jump(_))
        ));
        assert_eq!(check(frame(z, 49f64.to_radians(), 0.0, 0.0), 1.0), None);
        assert!(matches!(
            check(frame(z, 51f64.to_radians(), 0.0, 0.0), 1.0),
            Some(FailureReason::RotationJump(_))
        ));
        assert_eq!(
            check(frame(z, 0.0, 0.0, 0.0), f64::NAN),
            Some(FailureReason::NonFinite)
        );
        assert_eq!(
            check(frame(Vector3::new(f64::NAN, 0.0, 0.0), 0.0, 0.0, 0.0), 1.0),
            Some(FailureReason::NonFinite)
        );
        // Vision only: the biases are not judged.
        let f = frame(z, 0.0, 9.0, 9.0);
        assert_eq!(
            check_window(&window_with(f), &summary(1.0), &at, None, &limits, 0.0),
            None
        );
        // The time offset, against the configured 20 ms: 100 ms either side passes.
        let with_td = |td: f64| {
            let mut w = window_with(frame(z, 0.0, 0.0, 0.0));
            w.td = td;
            check_window(&w, &summary(1.0), &at, quiet, &limits, 0.02)
        };
        assert_eq!(with_td(0.119), None);
        assert_eq!(with_td(-0.079), None);
        assert!(
            matches!(with_td(0.121), Some(FailureReason::TimeOffset(d)) if (d - 0.101).abs() < 1e-12)
        );
        assert!(matches!(
            with_td(-0.081),
            Some(FailureReason::TimeOffset(_))
        ));
        assert_eq!(with_td(f64::NAN), Some(FailureReason::NonFinite));
        // Vision only: the offset is not a variable and is not judged.
        let mut w = window_with(frame(z, 0.0, 0.0, 0.0));
        w.td = 0.5;
        assert_eq!(
            check_window(&w, &summary(1.0), &at, None, &limits, 0.0),
            None
        );
        // The IMU χ² test: 150 degrees of freedom at 4.75 σ → 247.3.
        let threshold = chi2_quantile(150, 4.75);
        assert!((threshold - 247.3).abs() < 0.1, "{threshold}");
        let chi = |chi2| Some(ImuChi2 { chi2, dof: 150 });
        let f = frame(z, 0.0, 0.0, 0.0);
        assert_eq!(
            check_window(
                &window_with(f.clone()),
                &summary(1.0),
                &at,
                chi(246.0),
                &limits,
                0.0
            ),
            None
        );
        assert!(matches!(
            check_window(
                &window_with(f),
                &summary(1.0),
                &at,
                chi(248.0),
                &limits,
                0.0
            ),
            Some(FailureReason::ImuInconsistent { .. })
        ));
    }

    /// Wilson–Hilferty against exact χ² quantiles (R's `qchisq`): 99.9 % (z = 3.0902) at 15
    /// and 150 degrees of freedom, 37.697 and 208.98.
    #[test]
    fn sustained_rejections_fail_and_a_burst_does_not() {
        let limits = HealthLimits::default();
        let mut monitor = RejectionMonitor::default();
        // Healthy: 1 of 150 tracks per solve, never a failure.
        for _ in 0..100 {
            assert_eq!(monitor.push(150, 1, &limits), None);
        }
        // A burst of 40 % in one solve averages out over the 20.
        assert_eq!(monitor.push(150, 60, &limits), None);
        // Sustained 15 %: fails once the 10 % limit is passed over the last 20 solves.
        let mut failed_at = None;
        for k in 0..20 {
            if let Some(FailureReason::TracksRejected { fraction, solves }) =
                monitor.push(100, 15, &limits)
            {
                assert_eq!(solves, 20);
                assert!(fraction > 0.1 && fraction < 0.2, "{fraction}");
                failed_at = Some(k);
                break;
            }
        }
        assert!(matches!(failed_at, Some(8..=19)), "{failed_at:?}");
        // A new window starts counting afresh.
        monitor.clear();
        for _ in 0..19 {
            assert_eq!(monitor.push(100, 50, &limits), None);
        }
        assert!(monitor.push(100, 50, &limits).is_some());
    }
}
