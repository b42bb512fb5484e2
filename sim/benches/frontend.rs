//! The image front end on rendered images: one `FeatureTracker::track` call on an EuRoC-like
//! 752×480 radtan stereo pair in the textured room (the settings of
//! `room_figure8_rendered_stereo_imu`: vignetting 0.25, read noise 1, 40 e⁻ per level), 50 ms
//! after the previous pair, with the true gyro rotation between them and ~150 mature tracks
//! (10 captures of history before). Before criterion it prints the adapter, the tracker's
//! features and stereo matches on that pair, and the median of each stage over 50 repetitions.
//!
//! Each repetition starts from a clone of the same warmed tracker.
//!
//! `cargo bench -p sim --bench frontend`

use std::hint::black_box;
use std::time::Duration;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use estimator::frontend::{
    CameraImageView, FeatureFrame, FeatureTracker, ImageView, StageTimes, TrackerCamera,
    TrackerConfig,
};
use nalgebra::UnitQuaternion;
use sim::render::{ImageFrame, RenderConfig};
use sim::{World, WorldConfig};

/// Capture time of the benchmarked pair (ns); the previous pair is one period (50 ms) before.
const T_NS: i64 = 12_050_000_000;
/// Captures tracked before the previous pair.
const HISTORY: i64 = 10;
/// Repetitions for the per-stage medians.
const REPETITIONS: usize = 50;

/// Rendered captures (oldest first) with the true rotation since the capture before.
struct Captures {
    frames: Vec<(ImageFrame, Option<UnitQuaternion<f64>>)>,
    cameras: Vec<TrackerCamera>,
    adapter: String,
}

fn captures() -> Captures {
    let world = World::new(WorldConfig {
        seed: 1,
        duration_s: 13.0,
        ..WorldConfig::default()
    })
    .unwrap();
    let mut cfg = RenderConfig::default();
    cfg.photometric.vignetting = 0.25;
    cfg.photometric.read_noise = 1.0;
    cfg.photometric.electrons_per_level = 40.0;
    let mut renderer = world.renderer(&cfg).unwrap();
    let rig = world.config().rig.clone().unwrap();
    let period = rig.period_ns();
    let offsets = renderer.exposure_offsets_ns();
    let live: Vec<usize> = (0..rig.cameras.len()).collect();
    let mut stream = world.stream();
    let mut prev_q: Option<UnitQuaternion<f64>> = None;
    let mut frames = Vec::new();
    for k in (T_NS / period - HISTORY - 1)..=T_NS / period {
        let t = k * period;
        let q = stream.truth(t).unwrap().pose.q;
        let poses: Vec<_> = offsets
            .iter()
            .map(|o| stream.truth(t + o).unwrap().pose)
            .collect();
        let frame = renderer.render(t, t, k as u64, &poses, &live).unwrap();
        // R_bprev_bcur = q_prev⁻¹ q_cur: what an ideal gyroscope integrates.
        frames.push((frame, prev_q.map(|p| p.inverse() * q)));
        prev_q = Some(q);
    }
    let cameras = rig
        .cameras
        .iter()
        .map(|c| TrackerCamera {
            model: c.model.clone(),
            T_b_c: c.t_b_c,
        })
        .collect();
    Captures {
        frames,
        cameras,
        adapter: renderer.adapter().to_string(),
    }
}

fn views(frame: &ImageFrame) -> Vec<CameraImageView<'_>> {
    frame
        .cameras
        .iter()
        .map(|c| CameraImageView {
            cam_id: c.cam_id,
            image: ImageView::packed(c.image.width, c.image.height, &c.image.data).unwrap(),
        })
        .collect()
}

/// A tracker that has tracked every capture but the last.
fn warm(c: &Captures) -> FeatureTracker {
    let mut tracker = FeatureTracker::new(TrackerConfig::default(), c.cameras.clone()).unwrap();
    for (frame, rotation) in &c.frames[..c.frames.len() - 1] {
        tracker.track(&views(frame), frame.t_ns, *rotation).unwrap();
    }
    tracker
}

/// Tracks the last capture.
fn track_last(c: &Captures, tracker: &mut FeatureTracker) -> FeatureFrame {
    let (frame, rotation) = c.frames.last().unwrap();
    tracker.track(&views(frame), frame.t_ns, *rotation).unwrap()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn print_stages(c: &Captures) {
    let warm0 = warm(c);
    let mature = warm0.tracks().filter(|t| t.age >= 5).count();
    eprintln!("adapter: {}", c.adapter);
    let mut times: Vec<StageTimes> = Vec::with_capacity(REPETITIONS);
    let mut last = None;
    for _ in 0..REPETITIONS {
        let mut tracker = warm0.clone();
        let frame = track_last(c, &mut tracker);
        times.push(tracker.report().times);
        last = Some((frame, tracker.report().clone()));
    }
    let (frame, report) = last.unwrap();
    let features = frame.cameras.first().map_or(0, |f| f.features.len());
    let stereo: usize = frame.cameras.iter().skip(1).map(|f| f.features.len()).sum();
    eprintln!(
        "before the pair: {} tracks, {mature} seen in ≥ 5 frames; on the pair: {} in, {} lost \
         by KLT, {} by flow-back, {} by RANSAC, {} crowded, {} detected → {features} features, \
         {stereo} stereo matches ({} tried)",
        warm0.tracks().count(),
        report.tracks_in,
        report.klt_lost,
        report.flow_back_rejected,
        report.ransac_rejected.len(),
        report.crowded,
        report.detected,
        report.stereo_tried,
    );
    let stage = |f: fn(&StageTimes) -> f64| median(times.iter().map(f).collect()) * 1e3;
    eprintln!(
        "median of {REPETITIONS} (ms): pyramids {:.2}  temporal {:.2}  ransac {:.2}  \
         detect {:.2}  stereo {:.2}  total {:.2}",
        stage(|t| t.pyramids_s),
        stage(|t| t.temporal_s),
        stage(|t| t.ransac_s),
        stage(|t| t.detect_s),
        stage(|t| t.stereo_s),
        stage(|t| t.total_s),
    );
}

fn track_pair(crit: &mut Criterion) {
    let c = captures();
    print_stages(&c);
    let warmed = warm(&c);
    crit.bench_function("track_stereo_pair_150_tracks", |b| {
        b.iter_batched(
            || warmed.clone(),
            |mut tracker| black_box(track_last(&c, &mut tracker)),
            BatchSize::PerIteration,
        )
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(50)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(5));
    targets = track_pair
}
criterion_main!(benches);
