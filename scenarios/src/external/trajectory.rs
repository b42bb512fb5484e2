//! What an outside estimator wrote, read and checked before it is scored: its trajectory (TUM,
//! body = IMU frame, IMU clock; missing, empty, malformed or non-finite is a failure), its
//! optional per-pose timing, and whether its poses are of the body frame at all.

use std::collections::BTreeMap;
use std::path::Path;

use estimator::geometry::Pose;
use nalgebra::Matrix3;

use super::stamped_rows::{nearest_stamp, read_stamped_rows};
use crate::dataset::{StampedPose, read_tum};

/// The trajectory at `path`, or why it cannot be scored (a failure of the estimator, in words).
pub fn read_trajectory(path: &Path) -> Result<Vec<StampedPose>, String> {
    if !path.exists() {
        return Err(format!(
            "wrote no trajectory: {} does not exist",
            path.display()
        ));
    }
    let poses = read_tum(path).map_err(|e| format!("wrote a malformed trajectory: {e}"))?;
    if poses.is_empty() {
        return Err(format!(
            "wrote an empty trajectory: {} holds no pose",
            path.display()
        ));
    }
    Ok(poses)
}

/// A timing row matches the pose nearest its stamp within this (s): an estimator may stamp its
/// poses at the frame time plus its own time-offset estimate.
const TIMING_MATCH_S: f64 = 0.05;

/// The per-pose processing times (s) of a timing file, by pose stamp (ns): rows `t seconds`
/// (see [`read_stamped_rows`] for the form). A row is the time of the pose nearest its stamp
/// within 50 ms; rows of frames without a pose (before the estimator initialized) match none
/// and are left out. Malformed rows are refused naming the line.
pub fn read_timing(path: &Path, poses: &[StampedPose]) -> Result<BTreeMap<i64, f64>, String> {
    let rows = read_stamped_rows(path, "its timing file", 1, "t seconds")?;
    let stamps: Vec<i64> = poses.iter().map(|p| p.t_ns).collect();
    let mut out = BTreeMap::new();
    for row in rows {
        let s = row.values[0];
        if s < 0.0 {
            return Err(format!(
                "its timing file {}:{}: `{s}` is not a time ≥ 0 s",
                path.display(),
                row.line
            ));
        }
        if let Some(k) = nearest_stamp(&stamps, row.t_ns, (TIMING_MATCH_S * 1e9) as i64) {
            out.entry(stamps[k]).or_insert(s);
        }
    }
    Ok(out)
}

/// Relative rotations over at least this long (s) test the frame.
const FRAME_CHECK_SPAN_S: f64 = 1.0;

/// A camera rotated less than this from the body (deg) cannot be told from it by rotations.
const FRAME_CHECK_MIN_ROTATION_DEG: f64 = 5.0;

/// The median angle (deg) between the estimate's relative rotations over
/// [`FRAME_CHECK_SPAN_S`] and the truth's, the estimate read as `R_est · R_x` (x = the frame it
/// may be of: identity for the body, `R_c_b` for camera c's poses).
fn median_relative_error_deg(
    est: &[(i64, Matrix3<f64>)],
    truth: &[Matrix3<f64>],
    r_x: &Matrix3<f64>,
) -> Option<f64> {
    let span_ns = (FRAME_CHECK_SPAN_S * 1e9) as i64;
    let mut errors: Vec<f64> = Vec::new();
    for i in 0..est.len() {
        let j = est.partition_point(|(t, _)| *t < est[i].0 + span_ns);
        if j >= est.len() {
            break;
        }
        let rel_est = (est[i].1 * r_x).transpose() * (est[j].1 * r_x);
        let rel_truth = truth[i].transpose() * truth[j];
        let d = rel_truth.transpose() * rel_est;
        let cos = ((d.trace() - 1.0) * 0.5).clamp(-1.0, 1.0);
        errors.push(cos.acos().to_degrees());
    }
    if errors.is_empty() {
        return None;
    }
    errors.sort_by(f64::total_cmp);
    Some(errors[errors.len() / 2])
}

/// Whether poses `est` (with the truth at their times) are of the body (IMU) frame: an error
/// naming the camera when they fit camera c's frame (`T_w_b · T_b_c`, `cameras[c]` = `T_b_c`)
/// clearly better — relative rotations over 1 s within a quarter of the body reading's error,
/// which is over 1°. Relative rotations do not depend on the estimate's world frame, so no
/// alignment is involved; a camera rotated less than 5° from the body is not tested.
pub fn frame_check(est: &[StampedPose], truth: &[Pose], cameras: &[Pose]) -> Result<(), String> {
    let rot: Vec<(i64, Matrix3<f64>)> = est
        .iter()
        .map(|p| (p.t_ns, p.pose.q.to_rotation_matrix().into_inner()))
        .collect();
    let truth: Vec<Matrix3<f64>> = truth
        .iter()
        .map(|p| p.q.to_rotation_matrix().into_inner())
        .collect();
    let Some(body) = median_relative_error_deg(&rot, &truth, &Matrix3::identity()) else {
        return Ok(());
    };
    for (c, t_b_c) in cameras.iter().enumerate() {
        if t_b_c.q.angle().to_degrees() < FRAME_CHECK_MIN_ROTATION_DEG {
            continue;
        }
        let r_c_b = t_b_c.q.to_rotation_matrix().into_inner().transpose();
        let Some(cam) = median_relative_error_deg(&rot, &truth, &r_c_b) else {
            continue;
        };
        if body > 1.0 && cam < 0.25 * body {
            return Err(format!(
                "wrote the poses of cam{c}, not of the body (IMU) frame the adapter contract asks for: its rotations over {FRAME_CHECK_SPAN_S} s err by a median {body:.2}° read as the body's and {cam:.2}° read as cam{c}'s (write T_w_b = T_w_c · T_c_b)"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use nalgebra::{UnitQuaternion, Vector3};

    use super::*;

    fn truth(n: usize) -> Vec<Pose> {
        (0..n)
            .map(|k| {
                let t = k as f64 * 0.05;
                Pose::new(
                    UnitQuaternion::from_euler_angles(
                        0.3 * t.sin(),
                        0.2 * (1.3 * t).cos(),
                        0.5 * t,
                    ),
                    Vector3::new(t.cos(), t.sin(), 0.1 * t),
                )
            })
            .collect()
    }

    fn stamped(poses: &[Pose]) -> Vec<StampedPose> {
        poses
            .iter()
            .enumerate()
            .map(|(k, p)| StampedPose::new(k as i64 * 50_000_000, *p))
            .collect()
    }

    #[test]
    fn camera_poses_are_told_from_body_poses() {
        let gt = truth(200);
        let t_b_c = Pose::new(
            UnitQuaternion::from_euler_angles(
                -std::f64::consts::FRAC_PI_2,
                0.0,
                -std::f64::consts::FRAC_PI_2,
            ),
            Vector3::new(0.05, 0.0, 0.0),
        );
        // The body's poses in another world frame pass.
        let world = Pose::new(
            UnitQuaternion::from_euler_angles(0.1, -0.4, 2.0),
            Vector3::new(3.0, 1.0, 0.0),
        );
        let body: Vec<Pose> = gt.iter().map(|p| world.compose(p)).collect();
        frame_check(&stamped(&body), &gt, &[t_b_c]).unwrap();
        let cam: Vec<Pose> = body.iter().map(|p| p.compose(&t_b_c)).collect();
        let e = frame_check(&stamped(&cam), &gt, &[Pose::identity(), t_b_c]).unwrap_err();
        assert!(e.contains("poses of cam1"), "{e}");
    }
}
