mod common;
use common::Analytic;
use common::world::World;
#[test]
fn probe() {
    let mut w = World::new(1, 10, 0.0);
    w.imu_noise_scale = 0.0;
    for k in 0..3 { let a = w.imu(k * 5_000_000); let b = Analytic::sample(k * 5_000_000); println!("{:?} {:?}", a.gyro - b.gyro, a.accel - b.accel); }
}
