//! Rendered scenarios: rendering adds images without changing any other measurement (with
//! `frontend = "truth"` the estimate is byte-identical to the feature-level run), reports its
//! adapter and timing, exports images in the EuRoC layout, and rejects bad render settings and
//! bad tracker settings naming the key; a mono suite on a stereo rig tracks one camera.
//!
//! Needs Mesa's llvmpipe (`bash .ci/install-deps`).

use crate::common;

use scenarios::report;
use scenarios::run::RunOptions;
use scenarios::spec::{Origin, Scenario};

fn catalog_text(name: &str) -> String {
    std::fs::read_to_string(format!(
        "{}/scenarios/catalog/{name}.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

/// The rendered default scenario with the simulator's ideal tracks instead of the front end.
fn rendered_with_ideal_tracks() -> Scenario {
    let text = catalog_text("room_figure8_rendered_stereo_imu").replace(
        "mode = \"rendered\"",
        "mode = \"rendered\"\nfrontend = \"truth\"",
    );
    Scenario::parse(
        "rendered_truth",
        Origin::File("rendered_truth.toml".into()),
        &text,
    )
    .unwrap()
}

fn estimate_bytes(name: &str, seconds: f64) -> (Vec<u8>, report::Report) {
    let scenario = Scenario::load(name).unwrap();
    scenario_bytes(&scenario, seconds)
}

fn scenario_bytes(scenario: &Scenario, seconds: f64) -> (Vec<u8>, report::Report) {
    let done = common::run_scenario(scenario.clone(), Some(seconds));
    let dir = common::written(&done);
    let bytes = std::fs::read(dir.path().join("estimate.tum")).unwrap();
    let json = std::fs::read_to_string(dir.path().join("report.json")).unwrap();
    assert!(
        json.contains("\"camera_mode\""),
        "report.json lacks camera_mode"
    );
    (bytes, done.run.report)
}

/// Mono+IMU on the rendered default scenario's stereo rig: the front end tracks the first
/// camera only (the second camera's images used to stop the run: "image for camera 1, but the
/// rig has 1 camera(s)"), the window initializes and converges. Measured over 20 s (seed 1):
/// tracking 280 of 401 frames (initialized at 6 s), ATE 0.0143 m; over 60 s 0.0105 m.
#[test]
fn rendered_mono_imu_tracks_the_first_camera_of_a_stereo_rig() {
    let text = catalog_text("room_figure8_rendered_stereo_imu")
        .replace("suite = \"stereo_imu\"", "suite = \"mono_imu\"");
    assert!(text.contains("suite = \"mono_imu\""));
    let scenario = Scenario::parse(
        "rendered_mono",
        Origin::File("rendered_mono.toml".into()),
        &text,
    )
    .unwrap();
    let (_, rep) = scenario_bytes(&scenario, 20.0);
    assert!(
        rep.tracking_frames >= 250,
        "tracking {} of {} frames",
        rep.tracking_frames,
        rep.frames
    );
    let ate = rep.ate_rmse_m.expect("an ATE");
    assert!(ate < 0.025, "ATE {ate}");
}

#[test]
fn rendering_changes_no_measurement_and_reports_its_adapter_and_timing() {
    let (plain, plain_rep) = estimate_bytes("room_figure8_stereo_imu", 3.0);
    let (rendered, rep) = scenario_bytes(&rendered_with_ideal_tracks(), 3.0);
    assert!(plain.len() > 500);
    assert!(plain == rendered, "rendering changed the estimate");
    assert_eq!(plain_rep.camera_mode, "features");
    assert!(plain_rep.timing_ms.render.is_none());
    assert_eq!(rep.camera_mode, "rendered");
    let adapter = rep.renderer.as_deref().expect("adapter recorded");
    assert!(!adapter.is_empty());
    let render = rep.timing_ms.render.expect("render timing");
    assert!(render.median > 0.0 && render.max >= render.median);
}

#[test]
fn export_writes_rendered_images_in_the_euroc_layout() {
    let scenario = Scenario::load("room_figure8_rendered_stereo_imu").unwrap();
    let dir = common::scratch();
    let dir = dir.path();
    let options = RunOptions {
        seed: None,
        duration_s: Some(0.2),
        ..Default::default()
    };
    let s = scenarios::export::export(&scenario, &options, dir).unwrap();
    assert_eq!(s.frames, 5);
    assert_eq!(s.images, 10);
    for cam in 0..2 {
        let csv = std::fs::read_to_string(dir.join(format!("mav0/cam{cam}/data.csv"))).unwrap();
        let names: Vec<&str> = csv
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| l.split(',').nth(1).unwrap().trim())
            .collect();
        assert_eq!(names.len(), 5);
        for n in names {
            let img = image::open(dir.join(format!("mav0/cam{cam}/data/{n}"))).unwrap();
            assert_eq!((img.width(), img.height()), (752, 480));
        }
    }
}

#[test]
fn bad_render_settings_name_the_key_and_line() {
    let text = catalog_text("room_figure8_rendered_stereo_imu")
        .replace("vignetting = 0.25", "vignetting = 1.5");
    let err = Scenario::parse("bad", Origin::File("bad.toml".into()), &text).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("camera.photometric.vignetting"), "{msg}");
    assert!(err.line.is_some(), "{msg}");
    let painted = text.replace("mode = \"rendered\"", "mode = \"painted\"");
    assert!(painted != text);
    let err = Scenario::parse("bad", Origin::File("bad.toml".into()), &painted).unwrap_err();
    assert!(err.to_string().contains("camera.mode"), "{err}");
    // Feature-level scenarios check their render settings too (`vio render` uses them).
    let features = text.replace("mode = \"rendered\"", "mode = \"features\"");
    let err = Scenario::parse("bad", Origin::File("bad.toml".into()), &features).unwrap_err();
    assert!(
        err.to_string().contains("camera.photometric.vignetting"),
        "{err}"
    );
    let blur = text
        .replace(
            "[camera.render]\n",
            "[camera.render]\nmotion_blur = { exposure_s = 100.0, samples = 4 }\n",
        )
        .replace("vignetting = 1.5", "vignetting = 0.2");
    let err = Scenario::parse("bad", Origin::File("bad.toml".into()), &blur).unwrap_err();
    assert!(
        err.to_string().contains("camera.render.motion_blur"),
        "{err}"
    );
}

#[test]
fn bad_tracker_settings_name_the_key() {
    let base = catalog_text("room_figure8_rendered_stereo_imu");
    for (setting, key) in [
        ("window_px = 20", "camera.tracker.window_px"),
        ("max_features = 0", "camera.tracker.max_features"),
        ("flow_back_px = nan", "camera.tracker.flow_back_px"),
        (
            "ransac_confidence = 1.5",
            "camera.tracker.ransac_confidence",
        ),
    ] {
        let text = base.replace(
            "[camera.photometric]",
            &format!("[camera.tracker]\n{setting}\n\n[camera.photometric]"),
        );
        let err = Scenario::parse("bad", Origin::File("bad.toml".into()), &text).unwrap_err();
        assert!(err.to_string().contains(key), "{setting}: {err}");
    }
    let text = base.replace(
        "mode = \"rendered\"",
        "mode = \"rendered\"\nfrontend = \"orb\"",
    );
    let err = Scenario::parse("bad", Origin::File("bad.toml".into()), &text).unwrap_err();
    assert!(err.to_string().contains("camera.frontend"), "{err}");
}
