//! Recovery metrics of a fault (how long until the full sensor suite is back, the position error
//! when the fault ends and 10 s later) and the default expectations that keep a diverged run
//! from passing.

use crate::spec::Bound;

/// Seconds after a fault's end at which the second position error is taken.
pub const AFTER_S: f64 = 10.0;

/// A suite switch of the run: time and the live suites before and after.
#[derive(Clone, Debug, PartialEq)]
pub struct Switch {
    /// Time (s).
    pub t_s: f64,
    /// Live suite before.
    pub from: String,
    /// Live suite after.
    pub to: String,
}

/// Delay (s) from the end of the fault `[start_s, end_s)` to the return of the suite that was
/// live when it started, judged on the switches from its start to `AFTER_S` after its end:
/// `Some(0)` when the fault caused none, `None` when that suite did not come back (always for a
/// permanent fault, `end_s` infinite, that caused a switch). `switches` in time order.
pub fn back_after(switches: &[Switch], start_s: f64, end_s: f64) -> Option<f64> {
    let mut within = switches
        .iter()
        .filter(|s| s.t_s >= start_s && s.t_s <= end_s + AFTER_S);
    let Some(first) = within.next() else {
        return Some(0.0);
    };
    std::iter::once(first)
        .chain(within)
        .find(|s| s.to == first.from)
        .map(|s| (s.t_s - end_s).max(0.0))
}

/// The error of the first evaluated frame at or after `t_s` (within 1 s): `errors` are
/// `(time s, error m)` in time order.
pub fn error_at(errors: &[(f64, f64)], t_s: f64) -> Option<f64> {
    errors
        .iter()
        .find(|(t, _)| *t >= t_s && *t < t_s + 1.0)
        .map(|(_, e)| *e)
}

/// The default bound on the rotation ATE (deg), over eight times the largest bound a catalog
/// scenario states (1.2°).
pub const DEFAULT_ROTATION_DEG: f64 = 10.0;

/// The default bounds a scenario with the bounds `stated` gets on top of them: for each of these
/// metrics it sets no bound on, the ATE within `max(0.5 m, 2 % of the ground-truth path)`, the
/// rotation ATE within [`DEFAULT_ROTATION_DEG`] and tracking on at least half of the frames.
/// They catch divergence (metres of error, a turned-around attitude, a lost track), not
/// precision; a scenario states its own bounds for that. (A long path allows metres of
/// position error: an attitude that went 21° wrong on an 87 m Lissajous stayed under its 1.7 m.)
/// A scenario that expects no tracking (`tracking_fraction = { max = 0 }`: the estimator must
/// refuse to start) gets no ATE bounds: there is no trajectory. A static run
/// (`static_trajectory`: a ground truth that does not determine the alignment) has its position
/// drift from the first pose bounded instead of the ATE, and no rotation bound.
pub fn default_bounds(
    path_length_m: f64,
    stated: &[(&'static str, Bound)],
    static_run: bool,
) -> Vec<(&'static str, Bound)> {
    let expects_no_track = stated
        .iter()
        .any(|(m, b)| *m == "tracking_fraction" && b.max == Some(0.0));
    let ate = Bound {
        min: None,
        max: Some((0.02 * path_length_m).max(0.5)),
    };
    let tracking = Bound {
        min: Some(0.5),
        max: None,
    };
    let rotation = Bound {
        min: None,
        max: Some(DEFAULT_ROTATION_DEG),
    };
    let position = if static_run {
        "position_drift_m"
    } else {
        "ate_rmse_m"
    };
    let mut bounds = Vec::new();
    if !expects_no_track {
        bounds.push((position, ate));
        if !static_run {
            bounds.push(("ate_rot_rmse_deg", rotation));
        }
    }
    bounds.push(("tracking_fraction", tracking));
    bounds.retain(|(metric, _)| stated.iter().all(|(m, _)| m != metric));
    bounds
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovery_delay_follows_the_switches() {
        let s = |t, from: &str, to: &str| Switch {
            t_s: t,
            from: from.into(),
            to: to.into(),
        };
        let blackout = [
            s(20.46, "stereo_imu", "imu_only"),
            s(22.0, "imu_only", "stereo_imu"),
        ];
        assert_eq!(back_after(&blackout, 20.0, 22.0), Some(0.0));
        assert_eq!(back_after(&blackout, 20.0, 21.5), Some(0.5));
        // No switch at all: nothing to recover from.
        assert_eq!(back_after(&[], 20.0, 22.0), Some(0.0));
        // A dead camera never comes back.
        let death = [s(20.46, "stereo_imu", "mono_imu(cam1)")];
        assert_eq!(back_after(&death, 20.0, f64::INFINITY), None);
        assert_eq!(error_at(&[(1.0, 0.1), (2.0, 0.2)], 1.5), Some(0.2));
        assert_eq!(error_at(&[(1.0, 0.1)], 5.0), None);
    }

    #[test]
    fn default_bounds_cover_what_the_scenario_leaves_open() {
        let names =
            |b: Vec<(&'static str, Bound)>| b.into_iter().map(|(m, _)| m).collect::<Vec<_>>();
        let max = |v| Bound {
            min: None,
            max: Some(v),
        };
        let moving = default_bounds(100.0, &[], false);
        assert_eq!(
            names(moving.clone()),
            ["ate_rmse_m", "ate_rot_rmse_deg", "tracking_fraction"]
        );
        assert_eq!(moving[0].1.max, Some(2.0));
        assert_eq!(moving[1].1.max, Some(DEFAULT_ROTATION_DEG));
        assert_eq!(default_bounds(1.0, &[], false)[0].1.max, Some(0.5));
        // A stated bound is kept, not doubled.
        let stated = [("ate_rot_rmse_deg", max(0.5))];
        assert_eq!(
            names(default_bounds(100.0, &stated, false)),
            ["ate_rmse_m", "tracking_fraction"]
        );
        // At rest: the drift instead of the ATE, no rotation bound.
        assert_eq!(
            names(default_bounds(0.0, &[], true)),
            ["position_drift_m", "tracking_fraction"]
        );
        // Expected to refuse to start: no trajectory to bound.
        let refuse = [("tracking_fraction", max(0.0))];
        assert!(default_bounds(100.0, &refuse, false).is_empty());
    }
}
