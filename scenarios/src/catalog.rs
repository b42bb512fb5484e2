//! The built-in scenario catalog: `scenarios/catalog/*.toml` and their data files, embedded in
//! the binary so that `vio run NAME` works from any directory.

/// A built-in scenario.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    /// Name (the file stem).
    pub name: &'static str,
    /// The TOML text.
    pub text: &'static str,
}

/// The scenario `vio run` runs without an argument.
pub const DEFAULT: &str = "room_figure8_stereo_imu";

macro_rules! entry {
    ($name:literal) => {
        Entry {
            name: $name,
            text: include_str!(concat!("../catalog/", $name, ".toml")),
        }
    };
}

const ENTRIES: &[Entry] = &[
    entry!("room_figure8_stereo_imu"),
    entry!("room_figure8_stereo"),
    entry!("room_circle_stereo_imu"),
    entry!("room_replay_v2_02_stereo_imu"),
    entry!("room_replay_v2_02_glitchy_stereo_imu"),
    entry!("room_figure8_mono_imu"),
    entry!("room_replay_v2_02_mono_imu"),
    entry!("room_replay_v1_01_mono_imu"),
    entry!("room_figure8_blackout_stereo_imu"),
    entry!("room_figure8_left_camera_death_stereo_imu"),
    entry!("room_figure8_right_camera_death_stereo_imu"),
    entry!("room_figure8_imu_spikes_stereo_imu"),
    entry!("room_figure8_blackout_2s_stereo_imu"),
    entry!("room_figure8_freeze_2s_stereo_imu"),
    entry!("room_figure8_left_camera_freeze_stereo_imu"),
    entry!("room_figure8_blackout_10s_stereo_imu"),
    entry!("room_figure8_imu_dropout_short_stereo_imu"),
    entry!("room_figure8_imu_dropout_stereo_imu"),
    entry!("room_figure8_frame_drops_stereo_imu"),
    entry!("room_figure8_time_offset_stereo_imu"),
    entry!("room_replay_v1_01_time_offset_stereo_imu"),
    entry!("room_replay_v1_01_real_imu_stereo_imu"),
    entry!("room_replay_v1_01_real_imu_matched_stereo_imu"),
    entry!("euroc_mh_01_realistic_stereo"),
    entry!("euroc_mh_01_realistic_mono_imu"),
    entry!("euroc_mh_01_realistic_stereo_imu"),
    entry!("euroc_v1_01_realistic_stereo"),
    entry!("euroc_v1_01_realistic_mono_imu"),
    entry!("euroc_v1_01_realistic_stereo_imu"),
    entry!("euroc_v1_01_realistic_features_stereo_imu"),
    entry!("euroc_v2_02_realistic_stereo"),
    entry!("euroc_v2_02_realistic_mono_imu"),
    entry!("euroc_v2_02_realistic_stereo_imu"),
    entry!("room_replay_v1_01_fitted_imu_stereo_imu"),
    entry!("room_replay_v1_01_datasheet_imu_stereo_imu"),
    entry!("room_fast_rotation_imu_saturation_stereo_imu"),
    entry!("room_figure8_stops_stereo_imu"),
    entry!("room_figure8_calibration_stereo_imu"),
    entry!("room_lissajous_calibration_stereo_imu"),
    entry!("outdoor_figure8_stereo_imu"),
    entry!("outdoor_figure8_gnss_stereo_imu"),
    entry!("outdoor_figure8_gnss_outage_stereo_imu"),
    entry!("outdoor_figure8_gnss_bias_jump_stereo_imu"),
    entry!("hall_ground_vehicle_stereo_imu"),
    entry!("hall_ground_vehicle_wheel_stereo_imu"),
    entry!("hall_ground_vehicle_wheel_slip_stereo_imu"),
    entry!("hall_ground_vehicle_mono_imu"),
    entry!("hall_ground_vehicle_wheel_mono_imu"),
    entry!("room_figure8_rendered_stereo_imu"),
    entry!("room_figure8_left_camera_death_rendered"),
    entry!("room_figure8_blackout_2s_rendered"),
    entry!("room_figure8_exposure_jump_rendered"),
    entry!("room_figure8_blur_rendered"),
    entry!("room_fast_rotation_rendered"),
    entry!("hall_poor_wall_rendered"),
    entry!("room_replay_v2_02_rendered"),
];

