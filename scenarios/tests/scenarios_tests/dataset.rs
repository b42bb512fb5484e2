//! Dataset I/O: round trips (byte-identical, ns-exact), the EuRoC fixture, malformed inputs.

use std::path::{Path, PathBuf};

use estimator::frontend::{CameraFeatures, FeatureFrame, FeatureObservation};
use estimator::geometry::{Pose, so3_exp};
use estimator::imu::{ImuNoise, ImuSample};
use nalgebra::{UnitQuaternion, Vector2, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use scenarios::dataset::{
    CameraFrame, CameraSensor, DatasetError, EurocCamera, EurocDataset, GroundTruthState,
    ImuSensor, SensorYaml, StampedPose, format_features_csv, format_tum, parse_camera_csv,
    parse_features_csv, parse_features_csv_within, parse_groundtruth_csv, parse_imu_csv,
    parse_sensor_yaml, parse_tum, read_euroc, read_euroc_cameras, read_features_csv, read_tum,
    write_euroc, write_features_csv, write_tum,
};

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("scenarios-dataset")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures")
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

fn gauss3(rng: &mut ChaCha8Rng, s: f64) -> Vector3<f64> {
    Vector3::new(s * gauss(rng), s * gauss(rng), s * gauss(rng))
}

fn random_poses(rng: &mut ChaCha8Rng, n: usize) -> Vec<StampedPose> {
    let mut t = 1_403_636_580_838_555_648i64;
    (0..n)
        .map(|_| {
            t += 1 + (gauss(rng).abs() * 5e7) as i64; // ns-level irregular stamps
            let p = gauss3(rng, 10.0);
            let q = so3_exp(&gauss3(rng, 2.0));
            StampedPose::new(t, Pose::new(q, p))
        })
        .collect()
}

/// Asserts that the error names `file:line` (or just the file when `line` is `None`).
fn assert_names(err: &DatasetError, file: &str, line: Option<usize>) {
    let msg = err.to_string();
    match line {
        Some(l) => {
            assert!(
                msg.contains(&format!("{file}:{l}: ")),
                "`{msg}` does not name {file}:{l}"
            );
            assert_eq!(err.line(), Some(l));
        }
        None => assert!(msg.contains(file), "`{msg}` does not name {file}"),
    }
}

// ---------------------------------------------------------------------------------------------
// TUM

#[test]
fn tum_round_trip_is_byte_identical_and_ns_exact() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut poses = random_poses(&mut rng, 300);
    // Edge values: tiny and huge coordinates, exact zeros, negative time.
    poses[0].t_ns = -1_500_000_001;
    poses[0].pose.p = Vector3::new(1e-300, -0.0, 123456789012345680.0);
    poses[1].t_ns = 0;
    let dir = tmp("tum");
    let a = dir.join("a.tum");
    write_tum(&a, &poses).unwrap();
    let back = read_tum(&a).unwrap();
    assert_eq!(back.len(), poses.len());
    for (x, y) in poses.iter().zip(&back) {
        assert_eq!(x.t_ns, y.t_ns);
        assert_eq!(x.pose.p, y.pose.p);
        assert_eq!(x.pose.q.coords, y.pose.q.coords, "quaternion not bit-exact");
    }
    let b = dir.join("b.tum");
    write_tum(&b, &back).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // Timestamps are `{sec}.{nanos:09}`.
    let text = std::fs::read_to_string(&a).unwrap();
    assert!(text.lines().nth(1).unwrap().starts_with("-1.500000001 "));
    assert!(text.lines().nth(2).unwrap().starts_with("0.000000000 "));
}

