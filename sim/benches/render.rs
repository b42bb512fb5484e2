//! Render + readback (+ distortion remap) time per stereo pair on the default adapter: the
//! EuRoC-like 752×480 radtan pair in the textured room, with the default settings (mip-mapped
//! textures, distortion on), with 4× MSAA, with motion blur (4 sub-frames), with sensor noise,
//! and with the settings the rendered catalog scenarios fit to the real EuRoC frames (blur and
//! noise included). Prints the adapter first.
//!
//! `cargo bench -p sim --bench render`

use criterion::{Criterion, criterion_group, criterion_main};
use estimator::geometry::Pose;
use sim::render::{MotionBlur, RenderConfig};
use sim::{World, WorldConfig};
use std::hint::black_box;

fn render_pair(c: &mut Criterion) {
    let world = World::new(WorldConfig {
        duration_s: 10.0,
        ..WorldConfig::default()
    })
    .unwrap();
    let mut stream = world.stream();
    // Poses along the default figure-eight, a frame apart.
    let poses: Vec<Pose> = (0..40)
        .map(|i| stream.truth(2_000_000_000 + i * 50_000_000).unwrap().pose)
        .collect();
    let variants: [(&str, RenderConfig); 7] = [
        ("stereo_pair_default", RenderConfig::default()),
        (
            "stereo_pair_pinhole_scale_1",
            RenderConfig {
                pinhole_scale: 1.0,
                ..RenderConfig::default()
            },
        ),
        (
            "stereo_pair_msaa4",
            RenderConfig {
                msaa: true,
                ..RenderConfig::default()
            },
        ),
        (
            "stereo_pair_motion_blur_4",
            RenderConfig {
                motion_blur: Some(MotionBlur {
                    exposure_s: 0.005,
                    samples: 4,
                }),
                ..RenderConfig::default()
            },
        ),
        (
            "stereo_pair_trilinear",
            RenderConfig {
                trilinear: true,
                ..RenderConfig::default()
            },
        ),
        ("stereo_pair_noise", {
            let mut cfg = RenderConfig::default();
            cfg.photometric.read_noise = 1.0;
            cfg.photometric.electrons_per_level = 40.0;
            cfg
        }),
        // The settings of `room_figure8_rendered_stereo_imu`, fitted to the real EuRoC frames:
        // texture, vignetting, optical blur, read and shot noise.
        ("stereo_pair_fitted_to_euroc", {
            let mut cfg = RenderConfig {
                texture_density: 0.1,
                texture_contrast: 0.6,
                ..RenderConfig::default()
            };
            cfg.photometric.vignetting = 0.25;
            cfg.photometric.read_noise = 0.4;
            cfg.photometric.electrons_per_level = 62.0;
            cfg.photometric.optical_blur_px = 1.0;
            cfg
        }),
    ];
    let mut printed = false;
    for (name, cfg) in variants {
        let mut r = world.renderer(&cfg).unwrap();
        if !printed {
            eprintln!(
                "adapter: {}; virtual pinhole {:?}",
                r.adapter(),
                r.pinhole(0)
            );
            printed = true;
        }
        let k = r.exposure_offsets_ns().len();
        let mut i = 0usize;
        c.bench_function(name, |b| {
            b.iter(|| {
                let p = vec![poses[i % poses.len()]; k];
                i += 1;
                black_box(r.render(0, 0, i as u64, &p, &[0, 1]).unwrap())
            })
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = render_pair
}
criterion_main!(benches);
