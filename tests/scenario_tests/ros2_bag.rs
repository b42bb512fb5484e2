//! ROS 2 bags (MCAP) round trip: a scenario exported with `vio export --format mcap` and run
//! through `vio bag`'s pipeline gives the estimate `vio run` gives, from the rendered images
//! (image front end) and from the bag's feature tracks; GNSS fixes and wheel readings land on
//! their topics; bad bags name the file and the topic; `run.mcap` holds the run for viewers.
//!
//! The rendered case needs Mesa's llvmpipe (`bash .ci/install-deps`).

use std::path::{Path, PathBuf};

use crate::common;
use scenarios::dataset::ros2::{
    BagFile, CompressedImage, NavSatFix, PointCloud2, PoseArray, PoseStamped,
    PoseWithCovarianceStamped, TfMessage, TwistStamped, Vector3Stamped,
};
use scenarios::export::{GNSS_ORIGIN, export_bag};
use scenarios::pipeline::{ReportedRun, RunInput, run_to_report};
use scenarios::run::{BagOptions, EurocOptions, RunControl, RunError, RunOptions};
use scenarios::spec::Scenario;

/// Both runs last this long (s).
const SECONDS: f64 = 4.0;

fn options(scenario: &Scenario) -> BagOptions {
    BagOptions {
        settings: Some(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("scenarios/catalog")
                .join(format!("{}.toml", scenario.name)),
        ),
        ..BagOptions::new(scenario.spec.suite)
    }
}

fn bag_run(path: &Path, options: &BagOptions, seed: u64) -> Result<ReportedRun, RunError> {
    bag_run_with(path, options, seed, false)
}

/// [`bag_run`], recording the window for `run.mcap` when `scene`.
fn bag_run_with(
    path: &Path,
    options: &BagOptions,
    seed: u64,
    scene: bool,
) -> Result<ReportedRun, RunError> {
    let run = RunOptions {
        seed: Some(seed),
        scene,
        ..Default::default()
    };
    run_to_report(RunInput::Bag { path, options }, &run, RunControl::default())
}

/// Exports `scenario` for [`SECONDS`] as a bag in `dir`.
fn export(scenario: &Scenario, dir: &Path) -> PathBuf {
    let path = dir.join(format!("{}.mcap", scenario.name));
    let options = RunOptions {
        duration_s: Some(SECONDS),
        ..Default::default()
    };
    export_bag(scenario, &options, &path).unwrap();
    path
}

/// The same estimates, pose for pose, and the same ATE to 1e-6 m: `vio run` scores each
/// estimate against the simulator's truth at its time, `vio bag` against the bag's 200 Hz poses
/// interpolated there, and the estimated time offset puts estimates up to a few ms off the
/// samples (measured: 3e-8 m on 4 s of the figure-eight; against the same samples, in `vio
/// euroc`, the ATEs agree to 1e-9 m, below).
fn assert_same_run(run: &ReportedRun, bag: &ReportedRun) {
    let poses = |r: &ReportedRun| {
        r.output
            .frames
            .iter()
            .map(|f| (f.estimate.t_ns, f.estimate.T_w_b.p, f.estimate.T_w_b.q))
            .collect::<Vec<_>>()
    };
    assert!(run.output.frames.len() > 50);
    assert_eq!(poses(run), poses(bag));
    let (a, b) = (
        run.report.ate_rmse_m.unwrap(),
        bag.report.ate_rmse_m.unwrap(),
    );
    assert!((a - b).abs() < 1e-6, "ATE vio run {a} vs vio bag {b}");
    // A ground truth of poses: no bias errors (unknown, not zero).
    assert!(bag.report.gyro_bias_error_rad_s.is_none());
}

#[test]
fn a_rendered_bag_through_vio_bag_gives_the_run_of_vio_run() {
    let scenario = Scenario::load("room_figure8_rendered_stereo_imu").unwrap();
    let dir = common::scratch();
    let path = export(&scenario, dir.path());
    let expected = common::run_scenario(scenario.clone(), Some(SECONDS));
    // With run.mcap's window recorded: the estimate is the same.
    let got = bag_run_with(&path, &options(&scenario), scenario.spec.world.seed, true).unwrap();
    assert_same_run(&expected.run, &got);
    assert_eq!(got.report.camera_mode, "recorded");
    assert!(got.report.timing_ms.frontend.median > 0.0);
    // Its tracks pictures are drawn over the bag's images.
    let out = dir.path().join("bag-run");
    got.write_outputs(&out).unwrap();
    assert_tracks_over_images(&out.join("run.mcap"), got.output.frames.len());
}

