//! Estimator configuration.

use std::sync::Arc;

use super::{GnssConfig, HealthLimits, ImuNoiseModel, WheelConfig, ZeroVelocityConfig};
use crate::camera::{CameraModel, RollingShutter};
use crate::geometry::Pose;
use crate::imu::ImuNoise;
use crate::problem::SolverOptions;

/// Which sensors the estimator fuses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Suite {
    /// Stereo camera and IMU (the default).
    #[default]
    StereoImu,
    /// Stereo camera only (visual odometry; the oldest pose anchors the gauge).
    Stereo,
    /// One camera (the configuration's only camera) and the IMU; metric scale comes from the
    /// IMU at initialization (structure from motion and visual-inertial alignment).
    MonoImu,
}

/// What a persistent point's coordinates are ([`EstimatorConfig::point_coordinates`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointCoordinates {
    /// The world point `X_w`.
    World,
    /// Inverse distance about a fixed anchor.
    #[default]
    InverseDistance,
}

impl Suite {
    /// Whether IMU factors are used.
    pub fn uses_imu(self) -> bool {
        matches!(self, Suite::StereoImu | Suite::MonoImu)
    }

    /// Cameras the suite needs.
    pub fn cameras(self) -> usize {
        match self {
            Suite::StereoImu | Suite::Stereo => 2,
            Suite::MonoImu => 1,
        }
    }
}

/// One camera of the rig.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct CameraConfig {
    /// Projection model (intrinsics and distortion).
    pub model: Arc<dyn CameraModel>,
    /// Extrinsic `T_b_c`: camera to body (IMU) frame.
    pub T_b_c: Pose,
    /// Pixel noise standard deviation (px).
    pub pixel_sigma: f64,
    /// The camera's readout ([`RollingShutter::GLOBAL`] for a global shutter): with
    /// `model_rolling_shutter`, each observation belongs to its row's time.
    pub rolling_shutter: RollingShutter,
}

