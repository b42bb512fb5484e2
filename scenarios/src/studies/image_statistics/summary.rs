//! One sequence's statistics together, and the side-by-side table `vio image-stats` prints.

use std::fmt::Write as _;

use estimator::frontend::TrackerConfig;
use serde::Serialize;

use super::photometry::{Photometry, photometry};
use super::sequence::StaticSequence;
use super::static_tracks::{StaticTracks, static_tracks};
use super::texture::{Texture, texture};

/// Everything measured on one camera's static sequence.
#[derive(Clone, Debug, Serialize)]
pub struct ImageStatistics {
    /// The column's name.
    pub label: String,
    /// The `mav0` folder.
    pub mav0: String,
    /// The camera (`cam<i>`).
    pub camera: usize,
    /// Frames read.
    pub frames: usize,
    /// Width and height (px).
    pub size: [u32; 2],
    /// Noise and brightness.
    pub photometry: Photometry,
    /// Gradients and corners.
    pub texture: Texture,
    /// The KLT front end's drift.
    pub static_tracks: StaticTracks,
}

/// Measures `seq` with the tracker settings `config`.
pub fn measure(
    seq: &StaticSequence,
    label: &str,
    config: &TrackerConfig,
) -> Result<ImageStatistics, String> {
    Ok(ImageStatistics {
        label: label.to_string(),
        mav0: seq.mav0.display().to_string(),
        camera: seq.camera,
        frames: seq.frames.len(),
        size: seq.size,
        photometry: photometry(seq),
        texture: texture(seq, config),
        static_tracks: static_tracks(seq, config)?,
    })
}

/// The statistics side by side, one column per sequence.
pub fn table(stats: &[ImageStatistics]) -> String {
    let mut s = String::new();
    let row = |s: &mut String, name: &str, cells: Vec<String>| {
        let _ = write!(s, "{name:<34}");
        for c in cells {
            let _ = write!(s, " {c:>22}");
        }
        s.push('\n');
    };
    let col = |f: &dyn Fn(&ImageStatistics) -> String| stats.iter().map(f).collect::<Vec<_>>();
    let f3 = |v: f64| format!("{v:.3}");
    let trio = |v: [f64; 3], d: usize| format!("{:.d$} / {:.d$} / {:.d$}", v[0], v[1], v[2]);
    row(&mut s, "", col(&|x| x.label.clone()));
    row(
        &mut s,
        "camera, frames",
        col(&|x| format!("cam{} × {}", x.camera, x.frames)),
    );
    let mut bins: Vec<f64> = stats
        .iter()
        .flat_map(|x| x.photometry.noise.iter().map(|b| b.intensity))
        .collect();
    bins.sort_by(f64::total_cmp);
    bins.dedup();
    for i in bins {
        row(
            &mut s,
            &format!("temporal σ at {i:.0} (levels)"),
            col(&|x| {
                x.photometry
                    .noise
                    .iter()
                    .find(|b| b.intensity == i)
                    .map_or(String::new(), |b| {
                        format!("{:.2} ({} px)", b.sigma, b.pixels)
                    })
            }),
        );
    }
    row(
        &mut s,
        "noise fit σ² = a + I/g",
        col(&|x| {
            x.photometry
                .noise_fit
                .map_or("–".into(), |[a, g]| format!("{a:.2} + I/{g:.1}"))
        }),
    );
    row(
        &mut s,
        "→ read_noise, electrons_per_level",
        col(
            &|x| match (x.photometry.read_noise, x.photometry.electrons_per_level) {
                (Some(r), Some(g)) => format!("{r:.2}, {g:.1}"),
                _ => "–".into(),
            },
        ),
    );
    row(
        &mut s,
        "flat-area spatial residual σ",
        col(&|x| f3(x.photometry.spatial_residual_sigma)),
    );
    row(
        &mut s,
        "radial brightness (rings 2–5)",
        col(&|x| {
            let p = &x.photometry.radial_profile;
            format!("{:.2} {:.2} {:.2} {:.2}", p[1], p[2], p[3], p[4])
        }),
    );
    row(
        &mut s,
        "intensity p1 / p50 / p99",
        col(&|x| trio(x.photometry.intensity_percentiles, 0)),
    );
    row(
        &mut s,
        "saturated (≥ 250)",
        col(&|x| format!("{:.2} %", 100.0 * x.photometry.saturated_fraction)),
    );
    row(
        &mut s,
        "gradient p50 / p90 / p99 (lv/px)",
        col(&|x| trio(x.texture.gradient_percentiles, 1)),
    );
    row(
        &mut s,
        "edge pixels (≥ 8 lv/px)",
        col(&|x| format!("{:.1} %", 100.0 * x.texture.edge_fraction)),
    );
    row(
        &mut s,
        "Shi–Tomasi p50 / p90 / p99",
        col(&|x| trio(x.texture.response_percentiles, 1)),
    );
    row(
        &mut s,
        "above the detector's floor",
        col(&|x| format!("{:.1} %", 100.0 * x.texture.above_floor_fraction)),
    );
    row(
        &mut s,
        "corners per 10k px (10 px apart)",
        col(&|x| format!("{:.1}", x.texture.corners_per_10k_px)),
    );
    row(
        &mut s,
        "KLT error median / p95 / max (px)",
        col(&|x| {
            let t = &x.static_tracks;
            format!(
                "{:.3} / {:.3} / {:.2}",
                t.error_median_px, t.error_p95_px, t.error_max_px
            )
        }),
    );
    row(
        &mut s,
        "… scored, unscored observations",
        col(&|x| {
            format!(
                "{}, {}",
                x.static_tracks.observations, x.static_tracks.unscored
            )
        }),
    );
    row(
        &mut s,
        "motion left in: median / p95 (px)",
        col(&|x| {
            let r = x.static_tracks.raw_drift_px;
            format!("{:.3} / {:.3}", r[0], r[1])
        }),
    );
    row(
        &mut s,
        "features/frame, tracks, lost/frame",
        col(&|x| {
            let t = &x.static_tracks;
            format!(
                "{:.0}, {}, {:.2}",
                t.features_per_frame, t.tracks, t.lost_per_frame
            )
        }),
    );
    s
}