/// Data files the catalog scenarios reference, by their path relative to `catalog/` (bytes: a
/// recording may carry a comment that is not UTF-8).
const DATA: &[(&str, &[u8])] = &[
    (
        "data/euroc_V2_02_medium_20s.txt",
        include_bytes!("../catalog/data/euroc_V2_02_medium_20s.txt"),
    ),
    (
        "data/euroc_V2_02_medium_20s_glitchy.txt",
        include_bytes!("../catalog/data/euroc_V2_02_medium_20s_glitchy.txt"),
    ),
    (
        "data/euroc_V1_01_easy_20s.txt",
        include_bytes!("../catalog/data/euroc_V1_01_easy_20s.txt"),
    ),
    (
        "data/euroc_MH_01_easy_50hz.txt",
        include_bytes!("../catalog/data/euroc_MH_01_easy_50hz.txt"),
    ),
    (
        "data/euroc_V2_02_medium_100hz.txt",
        include_bytes!("../catalog/data/euroc_V2_02_medium_100hz.txt"),
    ),
    (
        "data/euroc_V1_01_easy_excerpt/mav0/state_groundtruth_estimate0/data.csv",
        include_bytes!(
            "../catalog/data/euroc_V1_01_easy_excerpt/mav0/state_groundtruth_estimate0/data.csv"
        ),
    ),
    (
        "data/euroc_V1_01_easy_excerpt/mav0/imu0/data.csv",
        include_bytes!("../catalog/data/euroc_V1_01_easy_excerpt/mav0/imu0/data.csv"),
    ),
];

/// Built-in IMU error models (`rig.imu.error_model = "<name>"`), each a file in
/// `catalog/imu_models/`.
const IMU_ERROR_MODELS: &[(&str, &str)] = &[(
    "euroc_mav",
    include_str!("../catalog/imu_models/euroc_mav.toml"),
)];

/// The text of `name` in a table of named files.
fn named(table: &[(&'static str, &'static str)], name: &str) -> Option<&'static str> {
    table.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The names of a table of named files.
fn names_in(table: &[(&'static str, &'static str)]) -> Vec<&'static str> {
    table.iter().map(|(n, _)| *n).collect()
}

/// A built-in IMU error model's text by name.
pub fn imu_error_model(name: &str) -> Option<&'static str> {
    named(IMU_ERROR_MODELS, name)
}

/// The names of the built-in IMU error models.
pub fn imu_error_model_names() -> Vec<&'static str> {
    names_in(IMU_ERROR_MODELS)
}

/// Built-in estimator IMU noise models (`estimator.imu_noise = "<name>"`), each a file in
/// `catalog/estimator_imu_noise/` written by `vio imu-model --gt`.
const ESTIMATOR_IMU_NOISE: &[(&str, &str)] = &[(
    "euroc_mav",
    include_str!("../catalog/estimator_imu_noise/euroc_mav.toml"),
)];

/// A built-in estimator IMU noise model's text by name.
pub fn estimator_imu_noise(name: &str) -> Option<&'static str> {
    named(ESTIMATOR_IMU_NOISE, name)
}

/// The names of the built-in estimator IMU noise models.
pub fn estimator_imu_noise_names() -> Vec<&'static str> {
    names_in(ESTIMATOR_IMU_NOISE)
}

/// Built-in tracker error models (`rig.cameras[i].tracker_error = "<name>"`), each a file in
/// `catalog/tracker_error/` fitted by the run summary's `tracker error` line.
const TRACKER_ERRORS: &[(&str, &str)] = &[(
    "euroc_rendered",
    include_str!("../catalog/tracker_error/euroc_rendered.toml"),
)];

/// A built-in tracker error model's text by name.
pub fn tracker_error(name: &str) -> Option<&'static str> {
    named(TRACKER_ERRORS, name)
}

/// The names of the built-in tracker error models.
pub fn tracker_error_names() -> Vec<&'static str> {
    names_in(TRACKER_ERRORS)
}

/// Built-in IMU models (`[rig.imu] preset = "<name>"`), each a partial `[rig.imu]` in
/// `catalog/sensors/imu/` with its sources.
const IMU_PRESETS: &[(&str, &str)] = &[
    (
        "adis16448",
        include_str!("../catalog/sensors/imu/adis16448.toml"),
    ),
    ("bmi160", include_str!("../catalog/sensors/imu/bmi160.toml")),
];

/// A built-in IMU model's text by name.
pub fn imu_preset(name: &str) -> Option<&'static str> {
    named(IMU_PRESETS, name)
}

/// The names of the built-in IMU models.
pub fn imu_preset_names() -> Vec<&'static str> {
    names_in(IMU_PRESETS)
}

/// Built-in camera modules (`[[rig.cameras]] preset = "<name>"`), each a partial camera
/// entry in `catalog/sensors/camera/` with its sources.
const CAMERA_PRESETS: &[(&str, &str)] = &[
    (
        "mt9v034_euroc",
        include_str!("../catalog/sensors/camera/mt9v034_euroc.toml"),
    ),
    (
        "ueye_tum_rs_1280",
        include_str!("../catalog/sensors/camera/ueye_tum_rs_1280.toml"),
    ),
    (
        "ueye_tum_vi_512",
        include_str!("../catalog/sensors/camera/ueye_tum_vi_512.toml"),
    ),
];