/// Sliding-window estimator settings (defaults follow VINS-Fusion's EuRoC configuration).
///
/// The rig (`suite`, `cameras`, `imu_noise`) comes from the sensors and is not serialized;
/// every other field is a setting that (de)serializes under its own name (a scenario's
/// `[estimator]` table). Missing keys take [`EstimatorConfig::settings_default`]'s values;
/// a nested table (`solver`, `health`) given in part takes its own type's defaults for the
/// rest, so to change one key of it on top of these defaults, overlay the table on the
/// serialized defaults (as the scenario loader does).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(default = "EstimatorConfig::settings_default", deny_unknown_fields)]
pub struct EstimatorConfig {
    /// Sensor suite.
    #[serde(skip)]
    pub suite: Suite,
    /// Cameras: index 0 is the left (anchor) camera, index 1 the right one (stereo suites);
    /// the one camera of mono+IMU.
    #[serde(skip)]
    pub cameras: Vec<CameraConfig>,
    /// IMU noise densities.
    #[serde(skip)]
    pub imu_noise: ImuNoise,
    /// Pixel noise σ (px) assumed for every camera instead of each camera's own
    /// [`CameraConfig::pixel_sigma`] (the estimator applies it when built); `None`: each
    /// camera's.
    pub pixel_sigma_px: Option<f64>,
    /// `[estimator.imu_noise]`: the IMU noise model assumed instead of `imu_noise` (the
    /// sensor's), key by key (the estimator applies it when built); empty: the sensor's.
    #[serde(rename = "imu_noise", skip_serializing_if = "ImuNoiseModel::is_empty")]
    pub imu_noise_model: ImuNoiseModel,
    /// Keyframes kept in the window (the newest frame comes on top); at least `init_frames`.
    pub window_size: usize,
    /// Keyframes kept for the first `startup_window_s` of tracking with the IMU (`window_size`
    /// or fewer: no start-up phase). Just after the alignment the tilt and the
    /// biases are poorly known, and what a keyframe leaves in the prior is linearized there for
    /// good; a longer window keeps those keyframes until the estimates have settled, then
    /// shrinks back one frame per frame (`sliding.rs`). Off by default (10): 25 keyframes for
    /// 5 s improve the figure-eight (seeds 1–30: 6.15 → 5.37 mm over 20 s, 6.94 → 6.53 mm over
    /// 60 s) but cost rotation on the circles and the replays (9–14 %); book, Window against batch.
    pub startup_window_size: usize,
    /// Seconds of tracking with the IMU (from the first tracked frame, again after every
    /// reset) that the window keeps `startup_window_size` keyframes.
    pub startup_window_s: f64,
    /// Average parallax (px) between the second- and third-newest frames that makes the
    /// second-newest a keyframe.
    pub keyframe_parallax_px: f64,
    /// Fewer features tracked from earlier frames than this makes a keyframe.
    pub keyframe_min_tracked: usize,
    /// Solver settings for each window optimization.
    pub solver: SolverOptions,
    /// Huber threshold on the whitened reprojection residual (σ units).
    pub huber_sigma: f64,
    /// Tracks whose average reprojection error exceeds this many pixel σ of the camera
    /// ([`CameraConfig::pixel_sigma`]) after a solve are dropped; a triangulation is kept only
    /// if every view reprojects within 5× this. 3: VINS-Fusion's 3 px at 1 px noise. In
    /// pixels, as it was, the test dropped sound tracks of a noisier camera (the mean error of
    /// a 2-D Gaussian is 1.25 σ): the default figure-eight at 3 px σ (seed 1) lost most tracks
    /// at every solve and ended at ATE 0.269 m, rotation 2.5°.
    pub outlier_reprojection_sigma: f64,
    /// Valid landmark depth range (m).
    pub min_depth_m: f64,
    /// Valid landmark depth range (m).
    pub max_depth_m: f64,
    /// Camera-IMU time offset `td` (s): a frame stamped `t` was taken at IMU time `t + td`.
    pub td_s: f64,
    /// Estimate `td` online (with the IMU), through image velocities the window's motion
    /// predicts (`time_offset.rs`); held at `td_s` until the window determines it to
    /// `calibration_release_sigma_ms` or contradicts it (`calibration_gates.rs`). Default
    /// figure-eight, seed 1, 60 s: from the true value, released as determined at 38.8 s and at
    /// most 1.12 ms off after the first second; a −10 ms error is contradicted at 5.6 s, within
    /// 2.2 ms after 30 s, −0.80 ms at the end. On by default: a real rig's camera and IMU
    /// clocks disagree by milliseconds, and an offset the window does not model breaks fast
    /// motions (EuRoC V1_01 with 10 ms: 23 IMU-χ² resets and 0.27 m held fixed, 0.0069 m
    /// estimated). It costs 0.15–0.4 ms per frame on the default motion (window bench).
    pub estimate_td: bool,
    /// Model the cameras' rolling shutter (`CameraConfig::rolling_shutter`): each observation
    /// is shifted along its predicted image velocity to its frame's time from its row's own
    /// time, as the time offset shifts it (VINS-Fusion's model). Off: every row is taken at
    /// the stamp, as an estimator that does not know the readout would.
    pub model_rolling_shutter: bool,
    /// Estimate the camera extrinsics online (with the IMU), held near the configured values by
    /// `extrinsic_prior_sigma_*` and, between cameras, `extrinsic_relative_prior_sigma_*`. The
    /// rig's rotation and translation are each held at the configured values until the window
    /// determines them to `calibration_release_sigma_deg` / `_m` (`calibration_gates.rs`).
    pub estimate_extrinsics: bool,
    /// Standard deviation of the configured extrinsic rotations when they are estimated (deg):
    /// a prior factor on each camera's `T_b_c`, applied in every solve and never marginalized
    /// (it touches no state that leaves the window, so it is counted once).
    pub extrinsic_prior_sigma_deg: f64,
    /// Standard deviation of the configured extrinsic translations when estimated (m).
    pub extrinsic_prior_sigma_m: f64,
    /// Standard deviation of the configured relative rotation of every camera to camera 0 when
    /// the extrinsics are estimated (deg): a [`crate::factors::RelativePosePrior`]. A stereo
    /// rig's own calibration knows its baseline far better than where it sits on the IMU; with
    /// only the absolute priors, the two free extrinsics let the baseline, and the scale of every
    /// stereo depth, wander (a 2° / 2 cm rig error on the tilting Lissajous motion, seed 1: the
    /// first loop 20 % too small, ATE 0.119 m).
    pub extrinsic_relative_prior_sigma_deg: f64,
    /// Standard deviation of the configured relative translation of every camera to camera 0
    /// when the extrinsics are estimated (m).
    pub extrinsic_relative_prior_sigma_m: f64,
    /// A minimum time (s) of tracking with the IMU since the last (re)initialization before a
    /// held calibration quantity may be released, on top of the information gate. 0 by default:
    /// the gate already keeps the start-up transient out (from the true extrinsics on the
    /// figure-eight, seed 1, the rotation is released at 2.1 s and moves at most 0.51°), and a
    /// held quantity is a variable of the marginalization prior, so holding it longer folds
    /// nothing wrong into the prior but does cost accuracy while it is wrong.
    pub calibration_warmup_s: f64,
    /// A held extrinsic rotation is released once, free, its marginal σ would be at most this
    /// (deg, largest direction; see `calibration_gates.rs`).
    pub calibration_release_sigma_deg: f64,
    /// A held extrinsic translation is released once, free, its marginal σ would be at most
    /// this (m, largest direction).
    pub calibration_release_sigma_m: f64,
    /// A held time offset is released once, free, its marginal σ would be at most this (ms).
    /// 0.67 by default: right after its release the offset strays up to about 2 σ, so 2/3 ms
    /// keeps it within 2 ms and 3 σ (released at 1 ms, the default figure-eight at 100 points
    /// strayed 1.20–2.11 ms over seeds 1–5; at 0.67 ms, 0.29–1.12 ms).
    pub calibration_release_sigma_ms: f64,
    /// A held time offset is also released before it is determined to
    /// `calibration_release_sigma_ms` once the window's data contradict its configured value:
    /// the estimate it would have if free lies at least this many of that estimate's σ from
    /// it (the score test of the hold, `calibration_gates.rs`), and that σ is at most
    /// `calibration_contradiction_sigma_ms`. So an offset the data agree with stays until they
    /// determine it, and a wrong one goes once they can tell.
    pub calibration_release_disagreement_sigmas: f64,
    /// The largest σ if free (ms) at which a contradicted time offset is released: before, the
    /// start-up transient makes the score test unreliable (a consumer-grade rig, seed 10, was
    /// contradicted at 0.7 s with σ 14 ms and ran 82 ms away).
    pub calibration_contradiction_sigma_ms: f64,
    /// Frames collected for the visual-inertial alignment before IMU factors are used (at most
    /// `window_size`).
    pub init_frames: usize,
    /// Stereo+IMU initialization: the least time (s) the `init_frames` frames of the initial
    /// window are spread over. A frame that comes sooner than `stereo_init_window_s /
    /// init_frames` after the last one kept leaves the window before the alignment, so the
    /// alignment sees the same time span whatever the camera rate. Gravity comes from the
    /// frames' second differences: over 10 frames at 60 Hz (0.15 s) stereo pose noise tilts it
    /// by tenths of a degree, and the window then spends seconds undoing it (EuRoC V2_02
    /// replay at 60 Hz, seeds 1–3: ATE 0.0077 / 0.0149 / 0.0148 m and rotation 0.49 / 0.89 /
    /// 0.89° initialized over 0.15 s; 0.0060 / 0.0055 / 0.0058 m and 0.31 / 0.21 / 0.24°
    /// over 0.45 s). 0.4 s: every frame at 20 Hz and below (the rate the defaults were
    /// measured at), every other at 25–50 Hz, every third at 60 Hz. 0: every frame.
    pub stereo_init_window_s: f64,
    /// Mono+IMU initialization with `estimate_td`: the camera–IMU offset is searched within
    /// ±this (s) of the current estimate, in 5 ms steps, by aligning the window's interior
    /// frames with their IMU intervals cut again at each shifted time (`init/offset.rs`); the
    /// window starts from the best. An offset the alignment does not model bends its gravity:
    /// EuRoC V2_02 replay with 35 ms, seed 1, started 13° tilted and diverged (ATE 13 m).
    /// 0.1 s: the health check's `max_time_offset_deviation_s`. 0: no search.
    pub init_td_search_s: f64,
    /// Mono+IMU initialization: the mean parallax (px) between the structure-from-motion
    /// reference frame and the newest frame (VINS-Mono: 30 px). Until some window frame has
    /// it, initialization waits for more motion.
    pub mono_init_parallax_px: f64,
    /// Mono+IMU initialization: the time (s) the `init_frames` keyframes of the initial window
    /// are spread over (OpenVINS's `init_window_time` is 2 s). Over a shorter window a gentle
    /// motion's acceleration is nearly constant and cannot be told from a tilt of gravity or
    /// the accelerometer bias, which leaves the scale undetermined. Measured with the
    /// `mono_init_max_scale_sigma` gate (seed 1): on the default figure-eight 2 s initializes
    /// at 5.6 s with ATE 0.043 m, 4 s at 3.95 s with 0.033 m; on the EuRoC V2_02 replay 2 s
    /// and 4 s both give 0.0095–0.0097 m (initialized at 1.5 s and 2.9 s).
    pub mono_init_window_s: f64,
    /// Mono+IMU initialization: the largest relative standard deviation of the metric scale
    /// (σ_s / s from the alignment's noise model) accepted; a less observable window waits for
    /// more motion. Motions whose body-frame acceleration is constant (a circle at constant
    /// speed facing along the tangent) never pass: the accelerometer bias absorbs it. 3 %: a
    /// window's scale error after initialization decays only as the window gathers more
    /// information than the initialization had (on the figure-eight a 5 % error took 4 s to
    /// halve), so the start-up transient is what this buys. Seeds 1–5 on the default
    /// figure-eight: ATE 0.0187 / 0.0157 / 0.0092 / 0.0232 / 0.0169 m initialized at 6.05 s,
    /// against 0.0242 / 0.0215 / 0.0132 / 0.0263 / 0.0173 m at 4.05–4.45 s with 5 %; EuRoC
    /// V2_02 unchanged (σ_s/s 1 % at the first try). A mono ground vehicle without wheels,
    /// which 5 % let start at 21.6 s into 0.31 m, does not start (its σ_s/s never falls below
    /// 5 %, and scales 10× apart pass 13 %: it does not observe the scale).
    pub mono_init_max_scale_sigma: f64,
    /// Mono+IMU initialization: the largest whitened residual of the visual-inertial alignment
    /// per degree of freedom accepted (its χ² / dof; about 1 when the IMU deltas, the structure
    /// from motion and their noise model agree). Above it the two contradict each other — a
    /// wrong structure from motion — and the initialization waits for the next keyframe.
    /// Measured on the initializations that start the window: 0.66–1.72 on the figure-eight
    /// and the V2_02 replay (seeds 1–5 each), 1.27–9.63 on EuRoC V1_01's take-off from rest
    /// (seeds 1–16), 1.56 on a 204° Kannala-Brandt stereo rig's left camera. A wrong one: 61 on
    /// V1_01 seed 4 at 4.45 s (let through by a scale gate of 10 %; its first window solve needs
    /// a 4.4 m/s² accelerometer bias). 20: twice the largest consistent value measured.
    /// Infinite: no gate.
    pub mono_init_max_chi2_per_dof: f64,
    /// Re-propagate a preintegration when the accelerometer bias moved more than this (m/s²).
    pub repropagate_ba: f64,
    /// Re-propagate a preintegration when the gyroscope bias moved more than this (rad/s).
    pub repropagate_bg: f64,
    /// Standard deviation of the prior on the accelerometer bias at initialization (m/s²).
    /// Over a short window the accelerometer bias is nearly indistinguishable from tilt; without
    /// this prior noise can trade one for the other.
    pub initial_ba_sigma: f64,
    /// Standard deviation of the prior on the gyroscope bias around its initial estimate (rad/s).
    pub initial_bg_sigma: f64,
    /// Standard deviation (m and rad) of the prior that pins the first frame's position and yaw,
    /// the four unobservable directions of visual-inertial odometry.
    pub gauge_sigma: f64,
    /// After marginalizing a keyframe, keep tracking the landmarks anchored in it (re-anchored in
    /// their next view) as VINS-Fusion does. Their remaining observations are then used both in
    /// the prior and in new factors (counted twice), which makes the window overconfident;
    /// `false` (the default) ends those tracks, and a later sighting starts a new track from
    /// new observations only. Measured on the default figure-eight with 3-dof landmarks (seed
    /// 1, 60 s): ATE 0.0108 m with reuse, 0.0123 m without; run-averaged NEES over seeds 1–6
    /// (20 s) velocity / ba / bg / roll-pitch 5.4 / 4.7 / 7.2 / 3.7 with reuse, 3.9 / 3.5 /
    /// 3.2 / 2.4 without (3, 3, 3, 2 expected).
    pub reuse_marginalized_tracks: bool,
    /// Live tracks anchored in a keyframe about to be marginalized become persistent points
    /// (states carried through marginalization, as OKVIS and Basalt keep landmarks and
    /// OpenVINS its SLAM features), up to this many in the window; the rest end with their
    /// anchor. Each point adds 3 coordinates to the dense reduced system. 0: none. Default 100,
    /// with `marginalize_lost_points` and points in inverse distance (2026-11-28; 30 world
    /// points before): the figure-eight's window/filter ATE ratio over seeds 1–10 median 1.05,
    /// max 1.20 (30 world points: 1.29, 1.62), mean ATE 6.8 → 5.2 mm over seeds 1–6, the four
    /// outdoor scenarios at 0.60–0.76 of their ATE, for 1.6× the back end's cost per frame
    /// (`vio bench`); the catalog, the scenes that lose and the costs in the book ("Window
    /// against batch", "Benchmarks"). Which tracks take the places: spread over the view
    /// (`point_selection`; the figure-eight's mean ATE over seeds 1–30 8.0 → 7.4 mm against
    /// the longest tracks first at 30 points, 2026-11-27).
    pub max_persistent_points: usize,
    /// Marginalize a persistent point as soon as the newest frame no longer observes it (its
    /// track is lost and does not come back), with every observation of it still in the
    /// window, instead of when its last observation leaves the window: its place in
    /// `max_persistent_points` goes to a live track. At 100 points on the figure-eight (60 s,
    /// seeds 1–10) the window/filter ATE ratio goes from median 1.05, max 1.49 to 1.06, 1.16
    /// and the mean ATE from 5.51 to 4.94 mm; at 30 points it changes nothing measurable (seeds
    /// 1–30: 6.94 → 6.96 mm). Default on (book, "Window against batch").
    pub marginalize_lost_points: bool,
    /// What a persistent point's three coordinates are: the world point (`world`), or the
    /// normalized coordinates and inverse distance in the frame of the camera it was anchored
    /// in when it was made, that frame then frozen as a constant (`inverse_distance`; the
    /// projection stays nearly linear over a far point's long distance uncertainty, which a
    /// prior holds for as long as the point lives: [`crate::factors::PointForm`]). Default
    /// inverse distance: at 100 points the outdoor figure-eight with a GNSS outage, seeds 1–4,
    /// mean ATE 117 mm in world coordinates, 57 mm in inverse distance (book, "Far points in
    /// inverse distance").
    pub point_coordinates: PointCoordinates,
    /// First-estimate Jacobians: every factor's Jacobians with respect to a state in the
    /// marginalization prior are evaluated at the prior's linearization point of that state
    /// (residuals at the current estimate), and marginalization keeps those points. The
    /// window's information then keeps the nullspace of visual-inertial odometry (global
    /// position and yaw) instead of gaining information along it from the relinearized
    /// factors.
    pub first_estimate_jacobians: bool,
    /// With `first_estimate_jacobians`, also fix the Jacobians of the persistent world points
    /// at their first estimate, so that the window's nullspace stays exact (4-dimensional).
    /// Relinearizing the points at every solve instead gives the window information about yaw
    /// that no sensor provided, and on a motion that turns all the time that shows: 60 s of
    /// circles facing along the tangent, seeds 1 and 2, ATE 0.0343 / 0.0292 m and rotation
    /// 1.20° / 0.96° relinearized against 0.0141 / 0.0131 m and 0.25° / 0.15° with first
    /// estimates. A first estimate that turns out far off is replaced
    /// (`point_relinearize_fraction`). Default on.
    pub first_estimate_points: bool,
    /// With `first_estimate_points`, while the IMU is in the window: a persistent point whose
    /// estimate has moved from its first estimate by more than this fraction of its distance
    /// from the newest frame gets the estimate as its new first estimate, and the prior's
    /// Jacobian carries the unobservable directions along so that the nullspace stays exact
    /// (`estimator/src/odometry/relinearization.rs`). Measured (seed 1 unless named, 60 s):
    /// left-camera death 0.0289 → 0.0109 m (seeds 2, 3: 0.0069 / 0.0080, unchanged), left-camera
    /// freeze 0.0235 → 0.0081 m, default figure-eight and circle unchanged (no point moves that
    /// far), mono+IMU 0.0187 m either way; 0.05 and 0.2 gave the same within 10 %.
    /// Infinite: never. Points in inverse distance (`point_coordinates`) are never moved.
    pub point_relinearize_fraction: f64,
    /// With `first_estimate_points`, while the IMU is in the window: a point in inverse
    /// distance that drifted as far (`point_relinearize_fraction`) and is seen from three
    /// window frames or more leaves the prior, marginalized out of it alone, and is determined
    /// by the window's observations from its current estimate on (`relinearization.rs`). On by
    /// default since 2026-11-28: over the catalog (45 scenarios, own seeds) 9 better by > 5 %,
    /// 34 within, 1 worse (the wheel-aided monocular ground vehicle's seed 1, 18.2 → 27.4 mm;
    /// its seeds 2 / 3 40.0 / 77.0 → 27.3 / 25.0 mm); the hall's stereo ground vehicles
    /// ×0.54–0.64, the fitted-IMU V1_01 replay 29.9 → 16.1 mm, camera freeze and death ×0.79,
    /// figure-eight 4.9 / 4.6 / 4.9 → 4.8 / 4.2 / 4.7 mm (seeds 1–3); the time offset's pull back
    /// from −10 ms unchanged (book, "Window against batch").
    pub release_drifted_points: bool,
    /// With `first_estimate_jacobians`, while the IMU is in the window: a frame held by the
    /// prior whose position has moved from its first estimate by more than this fraction of
    /// its distance from the newest frame (at least 0.1 m), or its velocity by more than this
    /// fraction of the first estimate's speed (at least 0.1 m/s), gets the estimate as its new
    /// first estimate, with the nullspace kept exact as for points (`relinearization.rs`).
    /// First estimates that stay far from the estimates bias the solution, whose fixed point
    /// makes the first-estimate Jacobians, not the true ones, orthogonal to the residuals:
    /// mono+IMU at 30 Hz (default figure-eight, seed 1) initialized 9 % short of the metric
    /// scale and stayed 2–3 % short for 50 s, ATE 0.0712 m; renewed, the scale is right within
    /// 1 s: 0.0198 m at 0.2 (0.1: 0.0204, 0.3: 0.0264, 0.5: 0.0315 m; no first estimates at
    /// all: 0.0193 m). Stale first estimates also make a diverging window contradict its IMU
    /// sooner: at 0.1 the 1 cm-baseline divergence of `tests/scenario_tests/faults.rs` failed the χ² test only
    /// at 8.75 s (0.91 m), at 0.2 at 3.50 s (0.33 m), as never renewed (3.75 s, 0.29 m).
    /// Infinite: never.
    pub frame_relinearize_fraction: f64,
    /// A track enters the optimization once seen in this many window frames, or in every frame
    /// of a window that has fewer (it also needs two measurements: a stereo pair counts).
    /// VINS-Fusion uses 4. Before the "fewer" rule, 3 and 4 raised the ATE from 3 cm to 26 and
    /// 51 cm: a starting window had no visual factor for its first frames (regression test
    /// `min_track_frames_4_does_not_starve_a_starting_window`). Default 1: every triangulated
    /// track counts at once.
    pub min_track_frames: usize,
    /// Keep every frame's factors to allow [`crate::Estimator::batch_solve`] at the end.
    pub record_history: bool,
    /// Return the marginal covariance of the newest state with every estimate
    /// ([`crate::Estimate::covariance`]) and of the newest pose relative to an earlier window
    /// frame ([`crate::Estimate::relative_pose`]). Both come from the window's Gauss-Newton
    /// information (all factors, landmarks and the prior included) of the solve's last
    /// linearization, with the landmarks eliminated by the Schur complement and the
    /// state-sized system factored once: about 0.6 ms per frame on the window bench, so it is
    /// off by default.
    pub compute_covariance: bool,
    /// With `compute_covariance`: the relative pose runs from the window frame closest to this
    /// long (s) before the newest frame. Half a second: inside a ten-keyframe window at 10–20
    /// keyframes per second, long enough for the IMU and vision to both matter.
    pub relative_pose_interval_s: f64,
    /// IMU spike rejection: a sample farther than this from the per-axis median of its
    /// five-sample neighbourhood (two before, two after) on any gyroscope axis (rad/s) or
    /// accelerometer axis (m/s², the second value) is excluded before preintegration (the
    /// interval integrates across it). It costs two samples of latency. Smooth motion stays far
    /// below the thresholds: the median follows it and 0.3 rad/s or 3 m/s² of change within
    /// 10 ms (30 rad/s², 300 m/s³) is violent. `None`: every sample is used.
    pub imu_spike_threshold: Option<(f64, f64)>,
    /// A sensor silent for longer than this (s) is out of the live suite (a camera: no
    /// features; the IMU: no samples); it is back with its next delivery. Only reporting: the
    /// window always uses whatever measurements arrive.
    pub sensor_timeout_s: f64,
    /// IMU samples farther apart than this (s) break the IMU chain: no interval is
    /// preintegrated across the gap (the frames on both sides are joined by vision only) and
    /// nothing is interpolated over it. Several missing samples at any usual IMU rate
    /// (100–1000 Hz) stay below it.
    pub imu_max_gap_s: f64,
    /// The IMU's measuring ranges `(gyroscope rad/s, accelerometer m/s²)`: a sample at a range
    /// on any axis was clipped, so no IMU interval is cut over it (the frames around it are
    /// joined by vision and the biases' random walk, as across a gap). `None`: never clipped.
    pub imu_range: Option<(f64, f64)>,
    /// Failure detection: the limits of a plausible solved state; past one the window is reset.
    pub health: HealthLimits,
    /// Zero-velocity detection at rest and its factor.
    pub zero_velocity: ZeroVelocityConfig,
    /// GNSS position fixes (used when fixes are pushed; IMU suites).
    pub gnss: GnssConfig,
    /// Wheel odometry (used when readings are pushed; IMU suites).
    pub wheel: WheelConfig,
    /// Fewest landmark observations in the newest frame's solve for the estimate to count as
    /// tracking ([`crate::Status::Tracking`]); below it the frame is reported
    /// [`crate::Status::Degraded`]. Ten: well above the three points a pose needs, so a
    /// frame that sees only a handful of features is not called tracked.
    pub min_tracking_observations: usize,
}

