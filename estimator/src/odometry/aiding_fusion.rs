//! GNSS position fixes and wheel odometry in the sliding window: they are factors over the same
//! frame states as the camera and IMU factors ([`GnssPositionFactor`], [`BodyVelocityFactor`]),
//! not a separate pose graph.
//!
//! - **Association.** Measurements are buffered in the window ([`Aiding`]) and attached to frames
//!   when the window problem is built: a GNSS fix to the window frame nearest in time (within
//!   `GnssConfig::max_dt_s`, its position carried along the frame's velocity, its σ widened by
//!   what that carry may miss), a frame to the
//!   wheel speed interpolated at its time between the two readings around it. A frame that
//!   leaves the window as a non-keyframe takes no measurement with it (they re-attach to the
//!   frames that stay, or are not used); one that is marginalized takes its factors into the
//!   prior, and its measurements leave the buffer.
//! - **The GNSS frame.** The receiver's frame `g` and the odometry's world frame `w` are both
//!   gravity-aligned, so they differ by a yaw and a translation: the 4-dof alignment
//!   `T_g_w = [t, ψ]`, a state of the window (never marginalized; carried through the prior like
//!   the extrinsics). It is initialized in closed form once the fixes, paired with the causal
//!   estimates at their times, span `align_min_spread_m` horizontally; that solution enters as a
//!   prior on the alignment with its own covariance, so the switch moves no state: the odometry
//!   keeps its world frame, and from then on the fixes pull the window through the alignment.
//!   Before it, fixes are only collected.
//! - **Vision-only suites** use neither sensor (the factors need the frames' velocities).

use std::collections::VecDeque;
use std::sync::Arc;

use nalgebra::Vector3;

use super::config::{EstimatorConfig, GnssConfig};
use super::frame::{BlockRef, WindowFrame};
use super::window_problem::WindowProblem;
use crate::aiding_samples::{GnssSample, WheelSample};
use crate::factors::{ALIGNMENT_SIZE, BodyVelocityFactor, GnssPositionFactor, yaw_rotation};
use crate::geometry::position_yaw;
use crate::problem::{Euclidean, Factor, HuberLoss, LossFunction, PriorFactor};

/// The 4-dof transform `T_g_w` from the odometry's world frame to the GNSS receiver's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssAlignment {
    /// Translation (m).
    pub t: Vector3<f64>,
    /// Yaw (rad).
    pub yaw: f64,
}

impl GnssAlignment {
    /// A world point in the receiver's frame.
    pub fn to_gnss(&self, p_w: &Vector3<f64>) -> Vector3<f64> {
        yaw_rotation(self.yaw).0 * p_w + self.t
    }

    fn to_array(self) -> [f64; ALIGNMENT_SIZE] {
        [self.t.x, self.t.y, self.t.z, self.yaw]
    }

    fn from_slice(v: &[f64]) -> Self {
        Self {
            t: Vector3::new(v[0], v[1], v[2]),
            yaw: v[3],
        }
    }
}

/// A fix paired with the causal estimate of the antenna at its time (alignment input).
#[derive(Clone, Copy, Debug)]
struct FixPair {
    antenna_w: Vector3<f64>,
    fix: GnssSample,
}

/// The aiding sensors' part of the window: buffered measurements, the alignment and what its
/// initialization collects.
#[derive(Clone, Debug, Default)]
pub(super) struct Aiding {
    /// GNSS fixes not yet marginalized, in time order, with the gate's verdict (`None`: not
    /// screened yet).
    gnss: VecDeque<(GnssSample, Option<bool>)>,
    /// Fixes rejected by the gate in a row.
    rejected_streak: usize,
    /// Wheel readings from just before the oldest window frame on, in time order.
    wheel: VecDeque<WheelSample>,
    /// The alignment state and the prior of its initialization.
    alignment: Option<(GnssAlignment, Arc<PriorFactor>)>,
    /// Fix/estimate pairs for the initialization (until it succeeds).
    pairs: VecDeque<FixPair>,
    /// Fixes up to this time have been paired.
    paired_until_ns: i64,
    /// Newest sample times (order checks).
    last_gnss_ns: Option<i64>,
    last_wheel_ns: Option<i64>,
}

