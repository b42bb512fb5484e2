//! Physical plausibility: the range every sensor quantity of a real rig lies in, with its
//! basis. A value outside is a units mistake (millimetres typed as metres, µg as m/s², a focal
//! length in millimetres) or a typo, not a sensor, so every reader of a rig (a scenario, a
//! `sensor.yaml`, a Kalibr file) refuses it at the door, naming its own key, the value and the
//! range. Each range spans the real sensors of its kind with a margin of at least 10 either way
//! (the simulator's studies sweep an IMU grade ×0.1 to ×30), and a units mistake of 10³ falls
//! outside it from any realistic value.

/// The range one quantity lies in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plausible {
    /// Smallest plausible value.
    pub lo: f64,
    /// Largest plausible value.
    pub hi: f64,
    /// The unit, as written after a value.
    pub unit: &'static str,
    /// What the range spans.
    pub basis: &'static str,
}

impl Plausible {
    /// `Err` with the value, the range and its basis when `v` is not finite or outside.
    pub fn check(&self, v: f64) -> Result<(), String> {
        if v.is_finite() && (self.lo..=self.hi).contains(&v) {
            return Ok(());
        }
        Err(format!(
            "{v} {} is not physically plausible: expected [{}, {}] {} ({})",
            self.unit,
            bound(self.lo),
            bound(self.hi),
            self.unit,
            self.basis
        ))
    }
}

/// A range end as written: plain between 10⁻³ and 10⁴, else in exponent form.
fn bound(v: f64) -> String {
    if v == 0.0 || (1e-3..1e4).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Camera frame rate.
pub const CAMERA_RATE_HZ: Plausible = Plausible {
    lo: 1.0,
    hi: 1_000.0,
    unit: "Hz",
    basis: "from slow machine-vision capture to high-speed cameras",
};

/// Gyroscope white noise density.
pub const GYROSCOPE_NOISE_DENSITY: Plausible = Plausible {
    lo: 1e-7,
    hi: 0.1,
    unit: "rad/s/√Hz",
    basis: "a navigation-grade gyroscope's 6e-7 to the cheapest MEMS' 1e-3, with margin; the EuRoC ADIS16448: 1.7e-4",
};

/// Accelerometer white noise density.
pub const ACCELEROMETER_NOISE_DENSITY: Plausible = Plausible {
    lo: 1e-6,
    hi: 1.0,
    unit: "m/s²/√Hz",
    basis: "a navigation-grade accelerometer's 1e-4 (10 µg/√Hz) to the cheapest MEMS' 1e-2, with margin; the EuRoC ADIS16448: 2e-3",
};

/// Gyroscope bias random walk.
pub const GYROSCOPE_RANDOM_WALK: Plausible = Plausible {
    lo: 1e-9,
    hi: 1e-2,
    unit: "rad/s²/√Hz",
    basis: "navigation grade to consumer MEMS' 1e-4, with margin; the EuRoC ADIS16448: 1.9e-5",
};

/// Accelerometer bias random walk.
pub const ACCELEROMETER_RANDOM_WALK: Plausible = Plausible {
    lo: 1e-8,
    hi: 1.0,
    unit: "m/s³/√Hz",
    basis: "navigation grade to consumer MEMS, with margin; the EuRoC ADIS16448: 3e-3",
};

/// Gyroscope full-scale range.
pub const GYRO_RANGE_RAD_S: Plausible = Plausible {
    lo: 1.0,
    hi: 100.0,
    unit: "rad/s",
    basis: "MEMS full scales run from ±125 °/s (2.2 rad/s) to ±4000 °/s (70 rad/s)",
};

/// Accelerometer full-scale range: at rest an accelerometer reads gravity, so a range below it
/// clips every sample.
pub const ACCEL_RANGE_M_S2: Plausible = Plausible {
    lo: 19.6,
    hi: 10_000.0,
    unit: "m/s²",
    basis: "MEMS full scales run from ±2 g (19.6 m/s²) up; below gravity every sample at rest clips",
};

/// A camera's distance from the IMU on one rigid body.
pub const CAMERA_OFFSET_M: Plausible = Plausible {
    lo: 0.0,
    hi: 5.0,
    unit: "m",
    basis: "a camera and an IMU on one body, a car's length apart at most; the EuRoC cameras: 0.07 m",
};

/// Focal length over the image's longer side (px per px): a 200° fisheye has about 0.17
/// (equidistant), a 1° telephoto about 60.
pub const FOCAL_PER_IMAGE_SIDE: Plausible = Plausible {
    lo: 0.05,
    hi: 100.0,
    unit: "× the longer image side",
    basis: "from a 200° fisheye (0.17) to a 1° telephoto (60); a focal length in millimetres is far below",
};

/// A focal length `f_px` on an image whose longer side is `longer_side_px`, against
/// [`FOCAL_PER_IMAGE_SIDE`]; the error names both.
pub fn check_focal_length(f_px: f64, longer_side_px: f64) -> Result<(), String> {
    FOCAL_PER_IMAGE_SIDE
        .check(f_px / longer_side_px)
        .map_err(|e| {
            format!("focal length {f_px} px over the longer side {longer_side_px} px: {e}")
        })
}

/// A lens distortion coefficient (radial-tangential, Kannala–Brandt, Mei).
pub const DISTORTION_COEFFICIENT: Plausible = Plausible {
    lo: -5.0,
    hi: 5.0,
    unit: "",
    basis: "real lenses' coefficients lie within ±2; the EuRoC cam0's k1: −0.28",
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_units_mistake_of_a_thousand_falls_outside_from_a_real_value() {
        // The EuRoC rig's values, and the same a thousand times larger (or smaller).
        for (p, real) in [
            (GYROSCOPE_NOISE_DENSITY, 1.6968e-4),
            (ACCELEROMETER_NOISE_DENSITY, 2.0e-3),
            (GYROSCOPE_RANDOM_WALK, 1.9393e-5),
            (ACCELEROMETER_RANDOM_WALK, 3.0e-3),
            (CAMERA_OFFSET_M, 0.068),
            (FOCAL_PER_IMAGE_SIDE, 458.654 / 752.0),
        ] {
            assert!(p.check(real).is_ok(), "{p:?}");
            assert!(p.check(real * 1e3).is_err(), "{p:?} × 1e3");
        }
        for (p, real) in [(CAMERA_RATE_HZ, 20.0), (ACCEL_RANGE_M_S2, 176.58)] {
            assert!(p.check(real).is_ok());
            assert!(p.check(real / 1e3).is_err(), "{p:?} / 1e3");
        }
        let e = ACCELEROMETER_NOISE_DENSITY.check(2.0).unwrap_err();
        assert!(
            e.contains("2 m/s²/√Hz") && e.contains("[1e-6, 1] m/s²/√Hz"),
            "{e}"
        );
        assert!(CAMERA_RATE_HZ.check(f64::NAN).is_err());
    }
}
