//! Motion: a rapier3d (f64) rigid body driven by a tracking controller; ground truth at the
//! physics rate.
//!
//! # Physics set-up
//! One dynamic body (mass, principal inertia, no collider) in a `PhysicsWorld` with **zero world
//! gravity** (gravity enters only the IMU model, as if a thrust cancelled it), one solver
//! iteration, one substep, sleeping and gyroscopic forces disabled, and forces/torques reset every
//! step. Each rapier step of `h` then is exactly semi-implicit Euler:
//! `v⁺ = v + F/m·h`, `ω⁺ = ω + I_w⁻¹τ·h`, `x⁺ = x + v⁺·h`, `q⁺ = normalize((1 + ω⁺h/2) ⊗ q)`
//! (ω in the world frame). [`PhysicsState`] `j` holds rapier's state after `j` steps, so its
//! `v`/`omega_w` are the rates used over the step *into* it.
//!
//! # Controller
//! PD plus feed-forward, written for that discrete scheme so that the body's step-`j` state
//! matches the reference at `t_j` for pose and at `t_j − h/2` for rates (the velocity rapier
//! stores is the average over the previous step):
//! `a = a_ref(t_j) + Kp·(p_ref(t_j) − p_j) + Kd·(v_ref(t_j − h/2) − v_j)`, `F = m·a`;
//! `α = α_ref(t_j) + Kr·Log(q_ref(t_j) q_jᵀ) + Kw·(ω_ref(t_j − h/2) − ω_j)`, `τ = I_w·α`.
//! With gyroscopic forces disabled the commanded angular acceleration is what rapier applies
//! (equivalently, the controller also cancels the gyroscopic term `ω × Iω`).

mod jumps;
pub mod recording;
pub mod reference;
mod sample_statistics;
pub mod spline;
mod step_blend;
pub mod vehicle;

pub use reference::{Lissajous, RefState, Reference, StaticStart, Stop, Stops};
pub use spline::{PoseSample, PoseSpline, RandomWaypoints, Replay, TrajectoryError};
pub use vehicle::GroundVehicle;

use estimator::geometry::Pose;
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use rapier3d_f64::math::{Rotation, Vector as GVec};
use rapier3d_f64::prelude::{
    MassProperties, PhysicsWorld, RigidBodyBuilder, RigidBodyHandle, RigidBodyVelocity,
};
use std::collections::VecDeque;
use std::sync::Arc;

fn to_na(v: GVec) -> Vector3<f64> {
    Vector3::new(v.x, v.y, v.z)
}
fn to_glam(v: &Vector3<f64>) -> GVec {
    GVec::new(v.x, v.y, v.z)
}
fn quat_to_na(q: &Rotation) -> UnitQuaternion<f64> {
    UnitQuaternion::new_unchecked(Quaternion::new(q.w, q.x, q.y, q.z))
}
fn quat_to_glam(q: &UnitQuaternion<f64>) -> Rotation {
    let c = q.quaternion();
    Rotation::from_xyzw(c.i, c.j, c.k, c.w)
}

/// Mass properties of the simulated body (body frame = IMU frame = centre of mass).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyParams {
    /// Mass (kg).
    pub mass: f64,
    /// Principal moments of inertia about the body axes (kg·m²).
    pub inertia: Vector3<f64>,
}

impl Default for BodyParams {
    /// A ~1.5 kg quadrotor-like body.
    fn default() -> Self {
        Self {
            mass: 1.5,
            inertia: Vector3::new(0.015, 0.017, 0.028),
        }
    }
}

/// Controller gains as natural frequencies and damping ratios.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControllerGains {
    /// Position loop natural frequency (rad/s).
    pub position_omega: f64,
    /// Position loop damping ratio.
    pub position_zeta: f64,
    /// Attitude loop natural frequency (rad/s).
    pub attitude_omega: f64,
    /// Attitude loop damping ratio.
    pub attitude_zeta: f64,
}

impl Default for ControllerGains {
    fn default() -> Self {
        Self {
            position_omega: 20.0,
            position_zeta: 1.0,
            attitude_omega: 40.0,
            attitude_zeta: 1.0,
        }
    }
}

/// Rapier's state after a step (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhysicsState {
    /// Time (ns).
    pub t_ns: i64,
    /// Position (m).
    pub p: Vector3<f64>,
    /// Attitude `R_w_b`.
    pub q: UnitQuaternion<f64>,
    /// Linear velocity used over the step into this state (m/s).
    pub v: Vector3<f64>,
    /// Angular velocity (world frame) used over the step into this state (rad/s).
    pub omega_w: Vector3<f64>,
}

/// Kinematic ground truth of the body at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Kinematics {
    /// Time (ns).
    pub t_ns: i64,
    /// Pose `T_w_b`.
    pub pose: Pose,
    /// Velocity in the world frame (m/s).
    pub v_w: Vector3<f64>,
    /// Acceleration in the world frame (m/s²).
    pub a_w: Vector3<f64>,
    /// Angular velocity in the body frame (rad/s).
    pub omega_b: Vector3<f64>,
}