/// A built-in camera module's text by name.
pub fn camera_preset(name: &str) -> Option<&'static str> {
    named(CAMERA_PRESETS, name)
}

/// The names of the built-in camera modules.
pub fn camera_preset_names() -> Vec<&'static str> {
    names_in(CAMERA_PRESETS)
}

/// Built-in estimator adapters (`estimator_adapter = "<name>"`), each a file in
/// `catalog/estimators/` whose scripts are in the source tree (`tools/peer/`).
const ESTIMATOR_ADAPTERS: &[(&str, &str)] = &[
    (
        "openvins-images",
        include_str!("../catalog/estimators/openvins-images.toml"),
    ),
    (
        "openvins-tracks",
        include_str!("../catalog/estimators/openvins-tracks.toml"),
    ),
];

/// A built-in estimator adapter's text by name.
pub fn estimator_adapter(name: &str) -> Option<&'static str> {
    named(ESTIMATOR_ADAPTERS, name)
}

/// The names of the built-in estimator adapters.
pub fn estimator_adapter_names() -> Vec<&'static str> {
    names_in(ESTIMATOR_ADAPTERS)
}

/// Built-in sensor presets (`preset = "<name>"`), each a partial scenario in
/// `catalog/presets/`.
const PRESETS: &[(&str, &str)] = &[(
    "euroc_realistic",
    include_str!("../catalog/presets/euroc_realistic.toml"),
)];

/// A built-in preset's text by name.
pub fn preset(name: &str) -> Option<&'static str> {
    named(PRESETS, name)
}

/// The names of the built-in presets.
pub fn preset_names() -> Vec<&'static str> {
    names_in(PRESETS)
}

/// Every built-in scenario, the default first.
pub fn entries() -> &'static [Entry] {
    ENTRIES
}

/// The built-in scenario `name`.
pub fn get(name: &str) -> Option<&'static Entry> {
    ENTRIES.iter().find(|e| e.name == name)
}

/// The names of the built-in scenarios.
pub fn names() -> Vec<&'static str> {
    ENTRIES.iter().map(|e| e.name).collect()
}

/// What to tell someone who asked for `name` among `known` (scenario names, preset names…):
/// the closest known name when one is close (Jaro–Winkler similarity ≥ 0.85, the `strsim`
/// crate's, as clap's own suggestions), else all of them.
pub fn closest_hint<S: AsRef<str>>(name: &str, known: &[S]) -> String {
    let best = known
        .iter()
        .map(|k| (strsim::jaro_winkler(name, k.as_ref()), k.as_ref()))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    match best {
        Some((score, k)) if score >= 0.85 => {
            format!("did you mean `{k}`? ({} known: `vio list`)", known.len())
        }
        _ => {
            let all: Vec<&str> = known.iter().map(AsRef::as_ref).collect();
            format!("known: {}", all.join(", "))
        }
    }
}

/// An embedded data file by its path relative to `catalog/`, as text (bytes that are not
/// UTF-8 replaced).
pub fn data(path: &str) -> Option<String> {
    let path = path.strip_prefix("./").unwrap_or(path);
    DATA.iter()
        .find(|(p, _)| *p == path)
        .map(|(_, t)| String::from_utf8_lossy(t).into_owned())
}

#[cfg(test)]
mod tests {
    use crate::spec::Scenario;

    /// A misspelt name gets the one close name, not the whole list; a name like none of them
    /// gets the list.
    #[test]
    fn a_misspelt_name_is_answered_with_the_closest() {
        let names = super::names();
        let hint = super::closest_hint("room_figure8_stereo_im", &names);
        assert!(
            hint.contains("did you mean `room_figure8_stereo_imu`?"),
            "{hint}"
        );
        assert!(!hint.contains("outdoor"), "{hint}");
        let hint = super::closest_hint("zzzz", &["alpha", "beta"]);
        assert_eq!(hint, "known: alpha, beta");
        let e = Scenario::load("euroc_v1_01_realistic_stereo_im")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("did you mean `euroc_v1_01_realistic_stereo_imu`?"),
            "{e}"
        );
    }

    #[test]
    fn every_catalog_scenario_parses_and_builds() {
        for e in super::entries() {
            let s = Scenario::load(e.name).unwrap_or_else(|err| panic!("{err}"));
            s.world_config(None, Some(1.0))
                .unwrap_or_else(|err| panic!("{err}"));
            s.estimator_config().unwrap_or_else(|err| panic!("{err}"));
        }
        assert_eq!(super::entries()[0].name, super::DEFAULT);
    }
}
