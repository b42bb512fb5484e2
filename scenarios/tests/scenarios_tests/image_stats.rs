//! `vio image-stats` measures a camera at rest and refuses frames that are not: the real EuRoC
//! excerpt (the MAV on the floor) is measured; the same frames panned (a camera that moves,
//! fast or by a fraction of a pixel a frame) and frames of random noise (not one scene) are
//! refused, saying which figure is out of its bound.

use std::path::{Path, PathBuf};

use crate::common;

use common::{scratch, vio};

fn excerpt() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("catalog/data/euroc_V1_01_easy_excerpt/mav0")
}

/// A `mav0` under `dir` with the excerpt's IMU log and cam0 calibration, and cam0 frames made
/// by `frame(k, real_frame_k)`.
fn with_frames(
    dir: &Path,
    frame: impl Fn(usize, &image::GrayImage) -> image::GrayImage,
) -> PathBuf {
    let src = excerpt();
    let mav0 = dir.join("mav0");
    std::fs::create_dir_all(mav0.join("imu0")).unwrap();
    std::fs::create_dir_all(mav0.join("cam0/data")).unwrap();
    for f in [
        "imu0/data.csv",
        "imu0/sensor.yaml",
        "cam0/sensor.yaml",
        "cam0/data.csv",
    ] {
        std::fs::copy(src.join(f), mav0.join(f)).unwrap();
    }
    let list = std::fs::read_to_string(src.join("cam0/data.csv")).unwrap();
    for (k, line) in list.lines().skip(1).enumerate() {
        let name = line.split(',').nth(1).unwrap().trim();
        let real = image::open(src.join("cam0/data").join(name))
            .unwrap()
            .to_luma8();
        frame(k, &real)
            .save(mav0.join("cam0/data").join(name))
            .unwrap();
    }
    mav0
}

fn image_stats(mav0: &Path) -> (Option<i32>, String) {
    let o = vio(&["image-stats", mav0.to_str().unwrap()]);
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn frames_at_rest_are_measured_and_moving_or_random_ones_refused() {
    let (code, stderr) = image_stats(&excerpt());
    assert_eq!(code, Some(0), "{stderr}");

    // The real frames panned 4 px per frame (76 px over the 20): the camera moves.
    let dir = scratch("image-stats-panned");
    let panned = with_frames(dir.path(), |k, real| {
        let (w, h) = real.dimensions();
        image::GrayImage::from_fn(w, h, |x, y| {
            *real.get_pixel((x + 4 * k as u32).min(w - 1), y)
        })
    });
    let (code, stderr) = image_stats(&panned);
    assert_eq!(code, Some(2), "{stderr}");
    // Measured: 10.8 % of the flat pixels change by more than 12 levels (the first check).
    assert!(stderr.contains("not a static sequence"), "{stderr}");
    assert!(
        stderr.contains("change by more than") || stderr.contains("the camera moves"),
        "{stderr}"
    );

    // Panned slowly, 0.4 px per frame (bilinear; 7.6 px over the 20): few pixels change by
    // much, but the tracks move (measured: 7.2 px, 95th percentile).
    let dir = scratch("image-stats-slow-pan");
    let slow = with_frames(dir.path(), |k, real| {
        let (w, h) = real.dimensions();
        let shift = 0.4 * k as f64;
        let (whole, frac) = (shift.floor() as u32, shift.fract());
        let at = |x: u32, y: u32| f64::from(real.get_pixel(x.min(w - 1), y).0[0]);
        image::GrayImage::from_fn(w, h, |x, y| {
            let v = (1.0 - frac) * at(x + whole, y) + frac * at(x + whole + 1, y);
            image::Luma([v.round().clamp(0.0, 255.0) as u8])
        })
    });
    let (code, stderr) = image_stats(&slow);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("the camera moves"), "{stderr}");

    // Uniform random frames (seeded): no scene stays.
    let dir = scratch("image-stats-random");
    let random = with_frames(dir.path(), |k, real| {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64 ^ (k as u64 + 1);
        let (w, h) = real.dimensions();
        image::GrayImage::from_fn(w, h, |_, _| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            image::Luma([(state >> 56) as u8])
        })
    });
    let (code, stderr) = image_stats(&random);
    assert_eq!(code, Some(2), "{stderr}");
    assert!(stderr.contains("change by more than"), "{stderr}");
}