/// The rapier body, its controller and reference; [`MotionSim::step`] advances one physics step.
pub struct MotionSim {
    world: PhysicsWorld,
    handle: RigidBodyHandle,
    reference: Arc<dyn Reference>,
    body: BodyParams,
    gains: ControllerGains,
    h_ns: i64,
    t_ns: i64,
}

impl std::fmt::Debug for MotionSim {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MotionSim")
            .field("reference", &self.reference)
            .field("body", &self.body)
            .field("gains", &self.gains)
            .field("h_ns", &self.h_ns)
            .field("t_ns", &self.t_ns)
            .finish_non_exhaustive()
    }
}

impl MotionSim {
    /// Places the body on the reference at `t_start_ns` (pose at `t`, rates at `t − h/2`) with a
    /// physics step of `h_ns` nanoseconds.
    pub fn new(
        reference: Arc<dyn Reference>,
        body: BodyParams,
        gains: ControllerGains,
        h_ns: i64,
        t_start_ns: i64,
    ) -> Self {
        assert!(h_ns > 0, "physics step must be positive");
        let mut world = PhysicsWorld::new();
        world.gravity = GVec::ZERO;
        world.integration_parameters.dt = h_ns as f64 * 1e-9;
        world.integration_parameters.num_solver_iterations = 1;
        let t = t_start_ns as f64 * 1e-9;
        let h = h_ns as f64 * 1e-9;
        let r = reference.state(t);
        let rh = reference.state(t - 0.5 * h);
        let rb = RigidBodyBuilder::dynamic()
            .translation(to_glam(&r.p))
            .linvel(to_glam(&rh.v))
            .angvel(to_glam(&rh.omega_w))
            .can_sleep(false)
            .gyroscopic_forces_enabled(false)
            .additional_mass_properties(MassProperties::new(
                GVec::ZERO,
                body.mass,
                to_glam(&body.inertia),
            ))
            .build();
        let handle = world.bodies.insert(rb);
        let b = &mut world.bodies[handle];
        b.set_rotation(quat_to_glam(&r.q), true);
        b.set_vels(
            RigidBodyVelocity {
                linvel: to_glam(&rh.v),
                angvel: to_glam(&rh.omega_w),
            },
            true,
        );
        Self {
            world,
            handle,
            reference,
            body,
            gains,
            h_ns,
            t_ns: t_start_ns,
        }
    }

    /// Physics step (ns).
    pub fn step_ns(&self) -> i64 {
        self.h_ns
    }

    /// The reference being tracked.
    pub fn reference(&self) -> &Arc<dyn Reference> {
        &self.reference
    }

    /// The current state.
    pub fn state(&self) -> PhysicsState {
        let b = &self.world.bodies[self.handle];
        PhysicsState {
            t_ns: self.t_ns,
            p: to_na(b.translation()),
            q: quat_to_na(b.rotation()),
            v: to_na(b.linvel()),
            omega_w: to_na(b.angvel()),
        }
    }

    /// Applies the controller and advances one physics step; returns the new state.
    pub fn step(&mut self) -> PhysicsState {
        let s = self.state();
        let h = self.h_ns as f64 * 1e-9;
        let t = self.t_ns as f64 * 1e-9;
        let r = self.reference.state(t);
        let rh = self.reference.state(t - 0.5 * h);
        let g = &self.gains;
        let kp = g.position_omega * g.position_omega;
        let kd = 2.0 * g.position_zeta * g.position_omega;
        let kr = g.attitude_omega * g.attitude_omega;
        let kw = 2.0 * g.attitude_zeta * g.attitude_omega;
        let a = r.a + (r.p - s.p) * kp + (rh.v - s.v) * kd;
        let e_r = (r.q * s.q.inverse()).scaled_axis();
        let alpha = r.alpha_w + e_r * kr + (rh.omega_w - s.omega_w) * kw;
        let rot = s.q.to_rotation_matrix();
        let i_w =
            rot.matrix() * Matrix3::from_diagonal(&self.body.inertia) * rot.matrix().transpose();
        let torque = i_w * alpha;
        let b = &mut self.world.bodies[self.handle];
        b.reset_forces(false);
        b.reset_torques(false);
        b.add_force(to_glam(&(a * self.body.mass)), true);
        b.add_torque(to_glam(&torque), true);
        self.world.step();
        self.t_ns += self.h_ns;
        self.state()
    }
}

/// The rapier integration scheme applied to an ideal IMU increment: advances `(p, q, v)` by one
/// step `h` with body-frame specific force `f_b` and rate `omega_b` taken over the step:
/// `q⁺ = normalize(q ⊗ [1, ω_b·h/2])`, `v⁺ = v + (R f_b + g)·h`, `p⁺ = p + v⁺·h`, where `R` is the
/// attitude at the start of the step.
pub fn integrate_step(
    p: &mut Vector3<f64>,
    q: &mut UnitQuaternion<f64>,
    v: &mut Vector3<f64>,
    f_b: &Vector3<f64>,
    omega_b: &Vector3<f64>,
    h: f64,
) {
    let a = *q * f_b + estimator::gravity_w();
    *v += a * h;
    *p += *v * h;
    let half = omega_b * (0.5 * h);
    *q = UnitQuaternion::new_normalize(
        q.quaternion() * Quaternion::new(1.0, half.x, half.y, half.z),
    );
}

