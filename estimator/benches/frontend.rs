//! Micro-benchmarks of the image front end's kernels on a synthetic 752×480 texture:
//! pyramid, Shi–Tomasi response, template sampling and one pyramidal KLT track.
//! (`cargo bench -p sim --bench frontend` times the whole tracker on rendered images.)

use criterion::{Criterion, criterion_group, criterion_main};
use estimator::frontend::corners::shi_tomasi_response;
use estimator::frontend::klt::{KltParams, Template, track};
use estimator::frontend::{ImageView, Pyramid};
use nalgebra::Vector2;
use std::hint::black_box;

/// A deterministic texture: a few sinusoids with 1/f-like amplitudes.
fn texture(w: u32, h: u32, dx: f64, dy: f64) -> Vec<u8> {
    let waves = [
        (0.05, 0.031, 40.0),
        (-0.11, 0.07, 25.0),
        (0.23, -0.19, 15.0),
        (0.41, 0.37, 9.0),
        (-0.6, 0.52, 6.0),
    ];
    let mut d = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let (u, v) = (x as f64 - dx, y as f64 - dy);
            let s: f64 = waves
                .iter()
                .map(|(a, b, amp)| amp * (a * u + b * v).sin())
                .sum();
            d.push((128.0 + s).clamp(0.0, 255.0) as u8);
        }
    }
    d
}

fn bench(c: &mut Criterion) {
    let (w, h) = (752, 480);
    let a = texture(w, h, 0.0, 0.0);
    let b = texture(w, h, 2.3, -1.6);
    let va = ImageView::packed(w, h, &a).unwrap();
    let vb = ImageView::packed(w, h, &b).unwrap();
    c.bench_function("pyramid 752x480 levels 0..=3", |bench| {
        bench.iter(|| Pyramid::build(black_box(&va), 3))
    });
    let mut resp = Vec::new();
    c.bench_function("shi-tomasi response 752x480", |bench| {
        bench.iter(|| shi_tomasi_response(black_box(&va), &mut resp))
    });
    let (pa, pb) = (Pyramid::build(&va, 3), Pyramid::build(&vb, 3));
    let params = KltParams::default();
    let p = Vector2::new(300.3, 200.7);
    c.bench_function("template 21x21, 4 levels", |bench| {
        bench.iter(|| Template::new(black_box(&pa), p, 4, &params))
    });
    let t = Template::new(&pa, p, 4, &params);
    c.bench_function("klt track 21x21, 4 levels", |bench| {
        bench.iter(|| track(black_box(&t), &pb, p, 3, &params))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