/// Every `/cam0/tracks` picture of the run bag at `path` (one per estimate, `frames`) is a JPEG
/// of the camera's size drawn over its image: unlike the flat background of feature-level runs
/// (`(24, 24, 24)` wherever no track is drawn, most of the picture), grey levels vary across it.
fn assert_tracks_over_images(path: &Path, frames: usize) {
    let bag = BagFile::open(path).unwrap();
    let tracks = bag
        .contents()
        .unwrap()
        .decode_all::<CompressedImage>("/cam0/tracks")
        .unwrap();
    assert_eq!(tracks.len(), frames);
    for (_, msg) in tracks.iter().step_by(10) {
        assert_eq!(msg.format, "jpeg");
        let picture = image::load_from_memory(&msg.data).unwrap().into_rgb8();
        assert_eq!(picture.dimensions(), (752, 480));
        // Grey pixels (no stroke): their levels spread like the camera image's, dimmed.
        let grey: Vec<f64> = picture
            .pixels()
            .filter(|p| p.0[0].abs_diff(p.0[1]) < 8 && p.0[1].abs_diff(p.0[2]) < 8)
            .map(|p| f64::from(p.0[1]))
            .collect();
        assert!(grey.len() > picture.len() / 3 / 2, "mostly strokes?");
        let mean = grey.iter().sum::<f64>() / grey.len() as f64;
        let sd = (grey.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / grey.len() as f64).sqrt();
        assert!(
            sd > 10.0 && mean > 30.0,
            "flat background: mean {mean}, sd {sd}"
        );
    }
}

#[test]
fn a_rendered_runs_tracks_pictures_are_drawn_over_its_images() {
    let scenario = Scenario::load("room_figure8_rendered_stereo_imu").unwrap();
    let options = RunOptions {
        duration_s: Some(2.0),
        scene: true,
        ..Default::default()
    };
    let viewed = common::run_with(scenario, &options);
    let dir = common::scratch();
    viewed.run.write_outputs(dir.path()).unwrap();
    assert_tracks_over_images(&dir.path().join("run.mcap"), viewed.run.output.frames.len());
}

#[test]
fn a_bags_feature_tracks_give_the_run_of_vio_run() {
    let scenario = Scenario::load("room_figure8_stereo_imu").unwrap();
    let dir = common::scratch();
    let path = export(&scenario, dir.path());
    let expected = common::run_scenario(scenario.clone(), Some(SECONDS));
    let opts = BagOptions {
        features_topic: Some("/features".into()),
        ..options(&scenario)
    };
    let got = bag_run(&path, &opts, scenario.spec.world.seed).unwrap();
    assert_same_run(&expected.run, &got);
    // The rig from the bag's own camera infos and /tf_static: the same estimates.
    let from_info = BagOptions {
        camera_info: true,
        ..opts.clone()
    };
    let info = bag_run(&path, &from_info, scenario.spec.world.seed).unwrap();
    assert_same_run(&expected.run, &info);

    // The ASL export of the same run through `vio euroc`: the same ground-truth samples, the
    // same ATE to 1e-9 m.
    let asl = dir.path().join("asl");
    let export_options = RunOptions {
        duration_s: Some(SECONDS),
        ..Default::default()
    };
    scenarios::export::export(&scenario, &export_options, &asl).unwrap();
    let euroc = EurocOptions {
        features: Some(asl.join("features.csv")),
        settings: opts.settings.clone(),
        ..EurocOptions::new(scenario.spec.suite)
    };
    let run = RunOptions {
        seed: Some(scenario.spec.world.seed),
        ..Default::default()
    };
    let mav0 = asl.join("mav0");
    let from_asl = run_to_report(
        RunInput::Euroc {
            mav0: &mav0,
            options: &euroc,
        },
        &run,
        RunControl::default(),
    )
    .unwrap();
    let (a, b) = (
        from_asl.report.ate_rmse_m.unwrap(),
        got.report.ate_rmse_m.unwrap(),
    );
    assert!((a - b).abs() < 1e-9, "ATE vio euroc {a} vs vio bag {b}");
}

