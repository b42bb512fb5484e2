//! An outside estimator's newest state with its covariance, for `vio nees`: the adapter's
//! `covariance` file, one row per pose,
//!
//! `t  vx vy vz  bax bay baz  bgx bgy bgz  P₁,₁ P₁,₂ … P₁₅,₁₅`
//!
//! (235 columns: the stamp as the trajectory's, the world-frame velocity, the accelerometer and
//! gyroscope biases, then the 15×15 covariance row by row) over the error state
//! `[δp (world), δθ (body, right perturbation: R = R̂·Exp(δθ)), δv (world), δba, δbg]` — our
//! estimator's order and convention. Each row is matched to the trajectory's pose of the same
//! stamp (within 1 ms); rows of no pose are left out. A covariance that is not symmetric (to
//! 1e-6 of its diagonal) or not positive definite is refused naming the line.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::{DMatrix, Vector3};

use super::stamped_rows::{nearest_stamp, read_stamped_rows};
use crate::dataset::StampedPose;

/// The error state's dimension.
const STATE: usize = 15;

/// A row is the state of the pose within this of its stamp (ns).
const MATCH_NS: i64 = 1_000_000;

/// The state an outside estimator reports beside a pose.
#[derive(Clone, Debug, PartialEq)]
pub struct OutsideState {
    /// World-frame velocity (m/s).
    pub v_w: Vector3<f64>,
    /// Accelerometer bias (m/s²).
    pub ba: Vector3<f64>,
    /// Gyroscope bias (rad/s).
    pub bg: Vector3<f64>,
    /// 15×15 over `[δp, δθ, δv, δba, δbg]`.
    pub covariance: DMatrix<f64>,
}

/// The states of `path` by pose stamp (ns), or why they cannot be used (a failure of the
/// estimator, in words).
pub fn read_state_covariance(
    path: &Path,
    poses: &[StampedPose],
) -> Result<BTreeMap<i64, OutsideState>, String> {
    if !path.exists() {
        return Err(format!(
            "wrote no covariance file: {} does not exist",
            path.display()
        ));
    }
    let what = "its covariance file";
    let rows = read_stamped_rows(
        path,
        what,
        9 + STATE * STATE,
        "t vx vy vz bax bay baz bgx bgy bgz and the 15×15 covariance row by row",
    )?;
    let stamps: Vec<i64> = poses.iter().map(|p| p.t_ns).collect();
    let mut out = BTreeMap::new();
    for row in rows {
        let bad = |m: String| format!("{what} {}:{}: {m}", path.display(), row.line);
        let v = &row.values;
        let covariance = DMatrix::from_row_slice(STATE, STATE, &v[9..]);
        let scale = covariance.diagonal().abs().max();
        let asymmetry = (&covariance - covariance.transpose()).abs().max();
        if asymmetry > 1e-6 * scale {
            return Err(bad(format!(
                "the covariance is not symmetric (entries differ by {asymmetry:.3e} against a largest diagonal of {scale:.3e})"
            )));
        }
        if covariance.clone().cholesky().is_none() {
            return Err(bad("the covariance is not positive definite".into()));
        }
        let Some(k) = nearest_stamp(&stamps, row.t_ns, MATCH_NS) else {
            continue;
        };
        out.entry(stamps[k]).or_insert(OutsideState {
            v_w: Vector3::new(v[0], v[1], v[2]),
            ba: Vector3::new(v[3], v[4], v[5]),
            bg: Vector3::new(v[6], v[7], v[8]),
            covariance,
        });
    }
    if out.is_empty() {
        return Err(format!(
            "{what} {} has no row at a pose's stamp (within {} ms)",
            path.display(),
            MATCH_NS / 1_000_000
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use estimator::geometry::Pose;

    use super::*;

    fn row(t: &str, covariance: &DMatrix<f64>) -> String {
        let mut fields = vec![t.to_string()];
        fields.extend((0..9).map(|k| format!("{k}")));
        fields.extend(covariance.transpose().iter().map(|c| format!("{c:e}")));
        fields.join(" ")
    }

    #[test]
    fn states_are_matched_to_poses_and_bad_covariances_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cov.txt");
        let poses: Vec<_> = (0..3)
            .map(|k| StampedPose::new(k * 50_000_000, Pose::identity()))
            .collect();
        let p = DMatrix::<f64>::identity(STATE, STATE) * 1e-4;
        let text = format!(
            "# t v ba bg P\n{}\n{}\n{}\n",
            row("0.0", &p),
            row("0.0500004", &p),
            row("7.0", &p)
        );
        std::fs::write(&path, text).unwrap();
        let states = read_state_covariance(&path, &poses).unwrap();
        assert_eq!(states.keys().copied().collect::<Vec<_>>(), [0, 50_000_000]);
        assert_eq!(states[&0].bg, Vector3::new(6.0, 7.0, 8.0));
        let mut asymmetric = p.clone();
        asymmetric[(0, 1)] = 1e-5;
        std::fs::write(&path, row("0.0", &asymmetric)).unwrap();
        let e = read_state_covariance(&path, &poses).unwrap_err();
        assert!(e.contains(":1: the covariance is not symmetric"), "{e}");
        let mut indefinite = p.clone();
        indefinite[(4, 4)] = -1e-4;
        std::fs::write(&path, format!("\n{}", row("0.0", &indefinite))).unwrap();
        let e = read_state_covariance(&path, &poses).unwrap_err();
        assert!(
            e.contains(":2: the covariance is not positive definite"),
            "{e}"
        );
        std::fs::write(&path, "0.0 1 2 3\n").unwrap();
        let e = read_state_covariance(&path, &poses).unwrap_err();
        assert!(e.contains("expected 235 columns"), "{e}");
        std::fs::write(&path, row("9.0", &p)).unwrap();
        let e = read_state_covariance(&path, &poses).unwrap_err();
        assert!(e.contains("no row at a pose's stamp"), "{e}");
    }
}