impl Aiding {
    /// Buffers a fix (refused when invalid or out of order).
    pub fn push_gnss(&mut self, s: GnssSample) -> Result<(), crate::aiding_samples::AidingError> {
        s.validate()?;
        check_order("gnss", &mut self.last_gnss_ns, s.t_ns)?;
        self.gnss.push_back((s, None));
        Ok(())
    }

    /// Buffers a wheel reading (refused when invalid or out of order).
    pub fn push_wheel(&mut self, s: WheelSample) -> Result<(), crate::aiding_samples::AidingError> {
        s.validate()?;
        check_order("wheel", &mut self.last_wheel_ns, s.t_ns)?;
        self.wheel.push_back(s);
        Ok(())
    }

    /// The current alignment, once initialized.
    pub fn alignment(&self) -> Option<GnssAlignment> {
        self.alignment.as_ref().map(|(a, _)| *a)
    }

    /// The wheel speed at `t_ns`, interpolated between readings at most `max_gap_s` apart.
    pub fn wheel_speed(&self, t_ns: i64, max_gap_s: f64) -> Option<f64> {
        wheel_speed_at(&self.wheel, t_ns, max_gap_s)
    }
}

fn check_order(
    sensor: &'static str,
    last: &mut Option<i64>,
    t_ns: i64,
) -> Result<(), crate::aiding_samples::AidingError> {
    if let Some(prev) = *last
        && t_ns <= prev
    {
        return Err(crate::aiding_samples::AidingError::NonIncreasing {
            sensor,
            t_ns,
            prev_t_ns: prev,
        });
    }
    *last = Some(t_ns);
    Ok(())
}

/// The window frame nearest to `t_ns` within `max_dt_s`: (index, fix time − frame time in s).
fn nearest_frame(frames: &VecDeque<WindowFrame>, t_ns: i64, max_dt_s: f64) -> Option<(usize, f64)> {
    let i = frames.partition_point(|f| f.t_ns < t_ns);
    [i.checked_sub(1), (i < frames.len()).then_some(i)]
        .into_iter()
        .flatten()
        .map(|k| (k, (t_ns - frames[k].t_ns) as f64 * 1e-9))
        .filter(|(_, dt)| dt.abs() <= max_dt_s)
        .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
}

/// The wheel speed at `t_ns`, interpolated between the readings around it (at most `max_gap_s`
/// apart).
fn wheel_speed_at(wheel: &VecDeque<WheelSample>, t_ns: i64, max_gap_s: f64) -> Option<f64> {
    let i = wheel.partition_point(|s| s.t_ns < t_ns);
    let b = wheel.get(i)?;
    if b.t_ns == t_ns {
        return Some(b.speed_m_s);
    }
    let a = wheel.get(i.checked_sub(1)?)?;
    let gap = (b.t_ns - a.t_ns) as f64;
    if gap * 1e-9 > max_gap_s {
        return None;
    }
    let f = (t_ns - a.t_ns) as f64 / gap;
    Some(a.speed_m_s + f * (b.speed_m_s - a.speed_m_s))
}

impl Aiding {
    /// Adds the alignment block (once initialized) with its initialization prior; called by
    /// `build` before the marginalization prior, which may refer to the block.
    pub(super) fn add_alignment_block(&self, built: &mut WindowProblem) {
        let Some((a, prior)) = &self.alignment else {
            return;
        };
        let b = built
            .problem
            .add_block(
                &a.to_array(),
                Arc::new(Euclidean::new(ALIGNMENT_SIZE)),
                crate::problem::BlockKind::State,
            )
            .expect("finite alignment");
        built.refs.push((BlockRef::GnssAlignment, b));
        let f: Arc<dyn Factor> = prior.clone();
        built
            .problem
            .add_factor(f, None, &[b])
            .expect("sizes match");
    }

