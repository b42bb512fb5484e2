//! The scenario file schema (TOML) and its mapping onto [`sim::WorldConfig`] and
//! [`estimator::EstimatorConfig`].
//!
//! A scenario file describes one run: the world (scene preset, seed), the trajectory (a generator
//! or a replayed ground-truth file), the sensor rig (cameras and IMU), the sensor suite the
//! estimator fuses, optional estimator settings, a fault timeline and the expectations `vio run`
//! checks. Every table rejects unknown keys, so a typo is an error rather than a silently ignored
//! setting. The built-in scenarios in `scenarios/catalog/` are the reference examples; a minimal
//! file looks like this:
//!
//! ```toml
//! description = "Stereo+IMU, a 20 s figure-eight in the room"
//! suite = "stereo_imu"            # or "stereo", "mono_imu" (the first camera and the IMU)
//!
//! [world]
//! scene = "room"
//! seed = 1
//!
//! [trajectory]
//! duration_s = 20.0
//! figure_eight = { center = [-0.5, 0.5, 1.5], half_width_m = 2.0, half_height_m = 1.0, period_s = 20.0 }
//!
//! [rig]
//! rate_hz = 20.0
//!
//! [[rig.cameras]]
//! model = "pinhole_radtan"
//! resolution = [752, 480]
//! intrinsics = [458.654, 457.296, 367.215, 248.375]
//! distortion = [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
//! T_b_c = { translation_m = [0.0, 0.055, 0.0], rotation = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]] }
//! pixel_sigma_px = 1.0
//!
//! [[rig.cameras]]
//! model = "pinhole_radtan"
//! resolution = [752, 480]
//! intrinsics = [458.654, 457.296, 367.215, 248.375]
//! distortion = [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
//! T_b_c = { translation_m = [0.0, -0.055, 0.0], rotation = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]] }
//! pixel_sigma_px = 1.0
//!
//! [rig.imu]
//! rate_hz = 200.0
//! gyroscope_noise_density = 1.6968e-4
//! accelerometer_noise_density = 2.0e-3
//! gyroscope_random_walk = 1.9393e-5
//! accelerometer_random_walk = 3.0e-3
//!
//! [expectations]
//! ate_rmse_m = { max = 0.1 }
//! ```
//!
//! Errors ([`SpecError`]) name the file, the key path (`rig.cameras[1].intrinsics`), the line
//! when it is known, and what was expected.

//!
//! The module is split by concern: [`schema`] holds the serde types as written, `validate` the
//! checks every file passes before anything runs, `mapping` the translation onto the simulator's
//! and the estimator's configurations, and [`error`] the error type and the key/line lookups.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use estimator::EstimatorConfig;
use estimator::camera::CameraModel;
use estimator::frontend::{TrackerConfig, TrackerError};
use sim::motion::Replay;
use sim::motion::recording::RecordingReport;
use sim::render::{RenderConfig, RenderError};

use crate::catalog;

mod calibration_draw;
mod calibration_truth;
mod camera_schema;
mod dotted_key;
pub mod error;
pub mod estimator_adapter;
pub(crate) mod estimator_imu_noise;
pub(crate) mod exact;
pub mod imu_error_model;
pub mod key_listing;
mod mapping;
mod named_model;
pub(crate) mod overlay;
mod preset;
mod recorded_imu;
pub mod schema;
mod sensor_preset;
mod tracker_error_model;
pub mod units;
mod validate;

pub use calibration_draw::DrawnCalibrationError;
pub use calibration_truth::CalibrationTruth;
pub use dotted_key::{parse_setting, set_key};
pub use error::SpecError;
pub use estimator_adapter::{AdapterInput, AdapterValues, EstimatorAdapter};
pub use imu_error_model::{ImuErrorModel, ImuErrorModelSpec};
pub use recorded_imu::RecordedImuLog;
pub use schema::*;

/// Where a scenario came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Origin {
    /// A built-in catalog scenario (its data files are embedded too).
    Catalog,
    /// A file on disk; relative data paths resolve against its directory.
    File(PathBuf),
    /// A catalog scenario that a file on disk builds on (a sweep over a catalog scenario,
    /// this being the sweep file): a data path the catalog embeds reads as
    /// [`Origin::Catalog`], any other resolves against this file's directory.
    CatalogBeside(PathBuf),
}

