//! The `[estimator]` and `[camera.tracker]` tables embed the estimator crate's own
//! configuration types: every setting is reachable from a scenario file, unset keys (nested
//! ones included) keep the crate's defaults, and a bad value or a misspelt key names its key
//! and line.

use crate::common;

use common::default_text;
use estimator::EstimatorConfig;
use estimator::frontend::TrackerConfig;
use estimator::problem::Method;
use scenarios::spec::{Origin, Scenario, SpecError};

fn parse(text: &str) -> Result<Scenario, SpecError> {
    Scenario::parse("settings", Origin::Catalog, text)
}

fn with_table(table: &str, body: &str) -> String {
    default_text(2.0) + "\n[" + table + "]\n" + body + "\n"
}

#[test]
fn every_estimator_setting_is_reachable_and_unset_keys_keep_the_defaults() {
    let defaults = EstimatorConfig::settings_default();
    // The whole serialized default table, written into the scenario, parses back to the same
    // settings: every field has a key (a field the schema could not reach would be refused).
    let full = toml::to_string(&defaults).unwrap();
    assert!(
        full.contains("[solver]") && full.contains("[health]"),
        "{full}"
    );
    let text = default_text(2.0)
        + &full
            .replace("[solver]", "[estimator.solver]")
            .replace("[health]", "[estimator.health]")
            .replace("[zero_velocity]", "[estimator.zero_velocity]")
            .replace("[gnss]", "[estimator.gnss]")
            .replace("[wheel]", "[estimator.wheel]")
            .replacen("", "[estimator]\n", 1);
    let mut cfg = parse(&text).unwrap().estimator_config().unwrap();
    // The rig's IMU has datasheet ranges; `imu_range` takes them where the file leaves it unset.
    assert_eq!(cfg.imu_range, Some((5.235987756, 176.58)));
    cfg.imu_range = None;
    assert_eq!(
        toml::to_string(&cfg).unwrap(),
        full,
        "a full table must round-trip"
    );

    // One nested key changes that key only: the rest of `solver` keeps the window's defaults
    // (function tolerance 1e-2, trust radius 1e12), not `SolverOptions::default()`'s.
    let text = with_table(
        "estimator.solver",
        "max_iterations = 7\nmethod = \"dogleg\"",
    );
    let cfg = parse(&text).unwrap().estimator_config().unwrap();
    assert_eq!(cfg.solver.max_iterations, 7);
    assert_eq!(cfg.solver.method, Method::Dogleg);
    assert_eq!(
        cfg.solver.function_tolerance,
        defaults.solver.function_tolerance
    );
    assert_eq!(
        cfg.solver.initial_trust_radius,
        defaults.solver.initial_trust_radius
    );
    assert_eq!(cfg.window_size, defaults.window_size);

    // Settings the old field-by-field schema could not reach.
    let text = with_table(
        "estimator",
        "gauge_sigma = 1e-3\ncompute_covariance = true\nimu_spike_threshold = [2.0, 20.0]\n\
         min_tracking_observations = 25\nhealth = { max_jump_m = 2.0 }\npixel_sigma_px = 1.5",
    );
    let cfg = parse(&text).unwrap().estimator_config().unwrap();
    assert_eq!(cfg.gauge_sigma, 1e-3);
    assert!(cfg.compute_covariance);
    assert_eq!(cfg.imu_spike_threshold, Some((2.0, 20.0)));
    assert_eq!(cfg.min_tracking_observations, 25);
    assert_eq!(cfg.health.max_jump_m, 2.0);
    assert_eq!(
        cfg.health.max_gyro_bias_rad_s,
        defaults.health.max_gyro_bias_rad_s
    );
    assert_eq!(cfg.pixel_sigma_px, Some(1.5));
    // The rig still comes from `[rig]`.
    assert_eq!(cfg.cameras.len(), 2);
}