#[test]
fn tum_reads_euroc_style_files_exactly() {
    let path = fixtures().join("evo/mh01/gt.tum");
    let poses = read_tum(&path).unwrap();
    assert_eq!(poses.len(), 400);
    // `1403636630.83856 4.379332 -0.456249 1.057880 -0.261626 -0.780148 -0.181344 0.538548`
    assert_eq!(poses[0].t_ns, 1_403_636_630_838_560_000);
    assert_eq!(poses[0].pose.p, Vector3::new(4.379332, -0.456249, 1.057880));
    assert!((poses[0].pose.q.w - 0.538548).abs() < 1e-5);
    assert!((poses[0].pose.q.norm() - 1.0).abs() < 1e-15);
    // Re-written and re-read: the same nanoseconds.
    let text = format_tum(&poses, &path).unwrap();
    let again = parse_tum(&text, &path).unwrap();
    assert!(
        poses
            .iter()
            .zip(&again)
            .all(|(a, b)| a.t_ns == b.t_ns && a.pose == b.pose)
    );
}

#[test]
fn tum_accepts_comments_blank_lines_crlf_and_small_quaternion_errors() {
    let text = "# header\r\n\r\n1.5 1 2 3 0 0 0 1.0004\r\n  # indented comment\n2\t1,2,3 0 0 0 1\n";
    let p = parse_tum(text, Path::new("x.tum")).unwrap();
    assert_eq!(p.len(), 2);
    assert_eq!(p[0].t_ns, 1_500_000_000);
    assert!((p[0].pose.q.norm() - 1.0).abs() < 1e-15, "renormalized");
    assert_eq!(p[1].t_ns, 2_000_000_000);
    assert_eq!(p[1].pose.q, UnitQuaternion::identity());
}

#[test]
fn tum_malformed_rows_name_file_and_line() {
    let cases: [(&str, usize, &str); 8] = [
        ("# c\n1 1 2 3 0 0 0\n", 2, "8 columns"),
        ("1 1 2 3 0 0 0 1\n2 1 2 3 0 0 0 1 9\n", 2, "8 columns"),
        ("1 1 2 NaN 0 0 0 1\n", 1, "tz"),
        ("1 1 2 3 0 0 0 1\n\n2 1 abc 3 0 0 0 1\n", 3, "ty"),
        (
            "1 1 2 3 0 0 0 1\n2 1 2 3 0 0 0 1\n1.5 1 2 3 0 0 0 1\n",
            3,
            "not increasing",
        ),
        (
            "1 1 2 3 0 0 0 1\n1.000000000 1 2 3 0 0 0 1\n",
            2,
            "not increasing",
        ),
        ("1 1 2 3 0 0 0.1 1\n", 1, "norm"),
        ("1x 1 2 3 0 0 0 1\n", 1, "timestamp"),
    ];
    for (text, line, what) in cases {
        let e = parse_tum(text, Path::new("dir/est.tum")).unwrap_err();
        assert_names(&e, "dir/est.tum", Some(line));
        assert!(
            e.to_string().contains(what),
            "`{e}` should mention `{what}`"
        );
    }
    let e = read_tum("/nonexistent/gt.tum").unwrap_err();
    assert_names(&e, "/nonexistent/gt.tum", None);
    let dir = tmp("tum-bad");
    std::fs::write(dir.join("bin.tum"), b"1 1 2 3 0 0 0 1\n\xff\xfe\n").unwrap();
    let e = read_tum(dir.join("bin.tum")).unwrap_err();
    assert_eq!(e.line(), Some(2));
}

#[test]
fn tum_writer_rejects_values_it_cannot_write() {
    let mut p = vec![StampedPose::new(0, Pose::identity()); 2];
    assert!(
        format_tum(&p, Path::new("o.tum")).is_err(),
        "equal timestamps"
    );
    p[1].t_ns = 1;
    p[1].pose.p.x = f64::NAN;
    let e = format_tum(&p, Path::new("o.tum")).unwrap_err();
    assert!(e.to_string().contains("o.tum"));
}

// ---------------------------------------------------------------------------------------------
// EuRoC

