//! Cost of generating 60 s of ground truth + IMU + stereo feature frames.

use criterion::{Criterion, criterion_group, criterion_main};
use sim::{World, WorldConfig};

fn bench(c: &mut Criterion) {
    let world = World::new(WorldConfig {
        duration_s: 60.0,
        rig: Some(sim::camera::RigConfig::euroc_like()),
        ..WorldConfig::default()
    })
    .unwrap();
    let mut g = c.benchmark_group("stream");
    g.sample_size(10);
    g.bench_function("60s_room_imu200_stereo20", |b| {
        b.iter(|| {
            let mut s = world.stream();
            let mut n = 0usize;
            let mut t = 0i64;
            while let Some(m) = s.next() {
                n += 1;
                // Ground truth at every event, as a runner would query it.
                if m.t_ns() >= t {
                    t = m.t_ns() + 50_000_000;
                    std::hint::black_box(s.truth(m.t_ns().max(0)));
                }
            }
            n
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