#[test]
fn estimator_errors_name_the_key_and_line() {
    let cases = [
        ("window_size = 1000", "estimator.window_size", "3 to 100"),
        // Below the default `init_frames` (10): the initialization would never run.
        (
            "window_size = 8",
            "estimator.window_size",
            "set window_size ≥ init_frames",
        ),
        (
            "window_size = \"ten\"",
            "estimator.window_size",
            "invalid type",
        ),
        (
            "windows_size = 10",
            "estimator",
            "unknown field `windows_size`",
        ),
        ("td_s = nan", "estimator.td_s", "NaN"),
        (
            "startup_window_size = 101",
            "estimator.startup_window_size",
            "3 to 100",
        ),
        (
            "startup_window_s = -1.0",
            "estimator.startup_window_s",
            "≥ 0",
        ),
        ("gauge_sigma = -1.0", "estimator.gauge_sigma", "> 0"),
        (
            "min_depth_m = 50.0\nmax_depth_m = 10.0",
            "estimator.min_depth_m",
            "below max_depth_m",
        ),
        (
            "solver = { max_iterations = 0 }",
            "estimator.solver.max_iterations",
            "1 to 1000",
        ),
        (
            "solver = { method = \"gauss_newton\" }",
            "estimator.solver.method",
            "unknown variant",
        ),
        (
            "health = { max_jump = 1.0 }",
            "estimator.health",
            "unknown field `max_jump`",
        ),
        ("suite = \"stereo\"", "estimator", "unknown field `suite`"),
    ];
    let base_lines = default_text(2.0).lines().count();
    for (body, key, what) in cases {
        let e = parse(&with_table("estimator", body)).unwrap_err();
        assert!(e.key.starts_with(key), "{body}: key {} ({e})", e.key);
        assert!(e.message.contains(what), "{body}: {e}");
        // `[estimator]` sits on line base + 2; the key on the next line.
        let line = e.line.unwrap_or_else(|| panic!("{body}: no line in {e}"));
        assert!(
            (base_lines + 2..=base_lines + 4).contains(&line),
            "{body}: line {line} (table at {})",
            base_lines + 2
        );
    }
}

#[test]
fn tracker_settings_embed_the_front_end_config() {
    let text = with_table("camera.tracker", "max_features = 90\nequalize = true");
    let s = parse(&text).unwrap();
    // Feature-level: no tracker runs; the settings are still parsed and checked.
    assert!(s.tracker_config(3).unwrap().is_none());
    let text = text.replace(
        "[camera.tracker]",
        "[camera]\nmode = \"rendered\"\n[camera.tracker]",
    );
    let cfg = parse(&text).unwrap().tracker_config(3).unwrap().unwrap();
    let d = TrackerConfig::default();
    assert_eq!((cfg.max_features, cfg.equalize, cfg.seed), (90, true, 3));
    assert_eq!(cfg.window_px, d.window_px);
    assert_eq!(cfg.ransac_threshold_px, d.ransac_threshold_px);

    let e = parse(&with_table("camera.tracker", "window_pix = 21")).unwrap_err();
    assert!(e.message.contains("unknown field `window_pix`"), "{e}");
    let e = parse(&with_table("camera.tracker", "seed = 5")).unwrap_err();
    assert!(e.message.contains("unknown field `seed`"), "{e}");
}

#[test]
fn vio_settings_prints_tables_a_scenario_accepts() {
    let out = common::vio(&["settings", "room_figure8_rendered_stereo_imu"]);
    assert!(out.status.success());
    let printed = String::from_utf8(out.stdout).unwrap();
    for table in [
        "[estimator]",
        "[estimator.solver]",
        "[estimator.health]",
        "[camera.tracker]",
        "[camera.render]",
        "[camera.photometric]",
    ] {
        assert!(printed.contains(table), "{table} missing:\n{printed}");
    }
    assert!(printed.contains("max_iterations = 4"), "{printed}");
    // Pasted into a scenario with a changed value, the tables parse and the change arrives.
    let pasted = printed
        .replace(
            "[camera.tracker]",
            "[camera]\nmode = \"rendered\"\n[camera.tracker]",
        )
        .replace("window_size = 10", "window_size = 12")
        .replace("vignetting = 0.0", "vignetting = 0.25")
        .replace("msaa = false", "msaa = true");
    assert!(pasted.contains("vignetting = 0.25") && pasted.contains("msaa = true"));
    let s = parse(&(default_text(2.0) + &pasted)).unwrap();
    assert_eq!(s.estimator_config().unwrap().window_size, 12);
    assert!(s.tracker_config(1).unwrap().is_some());
    let render = s.render_config().unwrap().unwrap();
    assert!(render.msaa);
    assert_eq!(render.photometric.vignetting, 0.25);
    let out = common::vio(&["settings", "no-such-scenario"]);
    assert_eq!(out.status.code(), Some(2));
}
