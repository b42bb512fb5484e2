//! What the estimator reports about itself: which sensors it is using and what it had to do
//! without (instead of swallowing a failure).

use std::fmt;

/// The sensors the window is using now: the configured suite, or what is left of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LiveSuite {
    /// Both cameras and the IMU.
    StereoImu,
    /// One camera (`cam`) and the IMU.
    MonoImu {
        /// The camera still delivering.
        cam: usize,
    },
    /// The IMU alone (every camera silent): propagation only.
    ImuOnly,
    /// Both cameras, no IMU (configured, or the IMU is silent).
    Stereo,
    /// One camera without the IMU (scale is then only carried by the landmarks).
    Mono {
        /// The camera still delivering.
        cam: usize,
    },
    /// Nothing delivers.
    None,
}

impl LiveSuite {
    /// The suite made of the live sensors.
    pub fn from_live(cameras: [bool; 2], imu: bool) -> Self {
        match (cameras, imu) {
            ([true, true], true) => Self::StereoImu,
            ([true, true], false) => Self::Stereo,
            ([true, false], true) => Self::MonoImu { cam: 0 },
            ([false, true], true) => Self::MonoImu { cam: 1 },
            ([true, false], false) => Self::Mono { cam: 0 },
            ([false, true], false) => Self::Mono { cam: 1 },
            ([false, false], true) => Self::ImuOnly,
            ([false, false], false) => Self::None,
        }
    }
}

impl fmt::Display for LiveSuite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::StereoImu => write!(f, "stereo_imu"),
            Self::MonoImu { cam } => write!(f, "mono_imu(cam{cam})"),
            Self::ImuOnly => write!(f, "imu_only"),
            Self::Stereo => write!(f, "stereo"),
            Self::Mono { cam } => write!(f, "mono(cam{cam})"),
            Self::None => write!(f, "none"),
        }
    }
}

/// What happened.
#[derive(Clone, Debug, PartialEq)]
pub enum EventKind {
    /// The live sensors changed: the window now uses `to`'s factors only.
    SuiteSwitch {
        /// Before.
        from: LiveSuite,
        /// After.
        to: LiveSuite,
        /// Which sensor stopped or came back.
        reason: String,
    },
    /// IMU samples were excluded as spikes (see `EstimatorConfig::imu_spike_threshold`).
    ImuSamplesExcluded {
        /// Their times (ns).
        t_ns: Vec<i64>,
    },
    /// IMU samples sat on the sensor's range (see `EstimatorConfig::imu_range`): the intervals
    /// over them carry no IMU factor.
    ImuSamplesSaturated {
        /// How many.
        count: usize,
    },
    /// Marginalization failed: the window goes on without a prior (its information is lost).
    PriorDropped,
    /// The GNSS alignment was initialized: fixes are factors from now on (see
    /// `super::aiding`).
    GnssAligned,
    /// GNSS fixes disagreed with the window `GnssConfig::realign_after_rejections` times in a
    /// row: the alignment was dropped and is initialized again from the fixes that follow.
    GnssAlignmentDropped,
    /// A held calibration quantity (rig rotation, rig translation or time offset) is free
    /// from now on: the window determines it (see `super::calibration`).
    CalibrationReleased {
        /// Which, and the σ it had when released.
        detail: String,
    },
    /// The solved window failed a health check (see [`super::health`]) and was discarded; the
    /// estimator restarted from the last good state, or initializes again when no state had
    /// passed (the first solve after an initialization is checked too).
    Reset {
        /// What failed.
        reason: String,
    },
}

/// A timestamped estimator event.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    /// Time (ns, IMU clock).
    pub t_ns: i64,
    /// What happened.
    pub kind: EventKind,
}