/// A parsed, validated scenario.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Name: the catalog name or the file stem.
    pub name: String,
    /// Where it came from.
    pub origin: Origin,
    /// The parsed file.
    pub spec: ScenarioSpec,
    /// The file's text (kept for line lookups in later errors).
    text: String,
    /// The `[estimator]` settings laid over the estimator's defaults (no rig yet).
    settings: EstimatorConfig,
    /// The `[camera.tracker]` settings laid over the front end's defaults (seed unset).
    tracker: TrackerConfig,
    /// The `[camera.render]` settings laid over the renderer's defaults, `[camera.photometric]`
    /// over their `photometric` part.
    render: RenderConfig,
    /// The camera models, built once: the simulator and the estimator share these.
    models: Vec<Arc<dyn CameraModel>>,
    /// A replayed recording, read, checked and fitted once (`trajectory.replay`).
    recording: Option<Arc<(Replay, RecordingReport)>>,
    /// A recorded IMU log on the replay's clock, read and checked once (`rig.imu.recorded`).
    recorded_imu: Option<Arc<RecordedImuLog>>,
    /// The simulated IMU's error model, read and checked once (`rig.imu.error_model`).
    imu_error_model: Option<Arc<ImuErrorModel>>,
    /// The outside estimator it runs, read and checked once (`estimator_adapter`); `None`: ours.
    adapter: Option<Arc<EstimatorAdapter>>,
}

impl Scenario {
    /// Loads a catalog scenario by name, or else a `.toml` file by path.
    pub fn load(name_or_path: &str) -> Result<Self, SpecError> {
        if let Some(entry) = catalog::get(name_or_path) {
            return Self::parse(entry.name, Origin::Catalog, entry.text);
        }
        let path = Path::new(name_or_path);
        if path.extension().is_some_and(|e| e == "toml") || path.exists() {
            return Self::from_file(path);
        }
        Err(SpecError {
            file: name_or_path.into(),
            key: String::new(),
            line: None,
            message: format!(
                "no catalog scenario of that name and no such file: {}",
                catalog::closest_hint(name_or_path, &catalog::names())
            ),
        })
    }

    /// Catalog scenario `name` with its text changed by `edit` (a study's variant, a test's
    /// twist), parsed as the catalog scenario of that name.
    pub fn catalog_edited(
        name: &str,
        edit: impl FnOnce(&str) -> String,
    ) -> Result<Self, SpecError> {
        let entry = catalog::get(name).ok_or_else(|| SpecError {
            file: name.into(),
            key: String::new(),
            line: None,
            message: format!(
                "no catalog scenario of that name: {}",
                catalog::closest_hint(name, &catalog::names())
            ),
        })?;
        Self::parse(entry.name, Origin::Catalog, &edit(entry.text))
    }

    /// Reads and parses a scenario file.
    pub fn from_file(path: &Path) -> Result<Self, SpecError> {
        let text = sim::input_file::read_to_string(path).map_err(|e| SpecError {
            file: path.display().to_string(),
            key: String::new(),
            line: None,
            message: format!("cannot read the scenario file: {e}"),
        })?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        Self::parse(&name, Origin::File(path.to_path_buf()), &text)
    }

    /// Parses scenario text; `origin` resolves relative data paths and names the file in errors.
    pub fn parse(name: &str, origin: Origin, text: &str) -> Result<Self, SpecError> {
        let file = origin.label(name);
        match kalibr_expansion(&file, &origin, text)? {
            None => Self::parse_expanded(name, origin, text, &file),
            Some((expanded, sources)) => Self::parse_expanded(name, origin, &expanded, &file)
                .map_err(|e| sources.relocate(e)),
        }
    }