#[test]
fn gnss_fixes_and_wheel_readings_land_on_their_topics() {
    let dir = common::scratch();
    let gnss = export(
        &Scenario::load("outdoor_figure8_gnss_stereo_imu").unwrap(),
        dir.path(),
    );
    let file = BagFile::open(&gnss).unwrap();
    let bag = file.contents().unwrap();
    let fixes = bag.decode_all::<NavSatFix>("/gnss/fix").unwrap();
    assert!(fixes.len() >= 4, "{} fixes", fixes.len());
    for (t, f) in &fixes {
        // About the documented origin (1e-3° of latitude ≈ 111 m), stamped as logged.
        assert!((f.latitude - GNSS_ORIGIN.0).abs() < 5e-3, "{}", f.latitude);
        assert!(
            (f.longitude - GNSS_ORIGIN.1).abs() < 5e-3,
            "{}",
            f.longitude
        );
        assert!((f.altitude - GNSS_ORIGIN.2).abs() < 100.0, "{}", f.altitude);
        assert_eq!(f.position_covariance_type, 2);
        assert!(f.position_covariance[0] > 0.0);
        assert_eq!(f.header.stamp.to_ns(), Some(*t as i64));
    }
    assert!(bag.decode_all::<TwistStamped>("/wheel/twist").is_err());

    let wheel = export(
        &Scenario::load("hall_ground_vehicle_wheel_mono_imu").unwrap(),
        dir.path(),
    );
    let file = BagFile::open(&wheel).unwrap();
    let readings = file
        .contents()
        .unwrap()
        .decode_all::<TwistStamped>("/wheel/twist")
        .unwrap();
    assert!(readings.len() >= 10, "{} readings", readings.len());
    assert!(readings.iter().any(|(_, r)| r.twist.linear.x > 0.1));
}

#[test]
fn bad_bags_name_the_file_and_the_topic() {
    let scenario = Scenario::load("room_figure8_stereo_imu").unwrap();
    let dir = common::scratch();
    let path = export(&scenario, dir.path());
    let opts = BagOptions {
        features_topic: Some("/features".into()),
        ..options(&scenario)
    };
    let err = |o: &BagOptions, p: &Path| bag_run(p, o, 1).unwrap_err().to_string();
    // A topic the bag does not have: the topics it has.
    let e = err(
        &BagOptions {
            imu_topic: "/imu".into(),
            ..opts.clone()
        },
        &path,
    );
    assert!(
        e.contains("no topic /imu") && e.contains("/imu0 (sensor_msgs/msg/Imu)"),
        "{e}"
    );
    // A topic of another type.
    let e = err(
        &BagOptions {
            imu_topic: "/groundtruth/pose".into(),
            ..opts.clone()
        },
        &path,
    );
    assert!(
        e.contains("carries geometry_msgs/msg/PoseStamped, expected sensor_msgs/msg/Imu"),
        "{e}"
    );
    // Images the bag does not have (a feature-level scenario).
    let e = err(&options(&scenario), &path);
    assert!(e.contains("no topic /cam0/image_raw"), "{e}");
    // A truncated file.
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = err(&opts, &cut);
    assert!(
        e.contains("cut.mcap") && e.contains("not a readable MCAP file"),
        "{e}"
    );
    // No rig: neither attached nor given.
    let e = err(
        &BagOptions {
            camchain: Some(dir.path().join("missing.yaml")),
            ..opts.clone()
        },
        &path,
    );
    assert!(e.contains("missing.yaml"), "{e}");
}

