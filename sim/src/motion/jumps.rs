//! Jumps in a recorded trajectory: a motion-capture system that loses a body and finds it
//! again a few centimetres off (a marker swapped, a reflection taken for a marker) makes the
//! recorded position step between two samples — further than the motion can move in that
//! time — and, usually, step back a little later. The glitch check does not see it: every
//! sample of the excursion agrees with its neighbours.
//!
//! Between samples `i` and `i + 1` the step is compared with what the velocities on both sides
//! predict; a residual beyond the allowance (ten times the recording's median residual, or three
//! times what its 99th-percentile acceleration can do over the three intervals involved, never
//! under 2 mm / 0.5°) that is also the largest of its neighbours is a jump. A jump followed
//! within [`MAX_EXCURSION_S`] by one that undoes it (their sum under a third of the larger, or
//! within the noise floor) bounds an excursion: the samples between are the glitch, dropped by
//! `repair` like single glitches (the hole left is bridged like a gap). A jump nothing undoes is a step: which side
//! is true cannot be told from the recording, and it is reported as such.

use nalgebra::Vector3;

use super::sample_statistics::median;
use super::spline::PoseSample;

/// Longest excursion (s) from a jump to the jump back.
pub const MAX_EXCURSION_S: f64 = 2.0;
/// Smallest position residual (m) counted as a jump.
const FLOOR_M: f64 = 2e-3;
/// Smallest attitude residual (rad) counted as a jump (0.5°).
const FLOOR_RAD: f64 = 0.5 * std::f64::consts::PI / 180.0;

/// A jump between samples `index` and `index + 1`: its residual step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jump {
    /// The sample before the jump.
    pub index: usize,
    /// Position residual (m).
    pub position: Vector3<f64>,
    /// Attitude residual (rad, rotation vector).
    pub attitude: Vector3<f64>,
}

impl Jump {
    /// Its size: (m, rad).
    pub fn size(&self) -> (f64, f64) {
        (self.position.norm(), self.attitude.norm())
    }
}

/// What [`find_jumps`] found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Jumps {
    /// Excursions: the indices of their first and last samples, and the jump into them.
    pub excursions: Vec<(usize, usize, Jump)>,
    /// Jumps that nothing undoes.
    pub steps: Vec<Jump>,
}

/// Residual of the step from `i` to `i + 1` against the velocities on both sides.
fn residual(s: &[PoseSample], i: usize) -> (Vector3<f64>, Vector3<f64>) {
    let dt = s[i + 1].t - s[i].t;
    let (db, da) = (s[i].t - s[i - 1].t, s[i + 2].t - s[i + 1].t);
    let v = 0.5 * ((s[i].p - s[i - 1].p) / db + (s[i + 2].p - s[i + 1].p) / da);
    let w = 0.5
        * ((s[i - 1].q.inverse() * s[i].q).scaled_axis() / db
            + (s[i + 1].q.inverse() * s[i + 2].q).scaled_axis() / da);
    let step_p = s[i + 1].p - s[i].p;
    let step_q = (s[i].q.inverse() * s[i + 1].q).scaled_axis();
    (step_p - v * dt, step_q - w * dt)
}

/// The jumps of `s` (see the module's documentation); `accel` is the recording's
/// 99th-percentile (linear, angular) acceleration.
pub fn find_jumps(s: &[PoseSample], accel: (f64, f64)) -> Jumps {
    let n = s.len();
    if n < 4 {
        return Jumps::default();
    }
    let residuals: Vec<(Vector3<f64>, Vector3<f64>)> = (1..n - 2).map(|i| residual(s, i)).collect();
    let at = |i: usize| residuals[i - 1];
    let floor_p = FLOOR_M.max(10.0 * median(residuals.iter().map(|r| r.0.norm()).collect()));
    let floor_q = FLOOR_RAD.max(10.0 * median(residuals.iter().map(|r| r.1.norm()).collect()));
    let score = |i: usize| {
        let span = s[i + 2].t - s[i - 1].t;
        let bound = 1.5 * span * span;
        let (p, q) = at(i);
        (p.norm() / floor_p.max(accel.0 * bound)).max(q.norm() / floor_q.max(accel.1 * bound))
    };
    let scores: Vec<f64> = (1..n - 2).map(score).collect();
    let mut jumps = Vec::new();
    for i in 1..n - 2 {
        let k = i - 1;
        let x = scores[k];
        let left = if k > 0 { scores[k - 1] } else { 0.0 };
        let right = scores.get(k + 1).copied().unwrap_or(0.0);
        if x > 1.0 && x >= left && x > right {
            let (position, attitude) = at(i);
            jumps.push(Jump {
                index: i,
                position,
                attitude,
            });
        }
    }
    let mut out = Jumps::default();
    let mut used = vec![false; jumps.len()];
    for a in 0..jumps.len() {
        if used[a] {
            continue;
        }
        let ja = jumps[a];
        let back = (a + 1..jumps.len()).find(|&b| {
            let jb = jumps[b];
            // Each part undone to a third of the larger jump, or to the noise floor.
            let undone = |x: Vector3<f64>, y: Vector3<f64>, floor: f64| {
                (x + y).norm() <= (x.norm().max(y.norm()) / 3.0).max(floor)
            };
            !used[b]
                && s[jb.index].t - s[ja.index + 1].t <= MAX_EXCURSION_S
                && undone(ja.position, jb.position, floor_p)
                && undone(ja.attitude, jb.attitude, floor_q)
        });
        match back {
            Some(b) => {
                used[a] = true;
                used[b] = true;
                out.excursions.push((ja.index + 1, jumps[b].index, ja));
            }
            None => out.steps.push(ja),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// A smooth circle at 100 Hz with `offset(i)` added to sample `i`'s position.
    fn circle(offset: impl Fn(usize) -> f64) -> Vec<PoseSample> {
        (0..1000)
            .map(|i| {
                let t = i as f64 * 0.01;
                PoseSample {
                    t,
                    p: Vector3::new(t.cos() + offset(i), t.sin(), 1.0),
                    q: UnitQuaternion::from_euler_angles(0.0, 0.0, t),
                }
            })
            .collect()
    }

    #[test]
    fn an_excursion_is_bounded_by_its_jumps_and_a_step_is_a_step() {
        let accel = (1.0, 1.0);
        assert_eq!(find_jumps(&circle(|_| 0.0), accel), Jumps::default());
        let j = find_jumps(
            &circle(|i| if (400..406).contains(&i) { 0.08 } else { 0.0 }),
            accel,
        );
        assert!(j.steps.is_empty(), "{j:?}");
        assert_eq!(j.excursions.len(), 1);
        let (first, last, jump) = j.excursions[0];
        assert_eq!((first, last), (400, 405));
        assert!((jump.size().0 - 0.08).abs() < 0.005, "{jump:?}");
        let j = find_jumps(&circle(|i| if i >= 400 { 0.08 } else { 0.0 }), accel);
        assert!(j.excursions.is_empty());
        assert_eq!(j.steps.len(), 1);
        assert_eq!(j.steps[0].index, 399);
    }
}