/// The ideal IMU of the step from `s0` to `s1` (inverse of [`integrate_step`]):
/// `f_b = R₀ᵀ((v₁ − v₀)/h − g)`, `ω_b = R₀ᵀ ω₁`. Returns `(f_b, ω_b)`.
pub fn ideal_imu(s0: &PhysicsState, s1: &PhysicsState) -> (Vector3<f64>, Vector3<f64>) {
    let h = (s1.t_ns - s0.t_ns) as f64 * 1e-9;
    let rt = s0.q.inverse();
    let f = rt * ((s1.v - s0.v) / h - estimator::gravity_w());
    let w = rt * s1.omega_w;
    (f, w)
}

/// A sliding buffer of physics states with interpolated ground-truth queries.
///
/// At step `j` the reported rates are centred: `v(t_j) = (v_j + v_{j+1})/2`,
/// `a(t_j) = (v_{j+1} − v_j)/h`, `ω(t_j) = (ω_j + ω_{j+1})/2`; between steps the position follows
/// the integrator's straight segment `p_j + v_{j+1}(t − t_j)`, attitude is slerped and rates are
/// interpolated linearly.
#[derive(Debug)]
pub struct TruthBuffer {
    sim: MotionSim,
    states: VecDeque<PhysicsState>,
}

impl TruthBuffer {
    /// Starts buffering from the simulator's current state.
    pub fn new(sim: MotionSim) -> Self {
        let mut states = VecDeque::new();
        states.push_back(sim.state());
        Self { sim, states }
    }

    /// Physics step (ns).
    pub fn step_ns(&self) -> i64 {
        self.sim.step_ns()
    }

    /// Time of the oldest buffered state.
    pub fn oldest_ns(&self) -> i64 {
        self.states[0].t_ns
    }

    /// Time of the physics state at or before `t_ns` (on the step grid of the buffer).
    pub fn step_at_or_before(&self, t_ns: i64) -> i64 {
        let (h, origin) = (self.step_ns(), self.oldest_ns());
        origin + (t_ns - origin).div_euclid(h) * h
    }

    /// Steps the physics until a state at or after `t_ns` is buffered.
    pub fn ensure(&mut self, t_ns: i64) {
        while self.states.back().is_some_and(|s| s.t_ns < t_ns) {
            let s = self.sim.step();
            self.states.push_back(s);
        }
    }

    /// Drops states older than `t_ns` (keeping the one at or before it).
    pub fn trim(&mut self, t_ns: i64) {
        while self.states.len() > 2 && self.states[1].t_ns <= t_ns {
            self.states.pop_front();
        }
    }

    /// The buffered state at exactly `t_ns` (a physics step time), stepping ahead as needed;
    /// `None` if already trimmed or not on the step grid.
    pub fn state_at(&mut self, t_ns: i64) -> Option<PhysicsState> {
        self.ensure(t_ns);
        let h = self.step_ns();
        let d = t_ns - self.oldest_ns();
        if d < 0 || d % h != 0 {
            return None;
        }
        self.states.get((d / h) as usize).copied()
    }

    fn centred(&self, j: usize, h: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let s0 = &self.states[j];
        let s1 = &self.states[j + 1];
        (
            (s0.v + s1.v) * 0.5,
            (s1.v - s0.v) / h,
            (s0.omega_w + s1.omega_w) * 0.5,
        )
    }

    /// Ground truth at any `t_ns` at or after the oldest buffered state (steps ahead as needed).
    pub fn kinematics(&mut self, t_ns: i64) -> Option<Kinematics> {
        let h_ns = self.step_ns();
        self.ensure(t_ns + 2 * h_ns);
        let d = t_ns - self.oldest_ns();
        if d < 0 {
            return None;
        }
        let j = (d / h_ns) as usize;
        let frac = (d % h_ns) as f64 / h_ns as f64;
        let h = h_ns as f64 * 1e-9;
        let s0 = self.states[j];
        let s1 = self.states[j + 1];
        let (v0, a0, w0) = self.centred(j, h);
        let (v1, a1, w1) = self.centred(j + 1, h);
        let p = s0.p + s1.v * (frac * h);
        let q = s0.q.slerp(&s1.q, frac);
        let lerp = |x: Vector3<f64>, y: Vector3<f64>| x + (y - x) * frac;
        Some(Kinematics {
            t_ns,
            pose: Pose::new(q, p),
            v_w: lerp(v0, v1),
            a_w: lerp(a0, a1),
            omega_b: q.inverse() * lerp(w0, w1),
        })
    }

    /// Iterates over buffered states from index `i` (for the IMU, which reads whole steps).
    pub fn states(&self) -> &VecDeque<PhysicsState> {
        &self.states
    }
}