    /// [`Scenario::parse`] of the text with any Kalibr tables already appended.
    fn parse_expanded(
        name: &str,
        origin: Origin,
        text: &str,
        file: &str,
    ) -> Result<Self, SpecError> {
        let file = file.to_string();
        let expanded = preset::expand(text, &file)?;
        let spec: ScenarioSpec = match sensor_preset::expand(expanded, &origin, text, &file)? {
            None => error::deserialize_toml(text, &file)?,
            Some(merged) => error::deserialize_table(merged, text, &file)?,
        };
        let (settings, tracker) = overlay::estimator_and_tracker(
            &spec.estimator,
            &spec.camera.tracker,
            &origin,
            text,
            &file,
        )?;
        let mut render = overlay::overlay(
            &RenderConfig::default(),
            &spec.camera.render,
            "camera.render",
            text,
            &file,
        )?;
        render.photometric = overlay::overlay(
            &render.photometric,
            &spec.camera.photometric,
            "camera.photometric",
            text,
            &file,
        )?;
        let s = Self {
            name: name.into(),
            origin,
            spec,
            text: text.into(),
            settings,
            tracker,
            render,
            models: Vec::new(),
            recording: None,
            recorded_imu: None,
            imu_error_model: None,
            adapter: None,
        };
        s.validate()?;
        let models = (0..s.spec.rig.cameras.len())
            .map(|i| s.camera_model(i))
            .collect::<Result<_, _>>()?;
        let s = Self { models, ..s };
        s.validate_estimator_config()?;
        let recording = s.load_recording()?.map(Arc::new);
        let s = Self { recording, ..s };
        let recorded_imu = s.load_recorded_imu()?.map(Arc::new);
        let s = Self { recorded_imu, ..s };
        let imu_error_model = s.load_imu_error_model()?.map(Arc::new);
        let s = Self {
            imu_error_model,
            ..s
        };
        s.validate_free_space()?;
        let adapter = s.load_estimator_adapter()?.map(Arc::new);
        Ok(Self { adapter, ..s })
    }

    /// The effective settings as TOML: `[estimator]` (the rig's cameras and IMU noise left
    /// out), `[camera.tracker]`, `[camera.render]` and `[camera.photometric]`, every key a
    /// scenario may set in them with this scenario's value (`vio settings`).
    pub fn settings_toml(&self) -> Result<String, SpecError> {
        fn table<T: serde::Serialize>(
            s: &Scenario,
            key: &str,
            v: &T,
        ) -> Result<toml::Table, SpecError> {
            toml::Table::try_from(v)
                .map_err(|e| s.error(key, format!("cannot write the settings: {e}")))
        }
        let mut render = table(self, "camera.render", &self.render)?;
        let photometric = render.remove("photometric");
        let mut camera = toml::Table::new();
        camera.insert(
            "tracker".into(),
            table(self, "camera.tracker", &self.tracker)?.into(),
        );
        camera.insert("render".into(), render.into());
        if let Some(p) = photometric {
            camera.insert("photometric".into(), p);
        }
        let mut root = toml::Table::new();
        root.insert(
            "estimator".into(),
            table(self, "estimator", &self.estimator_config()?)?.into(),
        );
        root.insert("camera".into(), camera.into());
        toml::to_string(&root).map_err(|e| self.error("estimator", e.to_string()))
    }

    /// The renderer configuration of a rendered scenario (`None` for feature-level ones).
    pub fn render_config(&self) -> Result<Option<RenderConfig>, SpecError> {
        let cfg = self.render_settings()?;
        Ok((self.spec.camera.mode == CameraMode::Rendered).then_some(cfg))
    }

    /// The scenario's rendering settings whatever its mode (`vio render` uses them for
    /// feature-level scenarios too); validated, errors name the key.
    pub fn render_settings(&self) -> Result<RenderConfig, SpecError> {
        let cfg = self.render.clone();
        cfg.validate().map_err(|e| {
            let key = match &e {
                RenderError::Field { field, .. } if field.starts_with("photometric.") => {
                    format!("camera.{field}")
                }
                RenderError::Field { field, .. } => format!("camera.render.{field}"),
                _ => "camera".into(),
            };
            self.error(&key, e.to_string())
        })?;
        Ok(cfg)
    }

    /// The image front end's configuration when the estimator should track the rendered images
    /// (`mode = "rendered"` and `frontend = "klt"`); `None` otherwise.
    pub fn tracker_config(&self, seed: u64) -> Result<Option<TrackerConfig>, SpecError> {
        let c = &self.spec.camera;
        let cfg = TrackerConfig {
            seed,
            ..self.tracker
        };
        cfg.validate().map_err(|e| match e {
            TrackerError::Config { field, message } => {
                self.error(&format!("camera.tracker.{field}"), message)
            }
            e => self.error("camera.tracker", e.to_string()),
        })?;
        Ok((c.mode == CameraMode::Rendered && c.frontend == FrontendSpec::Klt).then_some(cfg))
    }

    /// What the checks of a replayed recording found and did (`None` for generated motions).
    pub fn recording_report(&self) -> Option<&RecordingReport> {
        self.recording.as_ref().map(|r| &r.1)
    }

    /// File time (s) of a replayed recording's first sample: simulation time 0 (`None` for
    /// generated motions).
    pub fn recording_start_s(&self) -> Option<f64> {
        self.recording.as_ref().map(|r| r.0.t_file0)
    }

