//! Rolling shutter: the rows of an image are exposed one after another over the readout time,
//! not all at the frame's stamp.
//!
//! Convention (what a camera driver does): the frame's stamp is the time of the row read
//! first; row `r` (pixel centres at integer `v`, OpenCV) is read `readout · r / height` later,
//! counted from the top for [`ReadoutDirection::TopToBottom`] and from the bottom for
//! [`ReadoutDirection::BottomToTop`]. A global-shutter camera has a zero readout.

use nalgebra::Vector2;

/// Which row is read first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReadoutDirection {
    /// The top row (`v = 0`) first: most sensors.
    #[default]
    TopToBottom,
    /// The bottom row first (a sensor mounted upside down).
    BottomToTop,
}

/// A camera's readout: how long after the stamp each row is exposed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RollingShutter {
    /// Time from the first row to one row past the last (s); 0 for a global shutter.
    pub readout_s: f64,
    /// Which row is read first.
    pub direction: ReadoutDirection,
}

impl RollingShutter {
    /// A global shutter: every row at the stamp.
    pub const GLOBAL: Self = Self {
        readout_s: 0.0,
        direction: ReadoutDirection::TopToBottom,
    };

    /// Whether rows are exposed at different times.
    pub fn is_rolling(&self) -> bool {
        self.readout_s > 0.0
    }

    /// Time (s) after the stamp at which the row through distorted pixel `uv` of an image
    /// `height` rows tall is exposed (clamped to the image's rows).
    pub fn row_time_s(&self, uv: &Vector2<f64>, height: u32) -> f64 {
        if !self.is_rolling() {
            return 0.0;
        }
        let last = f64::from(height.max(1) - 1);
        let row = match self.direction {
            ReadoutDirection::TopToBottom => uv.y,
            ReadoutDirection::BottomToTop => last - uv.y,
        }
        .clamp(0.0, last);
        self.readout_s * row / f64::from(height.max(1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_read_in_order_over_the_readout() {
        let rs = RollingShutter {
            readout_s: 0.02,
            direction: ReadoutDirection::TopToBottom,
        };
        assert_eq!(rs.row_time_s(&Vector2::new(10.0, 0.0), 480), 0.0);
        assert!((rs.row_time_s(&Vector2::new(10.0, 240.0), 480) - 0.01).abs() < 1e-15);
        let up = RollingShutter {
            direction: ReadoutDirection::BottomToTop,
            ..rs
        };
        assert_eq!(up.row_time_s(&Vector2::new(10.0, 479.0), 480), 0.0);
        assert!((up.row_time_s(&Vector2::new(0.0, 0.0), 480) - 0.02 * 479.0 / 480.0).abs() < 1e-15);
        // Outside the image: the nearest row; a global shutter: the stamp.
        assert_eq!(rs.row_time_s(&Vector2::new(0.0, -3.0), 480), 0.0);
        assert_eq!(
            RollingShutter::GLOBAL.row_time_s(&Vector2::new(0.0, 300.0), 480),
            0.0
        );
    }
}