impl EstimatorConfig {
    /// Defaults for a stereo rig given its cameras.
    pub fn new(suite: Suite, cameras: Vec<CameraConfig>, imu_noise: ImuNoise) -> Self {
        Self {
            suite,
            cameras,
            imu_noise,
            pixel_sigma_px: None,
            imu_noise_model: ImuNoiseModel::default(),
            window_size: 10,
            startup_window_size: 10,
            startup_window_s: 0.0,
            keyframe_parallax_px: 10.0,
            keyframe_min_tracked: 20,
            // The window starts next to the optimum (IMU prediction, previous solve): start
            // with almost no damping so weakly observable directions (accelerometer bias
            // against tilt) converge in a few iterations instead of being damped for many.
            solver: SolverOptions {
                max_iterations: 4,
                initial_trust_radius: 1e12,
                // Stop once an accepted step improves the cost by < 1 %: well inside the χ²
                // spread of a window with thousands of residuals. Measured on the window test
                // (seed 1, 20 s): ATE 1.74 cm at a median of 2 iterations vs 1.75 cm at 4.
                function_tolerance: 1e-2,
                // The second step of a frame's solve reuses the first one's factorized system
                // (see `SolverOptions::modified_newton`).
                modified_newton: true,
                ..SolverOptions::default()
            },
            huber_sigma: 1.5,
            outlier_reprojection_sigma: 3.0,
            min_depth_m: 0.1,
            max_depth_m: 100.0,
            td_s: 0.0,
            estimate_td: true,
            model_rolling_shutter: true,
            estimate_extrinsics: false,
            extrinsic_prior_sigma_deg: 2.0,
            extrinsic_prior_sigma_m: 0.02,
            extrinsic_relative_prior_sigma_deg: 0.1,
            extrinsic_relative_prior_sigma_m: 0.001,
            calibration_warmup_s: 0.0,
            calibration_release_sigma_deg: 0.5,
            calibration_release_sigma_m: 0.005,
            calibration_release_sigma_ms: 0.67,
            calibration_release_disagreement_sigmas: 3.0,
            calibration_contradiction_sigma_ms: 5.0,
            init_frames: 10,
            stereo_init_window_s: 0.4,
            init_td_search_s: 0.1,
            mono_init_parallax_px: 30.0,
            mono_init_window_s: 4.0,
            mono_init_max_scale_sigma: 0.03,
            mono_init_max_chi2_per_dof: 20.0,
            repropagate_ba: 0.1,
            repropagate_bg: 0.01,
            initial_ba_sigma: 0.2,
            initial_bg_sigma: 0.01,
            gauge_sigma: 1e-4,
            reuse_marginalized_tracks: false,
            max_persistent_points: 100,
            marginalize_lost_points: true,
            point_coordinates: PointCoordinates::InverseDistance,
            min_track_frames: 1,
            first_estimate_jacobians: true,
            first_estimate_points: true,
            point_relinearize_fraction: 0.1,
            release_drifted_points: true,
            frame_relinearize_fraction: 0.2,
            record_history: false,
            compute_covariance: false,
            relative_pose_interval_s: 0.5,
            imu_spike_threshold: Some((1.0, 10.0)),
            sensor_timeout_s: 0.5,
            imu_max_gap_s: 0.05,
            imu_range: None,
            health: HealthLimits::default(),
            zero_velocity: ZeroVelocityConfig::default(),
            gnss: GnssConfig::default(),
            wheel: WheelConfig::default(),
            min_tracking_observations: 10,
        }
    }
}