    /// The GNSS and wheel factors of the window frames (IMU suites; see the module docs).
    pub(super) fn add_factors(
        &self,
        frames: &VecDeque<WindowFrame>,
        built: &mut WindowProblem,
        config: &EstimatorConfig,
    ) {
        let wc = &config.wheel;
        let wheel_loss: Arc<dyn LossFunction> = Arc::new(HuberLoss {
            delta: wc.huber_sigmas,
        });
        for f in frames {
            let Some(speed) = wheel_speed_at(&self.wheel, f.t_ns, wc.max_gap_s) else {
                continue;
            };
            let (Some(pose), Some(sb)) = (
                built.block(BlockRef::Pose(f.seq)),
                built.block(BlockRef::SpeedBias(f.seq)),
            ) else {
                continue;
            };
            let factor = BodyVelocityFactor {
                speed_m_s: speed,
                speed_sigma: wc.speed_sigma_m_s,
                lateral_sigma: wc.lateral_sigma_m_s,
            };
            let mut r = [0.0; 3];
            let sb_values = built.problem.values(sb);
            let ok = factor.evaluate(&[built.problem.values(pose), sb_values], &mut r, None);
            if !ok || Vector3::from(r).norm() > wc.gate_sigmas {
                continue;
            }
            let r = built
                .problem
                .add_factor(Arc::new(factor), Some(wheel_loss.clone()), &[pose, sb])
                .expect("sizes match");
            built.frame_factors.push((r, f.seq));
        }
        let Some(align) = built.block(BlockRef::GnssAlignment) else {
            return;
        };
        let gc = &config.gnss;
        let gnss_loss: Arc<dyn LossFunction> = Arc::new(HuberLoss {
            delta: gc.huber_sigmas,
        });
        for (fix, accepted) in &self.gnss {
            if *accepted != Some(true) {
                continue;
            }
            let Some((k, dt)) = nearest_frame(frames, fix.t_ns, gc.max_dt_s) else {
                continue;
            };
            let seq = frames[k].seq;
            let (Some(pose), Some(sb)) = (
                built.block(BlockRef::Pose(seq)),
                built.block(BlockRef::SpeedBias(seq)),
            ) else {
                continue;
            };
            let factor = gnss_factor(fix, gc, dt);
            let r = built
                .problem
                .add_factor(
                    Arc::new(factor),
                    Some(gnss_loss.clone()),
                    &[pose, sb, align],
                )
                .expect("sizes match");
            built.frame_factors.push((r, seq));
        }
    }

    /// Copies the solved alignment back.
    pub(super) fn write_back_alignment(&mut self, built: &WindowProblem) {
        if let (Some(b), Some((a, _))) = (
            built.block(BlockRef::GnssAlignment),
            self.alignment.as_mut(),
        ) {
            *a = GnssAlignment::from_slice(built.problem.values(b));
        }
    }

    /// After the oldest frame (`removed`) left: its fixes (those nearer to it than to the new
    /// oldest frame) went into the prior or were never used, and wheel readings before the new
    /// oldest frame's bracket are no longer needed.
    pub(super) fn trim(&mut self, frames: &VecDeque<WindowFrame>, removed: &WindowFrame) {
        let Some(oldest) = frames.front() else {
            return;
        };
        let mid = removed.t_ns + (oldest.t_ns - removed.t_ns) / 2;
        while self.gnss.front().is_some_and(|(s, _)| s.t_ns <= mid) {
            self.gnss.pop_front();
        }
        while self.wheel.get(1).is_some_and(|s| s.t_ns <= oldest.t_ns) {
            self.wheel.pop_front();
        }
    }

