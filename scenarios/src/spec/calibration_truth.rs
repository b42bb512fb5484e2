//! The true calibration of a scenario's rig (time offset, its steps, each camera's `T_b_c`)
//! that a run's calibration estimates are judged against.

use estimator::geometry::Pose;

/// The true calibration a run is judged against.
#[allow(non_snake_case)]
#[derive(Clone, Debug, PartialEq)]
pub struct CalibrationTruth {
    /// The rig's camera-IMU time offset (s): a frame stamped `t` was taken at `t + td_s`.
    pub td_s: f64,
    /// The `camera_time_offset` faults: from this time (ns) on, frames are stamped this much
    /// (s) earlier on top.
    pub td_steps: Vec<(i64, f64)>,
    /// Each used camera's true `T_b_c`.
    pub T_b_c: Vec<Pose>,
}

impl CalibrationTruth {
    /// The true time offset (s) of a frame taken at `t_ns`.
    pub fn td_at(&self, t_ns: i64) -> f64 {
        self.td_s
            + self
                .td_steps
                .iter()
                .filter(|(start_ns, _)| t_ns >= *start_ns)
                .map(|(_, td)| td)
                .sum::<f64>()
    }
}