#[test]
fn run_mcap_holds_the_run_for_viewers_and_changes_nothing_else() {
    let scenario = Scenario::load("room_figure8_stereo_imu").unwrap();
    let plain = common::run_scenario(scenario.clone(), Some(SECONDS));
    let options = RunOptions {
        duration_s: Some(SECONDS),
        covariance: true,
        scene: true,
        ..Default::default()
    };
    let viewed = common::run_with(scenario, &options);
    let dir = common::scratch();
    let (a, b) = (dir.path().join("plain"), dir.path().join("viewed"));
    plain.run.write_outputs(&a).unwrap();
    viewed.run.write_outputs(&b).unwrap();
    // The same estimate; run.mcap only where asked.
    assert_eq!(
        std::fs::read(a.join("estimate.tum")).unwrap(),
        std::fs::read(b.join("estimate.tum")).unwrap()
    );
    assert!(!a.join("run.mcap").exists());

    let file = BagFile::open(&b.join("run.mcap")).unwrap();
    let bag = file.contents().unwrap();
    let frames = viewed.run.output.frames.len();
    let poses = bag.decode_all::<PoseStamped>("/estimate/pose").unwrap();
    assert_eq!(poses.len(), frames);
    assert_eq!(
        bag.decode_all::<PoseStamped>("/groundtruth/pose")
            .unwrap()
            .len(),
        frames
    );
    let tf = bag.decode_all::<TfMessage>("/tf").unwrap();
    assert_eq!(tf.len(), frames);
    assert_eq!(tf[0].1.transforms[0].child_frame_id, "body");
    // The window: frames and persistent points once it tracks.
    let points = bag.decode_all::<PointCloud2>("/window/points").unwrap();
    assert!(points.iter().any(|(_, p)| p.width >= 10), "no points");
    let window = bag.decode_all::<PoseArray>("/window/poses").unwrap();
    assert!(window.iter().any(|(_, w)| w.poses.len() >= 5));
    // The trails: the estimates and the truth so far as points, the last one all of them.
    for (topic, truth) in [("/estimate/trail", false), ("/groundtruth/trail", true)] {
        let trails = bag.decode_all::<PointCloud2>(topic).unwrap();
        // Every 0.2 s of the estimates' span, and the last.
        let span_s = (poses[frames - 1].0 - poses[0].0) as f64 * 1e-9;
        assert!(
            trails.len() > (span_s / 0.2) as usize,
            "{topic} {} {span_s}",
            trails.len()
        );
        assert!(
            trails.len() <= (span_s / 0.2) as usize + 2,
            "{topic} {} {span_s}",
            trails.len()
        );
        let (_, last) = trails.last().unwrap();
        assert_eq!(last.width as usize, frames, "{topic}");
        for (i, (_, pose)) in poses.iter().enumerate().step_by(17) {
            let expected = if truth {
                let p = viewed.run.output.frames[i].truth.pose.p;
                [p.x, p.y, p.z]
            } else {
                let p = &pose.pose.position;
                [p.x, p.y, p.z]
            };
            let at = |k: usize| {
                let b = &last.data[12 * i + 4 * k..12 * i + 4 * k + 4];
                f64::from(f32::from_le_bytes(b.try_into().unwrap()))
            };
            for k in 0..3 {
                assert!((at(k) - expected[k]).abs() < 1e-6, "{topic} point {i}");
            }
        }
    }
    // The tracks picture: one PNG per estimate, of the first camera's size, on a flat
    // background (feature-level input has no images).
    let tracks = bag.decode_all::<CompressedImage>("/cam0/tracks").unwrap();
    assert_eq!(tracks.len(), frames);
    let (_, last) = tracks.last().unwrap();
    assert_eq!(last.format, "png");
    let png = image::load_from_memory(&last.data).unwrap().into_rgb8();
    assert_eq!((png.width(), png.height()), (752, 480));
    let flat = png.pixels().filter(|p| p.0 == [24, 24, 24]).count();
    assert!(flat > png.len() / 3 / 2);
    // Covariances: symmetric, positive on the diagonal.
    let cov = bag
        .decode_all::<PoseWithCovarianceStamped>("/estimate/pose_with_covariance")
        .unwrap();
    assert!(cov.len() + 2 >= frames);
    for (_, c) in &cov {
        let m = c.pose.covariance;
        for i in 0..6 {
            assert!(m[i][i] > 0.0);
            for k in 0..6 {
                assert!((m[i][k] - m[k][i]).abs() <= 1e-9 * (m[i][i] * m[k][k]).sqrt());
            }
        }
    }
    // The position error is the aligned estimate less the truth: its RMS is the ATE.
    let errors = bag
        .decode_all::<Vector3Stamped>("/estimate/position_error")
        .unwrap();
    let ate = viewed.run.report.ate_rmse_m.unwrap();
    let evaluated = &viewed.run.evaluation.evaluated;
    let rms = (evaluated
        .iter()
        .map(|&i| {
            let v = errors[i].1.vector;
            v.x * v.x + v.y * v.y + v.z * v.z
        })
        .sum::<f64>()
        / evaluated.len() as f64)
        .sqrt();
    assert!(
        (rms - ate).abs() < 1e-9 * ate.max(1.0),
        "{rms} vs ATE {ate}"
    );
}