    /// [`Scenario::recording_start_s`] in ns: the shift from the recording's clock to the run's.
    /// Exact (the file's own stamp) with a recorded IMU log on an EuRoC ASL ground truth, else
    /// rounded to the ns.
    pub fn recording_start_ns(&self) -> Option<i64> {
        match &self.recorded_imu {
            Some(r) => Some(r.shift_ns),
            None => self.recording_start_s().map(|t0| (t0 * 1e9).round() as i64),
        }
    }

    /// The outside estimator this scenario runs (`estimator_adapter`); `None`: ours.
    pub fn adapter(&self) -> Option<&EstimatorAdapter> {
        self.adapter.as_deref()
    }

    /// The name errors use for the file.
    pub fn file_label(&self) -> String {
        self.origin.label(&self.name)
    }

    /// An error at `key`, with the key's line.
    pub fn error(&self, key: &str, message: impl Into<String>) -> SpecError {
        SpecError::at(&self.file_label(), &self.text, key, message)
    }
}

/// With `rig.kalibr`, the scenario text with the Kalibr files' `[[rig.cameras]]` and
/// `[rig.imu]` tables appended (the original lines keep their numbers); `None` without it.
fn kalibr_expansion(
    file: &str,
    origin: &Origin,
    text: &str,
) -> Result<Option<(String, KalibrSources)>, SpecError> {
    let Ok(table) = text.parse::<toml::Table>() else {
        return Ok(None); // the deserializer reports the syntax error with its line
    };
    let Some(rig) = table.get("rig").and_then(|r| r.as_table()) else {
        return Ok(None);
    };
    let Some(k) = rig.get("kalibr").and_then(|k| k.as_table()) else {
        return Ok(None);
    };
    let err = |key: &str, m: String| SpecError::at(file, text, key, m);
    let path_of = |key: &str| -> Result<Option<String>, SpecError> {
        match k.get(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) => Ok(Some(s.clone())),
            Some(_) => Err(err(
                &format!("rig.kalibr.{key}"),
                "expected a file path".into(),
            )),
        }
    };
    let read = |key: &str, rel: &str| -> Result<(String, String), SpecError> {
        let text = origin
            .read(rel)
            .map_err(|m| err(&format!("rig.kalibr.{key}"), m))?;
        Ok((text, origin.path_of(rel).display().to_string()))
    };
    let kalibr_err = |e: crate::dataset::kalibr::KalibrError| SpecError {
        file: e.file,
        key: e.key,
        line: e.line,
        message: e.message,
    };
    let sigma = match k.get("pixel_sigma_px") {
        None => 1.0,
        Some(v) => v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .ok_or_else(|| err("rig.kalibr.pixel_sigma_px", "expected a number".into()))?,
    };
    let mut out = text.trim_end().to_string() + "\n";
    let Some(camchain) = path_of("camchain")? else {
        return Err(err("rig.kalibr", "missing `camchain`".into()));
    };
    if rig.get("cameras").is_some() {
        return Err(err(
            "rig.cameras",
            "`rig.kalibr.camchain` gives the cameras: remove the [[rig.cameras]] entries".into(),
        ));
    }
    let (t, name) = read("camchain", &camchain)?;
    out.push_str(&crate::dataset::kalibr::cameras_toml(&t, &name, sigma).map_err(kalibr_err)?);
    let mut sources = KalibrSources {
        camchain: (name, t),
        imu: None,
    };
    if let Some(imu) = path_of("imu")? {
        if rig.get("imu").is_some() {
            return Err(err(
                "rig.imu",
                "`rig.kalibr.imu` gives the IMU: remove [rig.imu] (or `kalibr.imu`)".into(),
            ));
        }
        let (t, name) = read("imu", &imu)?;
        out.push_str(&crate::dataset::kalibr::imu_toml(&t, &name).map_err(kalibr_err)?);
        sources.imu = Some((name, t));
    }
    Ok(Some((out, sources)))
}

/// The Kalibr files a scenario's rig came from: `(file, text)` of each.
struct KalibrSources {
    camchain: (String, String),
    imu: Option<(String, String)>,
}