fn euroc_camera(i: usize) -> CameraSensor {
    CameraSensor {
        comment: format!("sim cam{i}: \"left\" # not a comment"),
        t_bs: Pose::new(
            so3_exp(&Vector3::new(0.01, -0.02, 1.57)),
            Vector3::new(-0.0216, -0.0647 + 0.11 * i as f64, 0.0098),
        ),
        rate_hz: 20.0,
        resolution: [752, 480],
        camera_model: "pinhole".into(),
        intrinsics: vec![458.654, 457.296, 367.215, 248.375],
        distortion_model: "radial-tangential".into(),
        distortion_coefficients: vec![-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05],
    }
}

fn assert_pose_close(a: &Pose, b: &Pose) {
    assert!((a.p - b.p).norm() < 1e-15, "{a:?} {b:?}");
    assert!(a.q.angle_to(&b.q) < 1e-12, "{a:?} {b:?}");
}

#[test]
fn euroc_write_read_round_trip() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let t0 = 1_403_636_579_758_555_392i64;
    let imu: Vec<ImuSample> = (0..400)
        .map(|k| ImuSample {
            t_ns: t0 + k * 5_000_000 + (k % 3),
            gyro: gauss3(&mut rng, 0.3),
            accel: gauss3(&mut rng, 3.0) + Vector3::new(0.0, 0.0, 9.81),
        })
        .collect();
    let groundtruth: Vec<GroundTruthState> = random_poses(&mut rng, 50)
        .into_iter()
        .map(|s| GroundTruthState {
            t_ns: s.t_ns,
            pose: s.pose,
            velocity: gauss3(&mut rng, 1.0),
            gyro_bias: gauss3(&mut rng, 0.01),
            accel_bias: gauss3(&mut rng, 0.1),
        })
        .collect();
    let frames: Vec<CameraFrame> = (0..40)
        .map(|k| CameraFrame::at(t0 + k * 50_000_000))
        .collect();
    let data = EurocDataset {
        imu,
        imu_sensor: Some(ImuSensor {
            comment: "ideal IMU".into(),
            t_bs: Pose::identity(),
            rate_hz: 200.0,
            noise: ImuNoise::euroc(),
        }),
        groundtruth,
        cameras: (0..2)
            .map(|i| EurocCamera {
                sensor: Some(euroc_camera(i)),
                frames: frames.clone(),
            })
            .collect(),
    };
    let mav0 = tmp("euroc-rt").join("mav0");
    write_euroc(&mav0, &data).unwrap();
    let back = read_euroc(&mav0).unwrap();
    // CSV data are bit-exact.
    assert_eq!(back.imu, data.imu);
    assert_eq!(back.groundtruth, data.groundtruth);
    assert_eq!(back.cameras.len(), 2);
    for (a, b) in data.cameras.iter().zip(&back.cameras) {
        assert_eq!(a.frames, b.frames);
        let (sa, sb) = (a.sensor.as_ref().unwrap(), b.sensor.as_ref().unwrap());
        // T_BS passes through a rotation matrix: equal to round-off.
        assert_pose_close(&sa.t_bs, &sb.t_bs);
        let mut sb = sb.clone();
        sb.t_bs = sa.t_bs;
        assert_eq!(sa, &sb);
    }
    let (ia, ib) = (
        data.imu_sensor.as_ref().unwrap(),
        back.imu_sensor.as_ref().unwrap(),
    );
    assert_eq!(ia.noise, ib.noise);
    assert_eq!(ia.rate_hz, ib.rate_hz);
    assert_pose_close(&ia.t_bs, &ib.t_bs);
    // The files carry the EuRoC header lines, and a second write is byte-identical.
    let imu_csv = std::fs::read_to_string(mav0.join("imu0/data.csv")).unwrap();
    assert!(imu_csv.starts_with("#timestamp [ns],w_RS_S_x [rad s^-1],"));
    let cam_csv = std::fs::read_to_string(mav0.join("cam1/data.csv")).unwrap();
    assert!(
        cam_csv
            .starts_with("#timestamp [ns],filename\n1403636579758555392,1403636579758555392.png\n")
    );
    let mav0b = tmp("euroc-rt2").join("mav0");
    write_euroc(&mav0b, &back).unwrap();
    for f in [
        "imu0/data.csv",
        "state_groundtruth_estimate0/data.csv",
        "cam0/data.csv",
    ] {
        assert_eq!(
            std::fs::read(mav0.join(f)).unwrap(),
            std::fs::read(mav0b.join(f)).unwrap(),
            "{f}"
        );
    }
}

