//! `features.csv`: feature-track export, one observation per row `t_ns,cam_id,feature_id,u,v`
//! (distorted pixels, OpenCV convention), so that other estimators can consume exactly our
//! measurements.
//!
//! Rows are grouped into frames by timestamp (strictly increasing between frames), and within a
//! frame by camera (each camera one contiguous block, feature ids strictly increasing inside it).
//! A camera entry with no observations (or a frame with none at all) has no row, so it does not
//! survive a round trip.

use std::fmt::Write as _;
use std::path::Path;

use estimator::frontend::{CameraFeatures, FeatureFrame, FeatureObservation};
use nalgebra::Vector2;

use super::{
    DatasetError, check_finite, data_lines, fmt_f64, invalid, parse_error, parse_f64,
    parse_stamp_ns, read_text, write_text,
};

/// Header line of `features.csv`.
pub const FEATURES_HEADER: &str = "t_ns,cam_id,feature_id,u,v";

/// Parses `features.csv` text; `path` names the source in errors.
pub fn parse_features_csv(text: &str, path: &Path) -> Result<Vec<FeatureFrame>, DatasetError> {
    parse_features_csv_within(text, path, &[])
}

/// How far outside its image a feature's pixel may lie (px): a tracked pixel is inside it.
pub const PIXEL_SLACK_PX: f64 = 1.0;

/// [`parse_features_csv`] for cameras of `sizes` (`[width, height]` per camera, in order): a
/// pixel more than [`PIXEL_SLACK_PX`] outside its camera's image is an error naming the line.
/// Rows of cameras beyond `sizes` are not checked (the caller leaves them out); an empty
/// `sizes` checks no pixel.
pub fn parse_features_csv_within(
    text: &str,
    path: &Path,
    sizes: &[[u32; 2]],
) -> Result<Vec<FeatureFrame>, DatasetError> {
    let mut frames: Vec<FeatureFrame> = Vec::new();
    for (line, content) in data_lines(text) {
        let compact: String = content.chars().filter(|c| !c.is_whitespace()).collect();
        if compact == FEATURES_HEADER {
            continue;
        }
        let err = |m: String| parse_error(path, line, m);
        let f: Vec<&str> = content.split(',').map(str::trim).collect();
        if f.len() != 5 {
            return Err(err(format!(
                "expected 5 comma-separated columns (t_ns,cam_id,feature_id,u,v), found {}",
                f.len()
            )));
        }
        let t_ns = parse_stamp_ns(f[0], "t_ns").map_err(err)?;
        let cam_id: usize = f[1]
            .parse()
            .map_err(|_| err(format!("cam_id: `{}` is not a non-negative integer", f[1])))?;
        let feature_id: u64 = f[2].parse().map_err(|_| {
            err(format!(
                "feature_id: `{}` is not a non-negative integer",
                f[2]
            ))
        })?;
        let u = parse_f64(f[3], "u").map_err(err)?;
        let v = parse_f64(f[4], "v").map_err(err)?;
        if let Some(&[w, h]) = sizes.get(cam_id) {
            let inside =
                |x: f64, n: u32| (-PIXEL_SLACK_PX..=f64::from(n) + PIXEL_SLACK_PX).contains(&x);
            if !inside(u, w) || !inside(v, h) {
                return Err(err(format!(
                    "pixel ({}, {}) is outside camera {cam_id}'s {w}×{h} image",
                    f[3], f[4]
                )));
            }
        }
        let obs = FeatureObservation {
            feature_id,
            uv: Vector2::new(u, v),
        };

        let new_frame = match frames.last() {
            Some(fr) if fr.t_ns == t_ns => false,
            Some(fr) if t_ns < fr.t_ns => {
                return Err(err(format!(
                    "timestamps not increasing: {t_ns} ns follows {} ns",
                    fr.t_ns
                )));
            }
            _ => true,
        };
        if new_frame {
            frames.push(FeatureFrame {
                t_ns,
                cameras: Vec::new(),
            });
        }
        let last = frames.len() - 1; // a frame exists: pushed above if needed
        let frame = &mut frames[last];
        match frame.cameras.last_mut() {
            Some(cam) if cam.cam_id == cam_id => {
                if let Some(last) = cam.features.last()
                    && feature_id <= last.feature_id
                {
                    return Err(err(format!(
                        "feature ids of camera {cam_id} not increasing within the frame: {feature_id} follows {}",
                        last.feature_id
                    )));
                }
                cam.features.push(obs);
            }
            _ => {
                if frame.cameras.iter().any(|c| c.cam_id == cam_id) {
                    return Err(err(format!(
                        "rows of camera {cam_id} are not contiguous within the frame at {t_ns} ns"
                    )));
                }
                frame.cameras.push(CameraFeatures {
                    cam_id,
                    features: vec![obs],
                });
            }
        }
    }
    Ok(frames)
}

/// Reads `features.csv`.
pub fn read_features_csv(path: impl AsRef<Path>) -> Result<Vec<FeatureFrame>, DatasetError> {
    read_features_csv_within(path, &[])
}

/// Reads `features.csv` for cameras of `sizes` (see [`parse_features_csv_within`]).
pub fn read_features_csv_within(
    path: impl AsRef<Path>,
    sizes: &[[u32; 2]],
) -> Result<Vec<FeatureFrame>, DatasetError> {
    let path = path.as_ref();
    parse_features_csv_within(&read_text(path)?, path, sizes)
}

/// Formats feature frames as `features.csv` text (header line first). Frames must have strictly
/// increasing timestamps; rows follow the order of cameras and observations in each frame.
pub fn format_features_csv(frames: &[FeatureFrame], path: &Path) -> Result<String, DatasetError> {
    let mut s = String::from(FEATURES_HEADER);
    s.push('\n');
    let mut row = 0usize;
    for (i, fr) in frames.iter().enumerate() {
        if i > 0 && fr.t_ns <= frames[i - 1].t_ns {
            return Err(invalid(
                path,
                format!("cannot write frame {i}: timestamps not increasing"),
            ));
        }
        for cam in &fr.cameras {
            for o in &cam.features {
                check_finite(path, row, &[o.uv.x, o.uv.y])?;
                let _ = writeln!(
                    s,
                    "{},{},{},{},{}",
                    fr.t_ns,
                    cam.cam_id,
                    o.feature_id,
                    fmt_f64(o.uv.x),
                    fmt_f64(o.uv.y)
                );
                row += 1;
            }
        }
    }
    Ok(s)
}

/// Writes `features.csv` (creating parent folders).
pub fn write_features_csv(
    path: impl AsRef<Path>,
    frames: &[FeatureFrame],
) -> Result<(), DatasetError> {
    let path = path.as_ref();
    write_text(path, &format_features_csv(frames, path)?)
}