impl KalibrSources {
    /// An error about a key the Kalibr files gave, pointed at the Kalibr file's line and key
    /// with the value as written there (the appended tables' lines are in no file).
    fn relocate(&self, e: SpecError) -> SpecError {
        let imu = self.imu.as_ref().map(|(_, t)| t.as_str());
        match crate::dataset::kalibr::locate(&self.camchain.1, imu, &e.key) {
            Some((key, line, value)) => {
                let file = if e.key.starts_with("rig.imu") {
                    self.imu.as_ref().map_or(&self.camchain.0, |(f, _)| f)
                } else {
                    &self.camchain.0
                };
                SpecError {
                    file: file.clone(),
                    key,
                    line: Some(line),
                    message: format!("`{value}` as written: {} (as `{}`)", e.message, e.key),
                }
            }
            None => e,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::error::line_of_key;
    use super::*;

    fn default_text() -> &'static str {
        catalog::get(catalog::DEFAULT).unwrap().text
    }

    #[test]
    fn key_lines_are_found_down_to_array_elements() {
        let text = default_text();
        let line = |needle: &str| text.lines().position(|l| l.contains(needle)).unwrap() + 1;
        assert_eq!(line_of_key(text, "world.seed"), Some(line("seed = 1")));
        assert_eq!(
            line_of_key(text, "rig.cameras[1].pixel_sigma_px"),
            Some(
                text.lines()
                    .collect::<Vec<_>>()
                    .iter()
                    .rposition(|l| l.contains("pixel_sigma_px"))
                    .unwrap()
                    + 1
            )
        );
        // A missing key gives the line of its deepest present parent.
        assert_eq!(
            line_of_key(text, "trajectory.nope.deeper"),
            line_of_key(text, "trajectory")
        );
        assert_eq!(line_of_key(text, "nope"), None);
    }

    #[test]
    fn bounds_check_both_sides_and_reject_missing_values() {
        let b = Bound {
            min: Some(1.0),
            max: Some(2.0),
        };
        assert!(b.check(Some(1.5)));
        assert!(!b.check(Some(0.5)) && !b.check(Some(2.5)));
        assert!(!b.check(None) && !b.check(Some(f64::NAN)));
    }

    #[test]
    fn other_camera_models_and_quaternion_extrinsics_map_onto_the_configs() {
        let text = default_text()
            .replacen(
                "model = \"pinhole_radtan\"",
                "model = \"double_sphere\"\nxi = -0.2\nalpha = 0.6",
                1,
            )
            .replacen(
                "distortion = [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]\n",
                "",
                1,
            )
            .replacen(
                "rotation = [[0, 0, 1], [-1, 0, 0], [0, -1, 0]]",
                "quaternion_xyzw = [0.5, -0.5, 0.5, -0.5]",
                1,
            );
        let s = Scenario::parse("t", Origin::Catalog, &text).unwrap_or_else(|e| panic!("{e}"));
        let w = s.world_config(Some(9), Some(1.0)).unwrap();
        let e = s.estimator_config().unwrap();
        let rig = w.rig.unwrap();
        assert_eq!(w.seed, 9);
        // The estimator gets the very models the simulator projects with.
        for i in 0..2 {
            assert!(Arc::ptr_eq(&rig.cameras[i].model, &e.cameras[i].model));
        }
        // Both quaternion and matrix extrinsics give the same forward-looking rotation.
        let d = rig.cameras[0].t_b_c.q.angle_to(&rig.cameras[1].t_b_c.q);
        assert!(d < 1e-9, "{d}");
        assert_eq!(e.cameras[0].T_b_c, rig.cameras[0].t_b_c);
        let p = nalgebra::Vector3::new(0.1, -0.2, 1.0);
        assert_eq!(
            e.cameras[0].model.project(&p),
            rig.cameras[0].model.project(&p)
        );
    }

    #[test]
    fn replay_paths_resolve_relative_to_the_scenario_file() {
        let dir = std::env::temp_dir().join(format!("vio-spec-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("data")).unwrap();
        std::fs::write(
            dir.join("data/traj.txt"),
            catalog::data("data/euroc_V2_02_medium_20s.txt").unwrap(),
        )
        .unwrap();
        let text = catalog::get("room_replay_v2_02_stereo_imu")
            .unwrap()
            .text
            .replace("data/euroc_V2_02_medium_20s.txt", "data/traj.txt");
        let file = dir.join("replay.toml");
        std::fs::write(&file, text).unwrap();
        let s = Scenario::load(file.to_str().unwrap()).unwrap();
        assert_eq!(s.name, "replay");
        assert!(s.world_config(None, None).is_ok());
        let _ = std::fs::remove_dir_all(dir);
    }
}