#[test]
fn euroc_reads_the_real_file_format() {
    let d = read_euroc(fixtures().join("euroc/mav0")).unwrap();
    assert_eq!(d.imu.len(), 4);
    assert_eq!(d.imu[0].t_ns, 1_403_636_579_758_555_392);
    // The file's text `-0.099134701513277898` (more digits than an f64 holds) parses as Rust does.
    assert_eq!(
        d.imu[0].gyro.x,
        "-0.099134701513277898".parse::<f64>().unwrap()
    );
    assert_eq!(d.imu[3].accel.z, -2.4680069166666665);
    let imu = d.imu_sensor.unwrap();
    assert_eq!(
        imu.noise,
        ImuNoise::new(1.6968e-4, 2.0e-3, 1.9393e-5, 3.0e-3).unwrap()
    );
    assert_eq!(imu.rate_hz, 200.0);
    assert_eq!(imu.comment, "VI-Sensor IMU (ADIS16448)");
    assert_eq!(imu.t_bs, Pose::identity());

    assert_eq!(d.groundtruth.len(), 3);
    let g = &d.groundtruth[0];
    assert_eq!(g.t_ns, 1_403_636_580_838_555_648);
    assert_eq!(g.pose.p, Vector3::new(4.688319, -1.786938, 0.783338));
    // Column order w x y z.
    assert!((g.pose.q.w - 0.534108).abs() < 1e-5 && (g.pose.q.i + 0.153029).abs() < 1e-5);
    assert_eq!(g.velocity.z, 0.800006);
    assert_eq!(g.gyro_bias, Vector3::new(-0.003172, 0.021267, 0.078502));
    assert_eq!(g.accel_bias, Vector3::new(-0.025266, 0.136696, 0.075593));

    assert_eq!(d.cameras.len(), 1);
    let cam = &d.cameras[0];
    assert_eq!(cam.frames.len(), 3);
    assert_eq!(cam.frames[1], CameraFrame::at(1_403_636_579_813_555_456));
    let s = cam.sensor.as_ref().unwrap();
    assert_eq!(s.resolution, [752, 480]);
    assert_eq!(s.intrinsics, vec![458.654, 457.296, 367.215, 248.375]);
    assert_eq!(s.distortion_model, "radial-tangential");
    assert_eq!(s.distortion_coefficients[3], 1.76187114e-05);
    assert_eq!(s.comment, "VI-Sensor cam0 (MT9M034)");
    // T_BS: camera z (optical axis) ≈ body x, translation as in the file.
    assert!(
        (s.t_bs.p - Vector3::new(-0.0216401454975, -0.064676986768, 0.00981073058949)).norm()
            < 1e-15
    );
    let r = s.t_bs.q.to_rotation_matrix();
    assert!((r[(0, 1)] + 0.999880929698).abs() < 1e-9);
}

