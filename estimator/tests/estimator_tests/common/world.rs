//! A synthetic world for estimator tests: the analytic trajectory, landmarks on the walls of a
//! box-shaped room, a EuRoC-like stereo rig and a noisy, biased IMU.

use std::sync::Arc;

use estimator::camera::{CameraModel, PinholeRadtan};
use estimator::frontend::{CameraFeatures, FeatureFrame, FeatureObservation};
use estimator::geometry::Pose;
use estimator::imu::{ImuNoise, ImuSample};
use estimator::{CameraConfig, EstimatorConfig, Suite};
use nalgebra::{Matrix3, UnitQuaternion, Vector2, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::Analytic;

/// Frame period (20 Hz) and IMU period (200 Hz), ns.
pub const FRAME_NS: i64 = 50_000_000;
/// IMU period, ns.
pub const IMU_NS: i64 = 5_000_000;

/// The synthetic world.
pub struct World {
    /// Landmark positions (world).
    pub landmarks: Vec<Vector3<f64>>,
    priority: Vec<f64>,
    /// Camera model (both cameras).
    pub camera: PinholeRadtan,
    /// `T_b_c` of the left and right cameras.
    pub extrinsics: [Pose; 2],
    /// True constant biases (accelerometer, gyroscope).
    pub ba: Vector3<f64>,
    /// True gyroscope bias.
    pub bg: Vector3<f64>,
    /// IMU noise (white noise is applied; biases are held constant).
    pub noise: ImuNoise,
    /// Pixel noise σ.
    pub pixel_sigma: f64,
    /// Multiplies the IMU white noise (1 = the configured densities, 0 = noise-free).
    pub imu_noise_scale: f64,
    imu_rng: ChaCha8Rng,
    cam_rng: ChaCha8Rng,
    max_features: usize,
}

fn gauss3(rng: &mut ChaCha8Rng, s: f64) -> Vector3<f64> {
    Vector3::from_fn(|_, _| {
        let z: f64 = StandardNormal.sample(rng);
        z * s
    })
}

impl World {
    /// A room of 12 × 12 × 5 m around the trajectory with `n` landmarks on its walls, floor
    /// and ceiling.
    pub fn new(seed: u64, n: usize, pixel_sigma: f64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut landmarks = Vec::with_capacity(n);
        for _ in 0..n {
            let face = rng.random_range(0..6u32);
            let (u, v): (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let p = match face {
                0 => Vector3::new(6.0, 6.0 * u, 2.5 * v + 0.5),
                1 => Vector3::new(-6.0, 6.0 * u, 2.5 * v + 0.5),
                2 => Vector3::new(6.0 * u, 6.0, 2.5 * v + 0.5),
                3 => Vector3::new(6.0 * u, -6.0, 2.5 * v + 0.5),
                4 => Vector3::new(6.0 * u, 6.0 * v, -2.0),
                _ => Vector3::new(6.0 * u, 6.0 * v, 3.0),
            };
            landmarks.push(p);
        }
        let priority = (0..n).map(|_| rng.random_range(0.0..1.0)).collect();
        // Camera z forward = body x; camera x right = −body y; camera y down = −body z.
        let r_b_c = UnitQuaternion::from_matrix(&Matrix3::new(
            0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0,
        ));
        let extrinsics = [
            Pose::new(r_b_c, Vector3::new(0.05, 0.055, 0.0)),
            Pose::new(r_b_c, Vector3::new(0.05, -0.055, 0.0)),
        ];
        Self {
            landmarks,
            priority,
            camera: PinholeRadtan::euroc_cam0(),
            extrinsics,
            ba: Vector3::new(0.08, -0.05, 0.1),
            bg: Vector3::new(0.01, -0.015, 0.008),
            noise: ImuNoise::euroc(),
            pixel_sigma,
            imu_noise_scale: 1.0,
            imu_rng: ChaCha8Rng::seed_from_u64(seed ^ 0x1111),
            cam_rng: ChaCha8Rng::seed_from_u64(seed ^ 0x2222),
            max_features: 150,
        }
    }

    /// Estimator configuration matching this world.
    pub fn config(&self, suite: Suite) -> EstimatorConfig {
        let cams = self
            .extrinsics
            .iter()
            .map(|e| CameraConfig {
                model: Arc::new(self.camera.clone()),
                T_b_c: *e,
                pixel_sigma: self.pixel_sigma.max(0.5),
                rolling_shutter: estimator::camera::RollingShutter::GLOBAL,
            })
            .collect();
        EstimatorConfig::new(suite, cams, self.noise)
    }

    /// Noisy, biased IMU sample at `t_ns`.
    pub fn imu(&mut self, t_ns: i64) -> ImuSample {
        let s = Analytic::sample(t_ns);
        let dt = IMU_NS as f64 * 1e-9;
        let k = self.imu_noise_scale / dt.sqrt();
        let na = gauss3(
            &mut self.imu_rng,
            self.noise.accelerometer_noise_density * k,
        );
        let ng = gauss3(&mut self.imu_rng, self.noise.gyroscope_noise_density * k);
        ImuSample {
            t_ns,
            gyro: s.gyro + self.bg + ng,
            accel: s.accel + self.ba + na,
        }
    }

    /// Stereo feature frame at `t_ns`.
    pub fn frame(&mut self, t_ns: i64) -> FeatureFrame {
        let pose = Analytic::pose(t_ns);
        let mut visible: Vec<usize> = (0..self.landmarks.len())
            .filter(|&i| self.project(&pose, 0, i).is_some())
            .collect();
        visible.sort_by(|a, b| {
            self.priority[*b]
                .total_cmp(&self.priority[*a])
                .then(a.cmp(b))
        });
        visible.truncate(self.max_features);
        visible.sort();
        let mut cameras = Vec::new();
        for cam in 0..2 {
            let mut features = Vec::new();
            for &i in &visible {
                if let Some(uv) = self.project(&pose, cam, i) {
                    let noise = Vector2::new(
                        StandardNormal.sample(&mut self.cam_rng),
                        StandardNormal.sample(&mut self.cam_rng),
                    ) * self.pixel_sigma;
                    features.push(FeatureObservation {
                        feature_id: i as u64,
                        uv: uv + noise,
                    });
                }
            }
            cameras.push(CameraFeatures {
                cam_id: cam,
                features,
            });
        }
        FeatureFrame { t_ns, cameras }
    }

    fn project(&self, t_w_b: &Pose, cam: usize, i: usize) -> Option<Vector2<f64>> {
        let p_c = t_w_b
            .compose(&self.extrinsics[cam])
            .inverse()
            .transform(&self.landmarks[i]);
        if p_c.z < 0.2 || p_c.z > 20.0 {
            return None;
        }
        let uv = self.camera.project(&p_c)?;
        let margin = 2.0;
        (uv.x > margin && uv.y > margin && uv.x < 752.0 - margin && uv.y < 480.0 - margin)
            .then_some(uv)
    }
}

/// Position + yaw alignment (4 DoF) of `est` onto `gt` (paired positions); returns the aligned
/// estimate positions.
pub fn align_position_yaw(est: &[Vector3<f64>], gt: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let n = est.len() as f64;
    let ce = est.iter().sum::<Vector3<f64>>() / n;
    let cg = gt.iter().sum::<Vector3<f64>>() / n;
    let (mut s, mut c) = (0.0, 0.0);
    for (e, g) in est.iter().zip(gt) {
        let (e, g) = (e - ce, g - cg);
        s += e.x * g.y - e.y * g.x;
        c += e.x * g.x + e.y * g.y;
    }
    let yaw = s.atan2(c);
    let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw);
    est.iter().map(|e| r * (e - ce) + cg).collect()
}