    /// Before a solve, with the alignment: the gate's verdict on the fixes not yet screened,
    /// from their whitened error against the window's current (predicted) states. Returns
    /// `true` when `realign_after_rejections` fixes in a row were rejected.
    pub(super) fn screen_fixes(
        &mut self,
        frames: &VecDeque<WindowFrame>,
        config: &EstimatorConfig,
    ) -> bool {
        let gc = &config.gnss;
        let Some((alignment, _)) = &self.alignment else {
            return false;
        };
        let align = alignment.to_array();
        for (fix, verdict) in self.gnss.iter_mut().filter(|(_, v)| v.is_none()) {
            let Some((k, dt)) = nearest_frame(frames, fix.t_ns, gc.max_dt_s) else {
                continue;
            };
            let f = &frames[k];
            let sb = [f.v.x, f.v.y, f.v.z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
            let mut r = [0.0; 3];
            let ok =
                gnss_factor(fix, gc, dt).evaluate(&[&f.pose.to_array(), &sb, &align], &mut r, None);
            let accepted = ok && Vector3::from(r).norm() <= gc.gate_sigmas;
            *verdict = Some(accepted);
            if accepted {
                self.rejected_streak = 0;
            } else {
                self.rejected_streak += 1;
            }
        }
        self.rejected_streak >= gc.realign_after_rejections
    }

    /// Forgets the alignment (its information about the window's states stays in the prior,
    /// which the caller has already rid of the alignment block) and starts collecting fixes for
    /// a new one from now on.
    pub(super) fn forget_alignment(&mut self) {
        self.alignment = None;
        self.rejected_streak = 0;
        self.pairs.clear();
        if let Some(last) = self.gnss.back() {
            self.paired_until_ns = last.0.t_ns;
        }
    }

    /// After a solve, before the alignment exists: pairs the fixes whose frame is settled (all
    /// but the newest frame's) with the estimated antenna positions, and initializes the
    /// alignment once they span enough ground. Returns whether it was initialized now.
    pub(super) fn collect_for_alignment(
        &mut self,
        frames: &VecDeque<WindowFrame>,
        config: &EstimatorConfig,
    ) -> bool {
        let gc = config.gnss;
        if self.alignment.is_some() || frames.len() < 2 {
            return false;
        }
        let n = frames.len();
        // Fixes nearer to the second-newest frame than to the newest are settled.
        let settled_until = frames[n - 2].t_ns + (frames[n - 1].t_ns - frames[n - 2].t_ns) / 2;
        let lever = Vector3::from(gc.lever_arm_m);
        let from = self.paired_until_ns;
        let new: Vec<FixPair> = self
            .gnss
            .iter()
            .map(|(s, _)| s)
            .filter(|s| s.t_ns > from && s.t_ns <= settled_until)
            .filter_map(|fix| {
                let (k, dt) = nearest_frame(frames, fix.t_ns, gc.max_dt_s)?;
                let f = &frames[k];
                Some(FixPair {
                    antenna_w: f.pose.p + f.pose.q * lever + f.v * dt,
                    fix: *fix,
                })
            })
            .collect();
        self.paired_until_ns = self.paired_until_ns.max(settled_until);
        self.pairs.extend(new);
        while self.pairs.len() > gc.align_max_fixes {
            self.pairs.pop_front();
        }
        let Some(alignment) = align_4dof(&self.pairs, &gc) else {
            return false;
        };
        self.alignment = Some(alignment);
        self.pairs.clear();
        true
    }
}

/// The factor of `fix`, `dt_s` after its frame: the fix's σ with the carry's error added.
fn gnss_factor(fix: &GnssSample, gc: &GnssConfig, dt_s: f64) -> GnssPositionFactor {
    let carry = 0.5 * gc.carry_accel_m_s2 * dt_s * dt_s;
    GnssPositionFactor {
        z: fix.p_g,
        weight: fix.sigma_m.map(|s| 1.0 / (s * s + carry * carry).sqrt()),
        lever_arm_b: Vector3::from(gc.lever_arm_m),
        dt_s,
    }
}

/// The closed-form 4-dof alignment of the collected pairs ([`position_yaw`], every fix
/// weighted alike) with its prior, or `None` while they are too few or too close together.
fn align_4dof(
    pairs: &VecDeque<FixPair>,
    gc: &GnssConfig,
) -> Option<(GnssAlignment, Arc<PriorFactor>)> {
    let n = pairs.len();
    if n < gc.align_min_fixes {
        return None;
    }
    let nf = n as f64;
    let antenna: Vec<Vector3<f64>> = pairs.iter().map(|p| p.antenna_w).collect();
    let fixes: Vec<Vector3<f64>> = pairs.iter().map(|p| p.fix.p_g).collect();
    let py = position_yaw(&antenna, &fixes)?;
    let spread = (py.src_spread2 / nf).sqrt();
    if spread < gc.align_min_spread_m {
        return None;
    }
    let yaw = py.yaw;
    let t = py.mean_dst - yaw_rotation(yaw).0 * py.mean_src;
    // Least-squares accuracy: the mean fix noise over √N for the translation, the horizontal
    // noise over the spread for the yaw; inflated for the odometry's drift meanwhile.
    let sigma: Vector3<f64> = pairs.iter().map(|p| p.fix.sigma_m).sum::<Vector3<f64>>() / nf;
    let k = gc.align_sigma_inflation;
    let sigma_t = sigma * k / nf.sqrt();
    let sigma_yaw = k * 0.5 * (sigma.x + sigma.y) / (spread * nf.sqrt());
    let alignment = GnssAlignment { t, yaw };
    let mut jac = vec![0.0; ALIGNMENT_SIZE * ALIGNMENT_SIZE];
    for i in 0..3 {
        jac[i * ALIGNMENT_SIZE + i] = 1.0 / sigma_t[i];
    }
    jac[ALIGNMENT_SIZE * ALIGNMENT_SIZE - 1] = 1.0 / sigma_yaw;
    let prior = PriorFactor::new(
        vec![Arc::new(Euclidean::new(ALIGNMENT_SIZE))],
        vec![alignment.to_array().to_vec()],
        jac,
        vec![0.0; ALIGNMENT_SIZE],
    )
    .ok()?;
    Some((alignment, Arc::new(prior)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose;

    fn frame(seq: u64, t_ns: i64) -> WindowFrame {
        WindowFrame {
            seq,
            t_ns,
            pose: Pose::identity(),
            v: Vector3::zeros(),
            ba: Vector3::zeros(),
            bg: Vector3::zeros(),
            preint: None,
        }
    }

    #[test]
    fn a_fix_attaches_to_the_nearest_frame_within_reach() {
        let frames: VecDeque<WindowFrame> =
            (0..3).map(|k| frame(k, k as i64 * 50_000_000)).collect();
        assert_eq!(
            nearest_frame(&frames, 60_000_000, 0.03).map(|x| x.0),
            Some(1)
        );
        let (k, dt) = nearest_frame(&frames, 80_000_000, 0.03).unwrap();
        assert_eq!(k, 2);
        assert!((dt + 0.02).abs() < 1e-12);
        assert!(nearest_frame(&frames, 200_000_000, 0.03).is_none());
    }

    #[test]
    fn a_fix_carried_to_its_frame_loses_weight_by_what_the_carry_may_miss() {
        let fix = GnssSample {
            t_ns: 0,
            p_g: Vector3::zeros(),
            sigma_m: Vector3::new(0.02, 0.02, 0.05),
        };
        let gc = GnssConfig::default();
        assert_eq!(
            gnss_factor(&fix, &gc, 0.0).weight,
            Vector3::new(50.0, 50.0, 20.0)
        );
        // 100 ms at 2 m/s²: ½·a·dt² = 1 cm in quadrature with 2 cm.
        let w = gnss_factor(&fix, &gc, -0.1).weight;
        assert!((w.x - 1.0 / (0.02f64.powi(2) + 0.01f64.powi(2)).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn wheel_speed_is_interpolated_between_close_readings() {
        let w: VecDeque<WheelSample> = [(0, 1.0), (20_000_000, 2.0), (300_000_000, 3.0)]
            .into_iter()
            .map(|(t_ns, speed_m_s)| WheelSample { t_ns, speed_m_s })
            .collect();
        assert_eq!(wheel_speed_at(&w, 5_000_000, 0.1), Some(1.25));
        assert_eq!(wheel_speed_at(&w, 20_000_000, 0.1), Some(2.0));
        // The gap to the next reading is too long, or nothing follows.
        assert_eq!(wheel_speed_at(&w, 100_000_000, 0.1), None);
        assert_eq!(wheel_speed_at(&w, 400_000_000, 0.1), None);
    }

    #[test]
    fn the_closed_form_alignment_recovers_yaw_and_translation() {
        let truth = GnssAlignment {
            t: Vector3::new(12.0, -4.0, 0.7),
            yaw: 2.5,
        };
        let mut seed = 7u64;
        let pairs: VecDeque<FixPair> = (0..60)
            .map(|k| {
                let s = k as f64 * 0.2;
                let a = Vector3::new(10.0 * s.cos(), 6.0 * (2.0 * s).sin(), 0.1 * s);
                let noise = Vector3::from_fn(|_, _| crate::problem::test_lcg(&mut seed) * 0.1);
                FixPair {
                    antenna_w: a,
                    fix: GnssSample {
                        t_ns: k,
                        p_g: truth.to_gnss(&a) + noise,
                        sigma_m: Vector3::repeat(0.1),
                    },
                }
            })
            .collect();
        let (a, _) = align_4dof(&pairs, &GnssConfig::default()).expect("enough spread");
        assert!((a.yaw - truth.yaw).abs() < 0.01, "yaw {}", a.yaw);
        assert!((a.t - truth.t).norm() < 0.1, "t {:?}", a.t);
        // Too little spread: refused.
        let close: VecDeque<FixPair> = pairs
            .iter()
            .map(|p| FixPair {
                antenna_w: p.antenna_w * 0.1,
                fix: p.fix,
            })
            .collect();
        assert!(align_4dof(&close, &GnssConfig::default()).is_none());
    }
}