#[test]
fn euroc_malformed_rows_name_file_and_line() {
    let imu_header = "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
    let p = Path::new("mav0/imu0/data.csv");
    let e = parse_imu_csv(&format!("{imu_header}1,0,0,0,0,0\n"), p).unwrap_err();
    assert_names(&e, "mav0/imu0/data.csv", Some(2));
    assert!(e.to_string().contains("7 comma-separated columns"));
    let e = parse_imu_csv(&format!("{imu_header}1,0,0,0,0,0,0\n2,0,nan,0,0,0,0\n"), p).unwrap_err();
    assert_names(&e, "mav0/imu0/data.csv", Some(3));
    let e = parse_imu_csv(&format!("{imu_header}5,0,0,0,0,0,0\n4,0,0,0,0,0,0\n"), p).unwrap_err();
    assert_names(&e, "mav0/imu0/data.csv", Some(3));
    assert!(e.to_string().contains("not increasing"));
    let e = parse_imu_csv(&format!("{imu_header}1.5,0,0,0,0,0,0\n"), p).unwrap_err();
    assert!(e.to_string().contains("not an integer"));
    // Readings beyond any IMU's full scale (a corrupt value, or milli-g written as m/s²): refused
    // with the line and the column; the widest plausible readings pass.
    let e = parse_imu_csv(&format!("{imu_header}1,0,1e300,0,0,0,9.8\n"), p).unwrap_err();
    assert_names(&e, "mav0/imu0/data.csv", Some(2));
    assert!(
        e.to_string()
            .contains("w_y = 1e300 rad/s is beyond any IMU's full scale"),
        "{e}"
    );
    let e = parse_imu_csv(
        &format!("{imu_header}1,0,0,0,0,0,9806.65\n2,0,0,0,0,0,10001\n"),
        p,
    )
    .unwrap_err();
    assert_names(&e, "mav0/imu0/data.csv", Some(3));
    assert!(e.to_string().contains("a_z = 10001 m/s²"), "{e}");
    assert!(parse_imu_csv(&format!("{imu_header}1,-100,0,100,-1e4,0,1e4\n"), p).is_ok());

    let g = Path::new("gt/data.csv");
    let row = "1403636580838555648,4.688319,-1.786938,0.783338,0.534108,-0.153029,-0.827383,-0.082152,-0.027876,0.033207,0.800006,-0.003172,0.021267,0.078502,-0.025266,0.136696,0.075593";
    assert!(parse_groundtruth_csv(row, g).is_ok());
    let bad_q = row.replace(",0.534108,", ",0.6,");
    assert_names(
        &parse_groundtruth_csv(&bad_q, g).unwrap_err(),
        "gt/data.csv",
        Some(1),
    );
    let short = row.rsplit_once(',').unwrap().0;
    assert_names(
        &parse_groundtruth_csv(&format!("# h\n{short}"), g).unwrap_err(),
        "gt/data.csv",
        Some(2),
    );

    let c = Path::new("cam0/data.csv");
    assert_names(
        &parse_camera_csv("#h\n10,10.png\n10,11.png\n", c).unwrap_err(),
        "cam0/data.csv",
        Some(3),
    );
    assert_names(
        &parse_camera_csv("10\n", c).unwrap_err(),
        "cam0/data.csv",
        Some(1),
    );
    assert_names(
        &parse_camera_csv("10,\n", c).unwrap_err(),
        "cam0/data.csv",
        Some(1),
    );

    // A missing imu0/data.csv names the file.
    let mav0 = tmp("euroc-missing").join("mav0");
    std::fs::create_dir_all(&mav0).unwrap();
    let e = read_euroc(&mav0).unwrap_err();
    assert!(e.to_string().contains("imu0/data.csv"), "{e}");
}