impl EstimatorConfig {
    /// The IMU noise the estimator assumes: the sensor's `imu_noise` with `[estimator.imu_noise]`
    /// laid over it (what [`crate::Estimator::new`] uses).
    pub fn assumed_imu_noise(&self) -> ImuNoise {
        self.imu_noise_model.applied_to(self.imu_noise)
    }

    /// [`EstimatorConfig::assumed_imu_noise`] for an estimator whose biases only random-walk
    /// (the Kalibr files an outside estimator reads): a bias process's spread over times short
    /// against its correlation time, `σ_b·√(2/T)`, added in quadrature to each random walk.
    pub fn assumed_imu_noise_as_random_walks(&self) -> ImuNoise {
        let mut n = self.assumed_imu_noise();
        if let Some(p) = self.imu_noise_model.bias_process() {
            let (spread_a, spread_g) = p.random_walk_equivalents();
            let walk = |rw: f64, spread: f64| (rw.powi(2) + spread.powi(2)).sqrt();
            n.gyroscope_random_walk = walk(n.gyroscope_random_walk, spread_g);
            n.accelerometer_random_walk = walk(n.accelerometer_random_walk, spread_a);
        }
        n
    }

    /// The settings' defaults with an empty rig (stereo+IMU, no cameras, EuRoC IMU noise; not
    /// valid on its own); what a deserialized configuration starts from.
    pub fn settings_default() -> Self {
        Self::new(Suite::default(), Vec::new(), ImuNoise::euroc())
    }
}

/// Largest window (keyframes): the dense window solve grows with its cube.
pub const MAX_WINDOW_SIZE: usize = 100;

/// Most persistent world points: each adds 3 coordinates to the dense reduced system.
pub const MAX_PERSISTENT_POINTS: usize = 1000;
