//! Whether a sequence is static enough to be measured: `vio image-stats` reports a camera at
//! rest, and frames that move (or are not of one scene) give figures that look like sensor
//! noise and are not (a rendered figure-eight in motion: "read noise 3.6"; random frames: 5.0).
//! Two figures it measures anyway say so, each against a bound set from real frames at rest.

use super::photometry::FLICKER_LEVELS;
use super::summary::ImageStatistics;

/// Most share of the flat pixels' frame-to-frame differences beyond [`FLICKER_LEVELS`]. At
/// rest a difference that large is ≥ 4σ of a sensor noise of σ ≤ 2 levels; measured on EuRoC
/// V1_01 at rest (95 frames, and the 20 of the catalog excerpt): at most 0.04 % in any
/// brightness bin. A rendered figure-eight in motion: 9–17 %; uniform random frames: 90 %.
pub const MAX_CHANGED_FRACTION: f64 = 0.01;

/// Most 95th percentile of the tracks' displacement from their first position with the scene's
/// motion left in (px). EuRoC's MAV on the floor, rotors spinning, sways 1.0–1.5 px (20 and 95
/// frames); a rendered figure-eight moves 283 px, random frames 32 px.
pub const MAX_RAW_DRIFT_P95_PX: f64 = 5.0;

/// Why `s` is not a static sequence, or `None` when it is.
pub fn why_not_static(s: &ImageStatistics) -> Option<String> {
    let (changed, pixels) = s.photometry.noise.iter().fold((0.0, 0usize), |(c, n), b| {
        (c + b.flicker_fraction * b.pixels as f64, n + b.pixels)
    });
    if pixels > 0 {
        let fraction = changed / pixels as f64;
        if fraction > MAX_CHANGED_FRACTION {
            return Some(format!(
                "{:.1} % of the flat pixels' values change by more than {FLICKER_LEVELS} levels from one frame to the next (at rest: at most {:.0} %; EuRoC V1_01 on the floor: 0.04 %): the frames are not of one static scene",
                100.0 * fraction,
                100.0 * MAX_CHANGED_FRACTION
            ));
        }
    }
    let p95 = s.static_tracks.raw_drift_px[1];
    if p95 > MAX_RAW_DRIFT_P95_PX {
        return Some(format!(
            "the tracks move {p95:.1} px from where they started (95th percentile; at rest: at most {MAX_RAW_DRIFT_P95_PX} px; EuRoC's MAV on the floor: 1.5 px): the camera moves"
        ));
    }
    None
}