#[test]
fn sensor_yaml_errors_name_file_and_key() {
    let good = std::fs::read_to_string(fixtures().join("euroc/mav0/cam0/sensor.yaml")).unwrap();
    let p = Path::new("cam0/sensor.yaml");
    assert!(matches!(
        parse_sensor_yaml(&good, p).unwrap(),
        SensorYaml::Camera(_)
    ));
    let e = parse_sensor_yaml(&good.replace("rate_hz: 20\n", ""), p).unwrap_err();
    assert!(
        e.to_string().contains("cam0/sensor.yaml") && e.to_string().contains("rate_hz"),
        "{e}"
    );
    let e =
        parse_sensor_yaml(&good.replace("0.0, 0.0, 0.0, 1.0]", "0.0, 0.0, 0.0]"), p).unwrap_err();
    assert_names(&e, "cam0/sensor.yaml", Some(9));
    assert!(e.to_string().contains("16 values"), "{e}");
    let e = parse_sensor_yaml(&good.replace("0.999557249008", "0.5"), p).unwrap_err();
    assert!(e.to_string().contains("not a rotation"), "{e}");
    let e = parse_sensor_yaml(&good.replace("[752, 480]", "[752, abc]"), p).unwrap_err();
    assert_names(&e, "cam0/sensor.yaml", Some(16));
    let e = parse_sensor_yaml(
        &good.replace("  data: [0.0148655429818,", "  data: 0.0148655429818,"),
        p,
    )
    .unwrap_err();
    assert!(e.to_string().contains("cam0/sensor.yaml:"), "{e}");
    let e = parse_sensor_yaml(
        "sensor_type: lidar\nT_BS:\n  data: [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]\nrate_hz: 10\n",
        p,
    )
    .unwrap_err();
    assert_names(&e, "cam0/sensor.yaml", Some(1));
    let e = parse_sensor_yaml("sensor_type: imu\n\tbad: 1\n", p).unwrap_err();
    assert_names(&e, "cam0/sensor.yaml", Some(2));
}

/// A `sensor.yaml` value outside its physical range (`sim::plausible`) is refused naming the
/// file, the line and the key, where it used to run (an accelerometer density of 2.0 to a PASS).
#[test]
fn sensor_yaml_refuses_physically_impossible_values() {
    let fix = |s: &str| std::fs::read_to_string(fixtures().join(s)).unwrap();
    let (cam, imu) = (
        fix("euroc/mav0/cam0/sensor.yaml"),
        fix("euroc/mav0/imu0/sensor.yaml"),
    );
    let p = Path::new("x/sensor.yaml");
    let cases = [
        (
            cam.replace("458.654", "4.58"),
            "intrinsics",
            "focal length 4.58 px",
        ),
        (
            cam.replace("-0.28340811", "1e6"),
            "distortion_coefficients",
            "1000000",
        ),
        (
            cam.replace("-0.0216401454975", "55.0"),
            "T_BS.data",
            "m from the body origin",
        ),
        (
            cam.replace("rate_hz: 20", "rate_hz: 0.05"),
            "rate_hz",
            "0.05 Hz",
        ),
        (
            imu.replace(
                "accelerometer_noise_density: 2.0000e-3",
                "accelerometer_noise_density: 2.0",
            ),
            "accelerometer_noise_density",
            "[1e-6, 1] m/s²/√Hz",
        ),
        (
            imu.replace(
                "gyroscope_noise_density: 1.6968e-04",
                "gyroscope_noise_density: 1e300",
            ),
            "gyroscope_noise_density",
            "not physically plausible",
        ),
    ];
    for (text, key, says) in &cases {
        let e = parse_sensor_yaml(text, p).expect_err(key).to_string();
        assert!(
            e.contains("x/sensor.yaml:") && e.contains(key) && e.contains(says),
            "{key}: {e}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// features.csv

/// `(feature_id, u, v)`.
type Obs = (u64, f64, f64);

fn frame(t_ns: i64, cams: &[(usize, &[Obs])]) -> FeatureFrame {
    FeatureFrame {
        t_ns,
        cameras: cams
            .iter()
            .map(|(cam_id, obs)| CameraFeatures {
                cam_id: *cam_id,
                features: obs
                    .iter()
                    .map(|&(feature_id, u, v)| FeatureObservation {
                        feature_id,
                        uv: Vector2::new(u, v),
                    })
                    .collect(),
            })
            .collect(),
    }
}

#[test]
fn features_csv_round_trip() {
    let frames = vec![
        frame(
            100,
            &[
                (0, &[(1, 10.25, 20.5), (7, 0.1 + 0.2, 479.0)]),
                (1, &[(1, 3.0, 4.0)]),
            ],
        ),
        frame(150, &[(1, &[(2, -0.5, 1e-7)])]),
        frame(200, &[(0, &[(u64::MAX, 751.999, 0.0)])]),
    ];
    let dir = tmp("features");
    let f = dir.join("features.csv");
    write_features_csv(&f, &frames).unwrap();
    let text = std::fs::read_to_string(&f).unwrap();
    assert!(text.starts_with("t_ns,cam_id,feature_id,u,v\n100,0,1,10.25,20.5\n"));
    assert_eq!(read_features_csv(&f).unwrap(), frames);
    // Byte-identical second write.
    assert_eq!(
        format_features_csv(&read_features_csv(&f).unwrap(), &f).unwrap(),
        text
    );
}

#[test]
fn features_csv_malformed_rows_name_file_and_line() {
    let p = Path::new("out/features.csv");
    let h = "t_ns,cam_id,feature_id,u,v\n";
    let cases: [(String, usize); 6] = [
        (format!("{h}1,0,1,2\n"), 2),
        (format!("{h}1,0,1,2,NaN\n"), 2),
        (format!("{h}1,-1,1,2,3\n"), 2),
        (format!("{h}2,0,1,2,3\n1,0,1,2,3\n"), 3),
        (format!("{h}1,0,5,2,3\n1,0,5,2,3\n"), 3),
        (format!("{h}1,0,1,2,3\n1,1,1,2,3\n1,0,2,2,3\n"), 4),
    ];
    for (text, line) in cases {
        let e = parse_features_csv(&text, p).unwrap_err();
        assert_names(&e, "out/features.csv", Some(line));
    }
    // With the cameras' image sizes known, a pixel far outside its image is refused as
    // written; rows of a camera the run does not use are not judged.
    let sizes = [[752, 480]];
    for (text, line) in [
        (format!("{h}1,0,1,2,3\n1,0,2,1e9,3\n"), 3),
        (format!("{h}1,0,1,-40,3\n"), 2),
        (format!("{h}1,0,1,2,481.5\n"), 2),
    ] {
        let e = parse_features_csv_within(&text, p, &sizes).unwrap_err();
        assert_names(&e, "out/features.csv", Some(line));
        assert!(e.to_string().contains("outside camera 0"), "{e}");
    }
    let edge = format!("{h}1,0,1,-0.5,479.9\n1,1,1,5000,3\n");
    assert_eq!(
        parse_features_csv_within(&edge, p, &sizes).unwrap().len(),
        1
    );
}

#[test]
fn stamps_whose_differences_would_wrap_are_refused_naming_the_line() {
    let p = Path::new("mav0/imu0/data.csv");
    let h = "#timestamp [ns],w_x,w_y,w_z,a_x,a_y,a_z\n";
    let ok = format!("{h}1403715273262142976,0,0,0,0,0,9.8\n");
    assert_eq!(parse_imu_csv(&ok, p).unwrap().len(), 1);
    for (text, line) in [
        (format!("{h}-9223372036854775808,0,0,0,0,0,9.8\n"), 2),
        (format!("{ok}9223372036854775807,0,0,0,0,0,9.8\n"), 3),
    ] {
        let e = parse_imu_csv(&text, p).unwrap_err();
        assert_names(&e, "mav0/imu0/data.csv", Some(line));
        assert!(e.to_string().contains("64 bits"), "{e}");
    }
    let e =
        parse_camera_csv("#timestamp [ns],filename\n5000000000000000000,a.png\n", p).unwrap_err();
    assert!(e.to_string().contains("64 bits"), "{e}");
}

#[test]
fn parsers_never_panic_on_garbage() {
    // Random lines from the characters these formats are made of: errors, never panics.
    let alphabet: Vec<char> = "0123456789.,-+e #\n\r\t[]:\"'\\nanNaN_xyzT_BSdatasensor_typeé"
        .chars()
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let p = Path::new("garbage");
    for n in 0..3000 {
        let len = n % 120;
        let text: String = (0..len)
            .map(|_| alphabet[(gauss(&mut rng).abs() * 1e6) as usize % alphabet.len()])
            .collect();
        for t in [
            text.clone(),
            format!("sensor_type: camera\nT_BS:\n  data: [{text}]\n"),
        ] {
            let _ = parse_tum(&t, p);
            let _ = parse_imu_csv(&t, p);
            let _ = parse_groundtruth_csv(&t, p);
            let _ = parse_camera_csv(&t, p);
            let _ = parse_features_csv(&t, p);
            let _ = parse_sensor_yaml(&t, p);
        }
    }
}

/// A copy of the EuRoC fixture's `mav0` in a fresh folder.
fn fixture_copy(name: &str) -> PathBuf {
    let mav0 = tmp(name).join("mav0");
    let src = fixtures().join("euroc/mav0");
    for sub in ["cam0", "imu0", "state_groundtruth_estimate0"] {
        std::fs::create_dir_all(mav0.join(sub)).unwrap();
        for f in std::fs::read_dir(src.join(sub)).unwrap() {
            let f = f.unwrap().path();
            std::fs::copy(&f, mav0.join(sub).join(f.file_name().unwrap())).unwrap();
        }
    }
    mav0
}

#[test]
fn empty_files_are_errors_a_bom_is_not_data_and_unused_camera_folders_are_not_read() {
    let good = read_euroc(fixtures().join("euroc/mav0")).unwrap();
    assert!(!good.groundtruth.is_empty());

    // A 0-byte or header-only file is an error naming it, not an absent file.
    for (file, what) in [
        (
            "state_groundtruth_estimate0/data.csv",
            "no ground-truth rows",
        ),
        ("imu0/data.csv", "no IMU samples"),
    ] {
        for (tag, text) in [("empty", String::new()), ("header", "#t,a,b\n".to_string())] {
            let mav0 = fixture_copy(&format!("empty-{tag}-{}", file.replace('/', "-")));
            std::fs::write(mav0.join(file), text).unwrap();
            let e = read_euroc(&mav0).unwrap_err().to_string();
            assert!(e.contains(file) && e.contains(what), "{file} {tag}: {e}");
        }
    }

    // A byte-order mark before the header (spreadsheet exports) reads the same data.
    let mav0 = fixture_copy("bom");
    for file in [
        "imu0/data.csv",
        "state_groundtruth_estimate0/data.csv",
        "cam0/data.csv",
    ] {
        let text = std::fs::read_to_string(mav0.join(file)).unwrap();
        std::fs::write(mav0.join(file), format!("\u{feff}{text}")).unwrap();
    }
    assert_eq!(read_euroc(&mav0).unwrap(), good);

    // A stray cam1/ without data.csv: a run using one camera does not read it.
    let mav0 = fixture_copy("stray-camera");
    std::fs::create_dir_all(mav0.join("cam1")).unwrap();
    let e = read_euroc(&mav0).unwrap_err().to_string();
    assert!(e.contains("cam1/data.csv"), "{e}");
    assert_eq!(read_euroc_cameras(&mav0, 1).unwrap(), good);
}

#[test]
fn a_run_on_images_refuses_a_camera_that_lists_none_naming_its_file() {
    use scenarios::pipeline::{RunInput, run_to_report};
    use scenarios::run::{EurocOptions, RunControl, RunOptions};
    use scenarios::spec::SuiteSpec;
    let mav0 = fixture_copy("no-images");
    std::fs::write(mav0.join("cam0/data.csv"), "#timestamp [ns],filename\n").unwrap();
    let input = RunInput::Euroc {
        mav0: &mav0,
        options: &EurocOptions::new(SuiteSpec::MonoImu),
    };
    let e = match run_to_report(input, &RunOptions::default(), RunControl::default()) {
        Ok(_) => panic!("a camera without images was run"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("cam0/data.csv") && e.contains("lists no images"),
        "{e}"
    );
}
