//! `estimator_adapter = "NAME" | "FILE.toml"`: the estimator a scenario runs when it is not
//! ours. An adapter file names an outside program as an argv list with placeholders, the input
//! it reads, the trajectory it writes and how long it may take; it is read and checked here, at
//! the scenario's door, so a sweep's plan or a regression catalog refuses a bad adapter before
//! any run. Running it is [`crate::external`]'s job.
//!
//! ```toml
//! name = "my-vio"                                  # in reports and JUnit names
//! command = ["{here}/run_my_vio.sh", "{dataset}", "{out}", "--seed", "{seed}"]
//! input = "asl_features"                           # asl_images | asl_features | mcap
//! trajectory = "estimate.tum"                      # under {out}: TUM, body = IMU frame, IMU clock
//! timing = "timing.csv"                            # optional, under {out}: `t_s,seconds` rows
//! covariance = "state.txt"                         # optional, under {out}: state and covariance
//! time_limit_s = 600                               # the process is killed past it
//! ```
//!
//! Placeholders: `{dataset}` (the exported ASL folder: `mav0/`, `features.csv`, the Kalibr files;
//! inputs `asl_*`), `{bag}` (the exported ROS 2 bag; input `mcap`), `{out}` (an empty folder the
//! program writes into), `{seed}`, `{suite}` (`stereo_imu`, `stereo`, `mono_imu`), `{here}` (the
//! adapter file's folder) and `{source}` (the source tree this `vio` was built from, where the
//! built-in adapters' scripts are).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::error::deserialize_toml;
use super::named_model::{BuiltIn, is_preset_name, model_text};
use super::{Origin, Scenario, SpecError};
use crate::catalog;

/// The scenario key this module reads.
pub const KEY: &str = "estimator_adapter";

/// The name of our own estimator as an adapter value (the default).
pub const OURS: &str = "ours";

/// The longest time limit an adapter may set (s): a day.
pub const MAX_TIME_LIMIT_S: f64 = 86_400.0;

/// What an outside estimator reads.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum AdapterInput {
    /// The ASL folder with the rendered images (`mav0/cam<i>/data/*.png`): rendered scenarios.
    AslImages,
    /// The ASL folder's feature tracks (`features.csv`, distorted pixels) and IMU log.
    AslFeatures,
    /// A ROS 2 bag (MCAP) of the same measurements.
    Mcap,
}

impl AdapterInput {
    /// The name as written in adapter files.
    pub fn as_str(self) -> &'static str {
        match self {
            AdapterInput::AslImages => "asl_images",
            AdapterInput::AslFeatures => "asl_features",
            AdapterInput::Mcap => "mcap",
        }
    }
}

/// An adapter file as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct AdapterSpec {
    name: String,
    #[serde(default)]
    description: String,
    command: Vec<String>,
    input: AdapterInput,
    #[serde(default = "default_trajectory")]
    trajectory: String,
    timing: Option<String>,
    covariance: Option<String>,
    #[serde(default = "default_time_limit")]
    time_limit_s: f64,
}

fn default_trajectory() -> String {
    "estimate.tum".into()
}

fn default_time_limit() -> f64 {
    600.0
}

/// The placeholders a command may hold.
pub const PLACEHOLDERS: &[&str] = &["dataset", "bag", "out", "seed", "suite", "here", "source"];

/// A checked estimator adapter.
#[derive(Clone, Debug, PartialEq)]
pub struct EstimatorAdapter {
    /// Its name (reports, JUnit, sweep labels).
    pub name: String,
    /// One line on what it runs.
    pub description: String,
    /// Where it was read from (`preset:NAME` or the file's path).
    pub source: String,
    /// The argv, placeholders unreplaced.
    pub command: Vec<String>,
    /// What it reads.
    pub input: AdapterInput,
    /// Its trajectory file, relative to `{out}`.
    pub trajectory: PathBuf,
    /// Its per-pose timing file, relative to `{out}`.
    pub timing: Option<PathBuf>,
    /// Its newest-state covariance file, relative to `{out}`, for `vio nees` (its form: the
    /// `external::state_covariance` module).
    pub covariance: Option<PathBuf>,
    /// Wall-clock limit (s).
    pub time_limit_s: f64,
    /// `{here}`: the adapter file's folder.
    pub here: PathBuf,
}

/// What the placeholders stand for in one run.
#[derive(Clone, Debug)]
pub struct AdapterValues<'a> {
    /// `{dataset}`.
    pub dataset: &'a Path,
    /// `{bag}`.
    pub bag: &'a Path,
    /// `{out}`.
    pub out: &'a Path,
    /// `{seed}`.
    pub seed: u64,
    /// `{suite}`.
    pub suite: &'a str,
}

/// The source tree this binary was built from (`{source}`).
pub fn source_tree() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")),
        Path::to_path_buf,
    )
}

/// The `{…}` names in `arg`, or why it is not well formed.
fn placeholders_in(arg: &str) -> Result<Vec<&str>, String> {
    let mut out = Vec::new();
    let mut rest = arg;
    while let Some(open) = rest.find(['{', '}']) {
        if rest.as_bytes()[open] == b'}' {
            return Err(format!("`{arg}` has a `}}` without its `{{`"));
        }
        let after = &rest[open + 1..];
        let close = after
            .find('}')
            .ok_or_else(|| format!("`{arg}` has a `{{` without its `}}`"))?;
        out.push(&after[..close]);
        rest = &after[close + 1..];
    }
    Ok(out)
}

impl EstimatorAdapter {
    /// Parses and checks adapter `text` read from `source`; `here` is its folder. Errors name
    /// `source`, the key and the line.
    pub fn parse(text: &str, source: &str, here: &Path) -> Result<Self, SpecError> {
        let spec: AdapterSpec = deserialize_toml(text, source)?;
        let err = |key: &str, m: String| SpecError::at(source, text, key, m);
        if spec.name.trim().is_empty() || spec.name.chars().any(char::is_control) {
            return Err(err("name", "expected a name (one line of text)".into()));
        }
        if spec.command.first().is_none_or(|p| p.trim().is_empty()) {
            return Err(err(
                "command",
                "expected the program and its arguments, e.g. [\"{here}/run.sh\", \"{dataset}\", \"{out}\"]".into(),
            ));
        }
        for arg in &spec.command {
            for p in placeholders_in(arg).map_err(|m| err("command", m))? {
                if !PLACEHOLDERS.contains(&p) {
                    return Err(err(
                        "command",
                        format!(
                            "unknown placeholder `{{{p}}}` (known: {})",
                            PLACEHOLDERS
                                .iter()
                                .map(|p| format!("{{{p}}}"))
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    ));
                }
                let wrong_input = match p {
                    "dataset" => spec.input == AdapterInput::Mcap,
                    "bag" => spec.input != AdapterInput::Mcap,
                    _ => false,
                };
                if wrong_input {
                    return Err(err(
                        "command",
                        format!(
                            "`{{{p}}}` is not written for input = \"{}\" ({{dataset}} comes with asl_images and asl_features, {{bag}} with mcap)",
                            spec.input.as_str()
                        ),
                    ));
                }
            }
        }
        let relative = |key: &str, v: &str| -> Result<PathBuf, SpecError> {
            let p = Path::new(v);
            if v.is_empty()
                || p.is_absolute()
                || p.components()
                    .any(|c| !matches!(c, std::path::Component::Normal(_)))
            {
                return Err(err(
                    key,
                    format!("`{v}`: expected a file name under {{out}} (relative, no `..`)"),
                ));
            }
            Ok(p.to_path_buf())
        };
        let trajectory = relative("trajectory", &spec.trajectory)?;
        let timing = spec
            .timing
            .as_deref()
            .map(|t| relative("timing", t))
            .transpose()?;
        let covariance = spec
            .covariance
            .as_deref()
            .map(|t| relative("covariance", t))
            .transpose()?;
        if !(spec.time_limit_s.is_finite()
            && spec.time_limit_s > 0.0
            && spec.time_limit_s <= MAX_TIME_LIMIT_S)
        {
            return Err(err(
                "time_limit_s",
                format!(
                    "{}: expected seconds in (0, {MAX_TIME_LIMIT_S}]",
                    spec.time_limit_s
                ),
            ));
        }
        Ok(Self {
            name: spec.name,
            description: spec.description,
            source: source.into(),
            command: spec.command,
            input: spec.input,
            trajectory,
            timing,
            covariance,
            time_limit_s: spec.time_limit_s,
            here: here.to_path_buf(),
        })
    }

    /// The argv with every placeholder replaced.
    pub fn argv(&self, values: &AdapterValues) -> Vec<String> {
        let seed = values.seed.to_string();
        let source = source_tree();
        self.command
            .iter()
            .map(|arg| {
                arg.replace("{dataset}", &values.dataset.display().to_string())
                    .replace("{bag}", &values.bag.display().to_string())
                    .replace("{out}", &values.out.display().to_string())
                    .replace("{seed}", &seed)
                    .replace("{suite}", values.suite)
                    .replace("{here}", &self.here.display().to_string())
                    .replace("{source}", &source.display().to_string())
            })
            .collect()
    }
}

/// The built-in adapters (`catalog/estimators/`).
fn built_in() -> BuiltIn {
    BuiltIn {
        kind: "estimator adapter",
        get: catalog::estimator_adapter,
        names: catalog::estimator_adapter_names,
    }
}

/// The adapter `value` names (`None` for [`OURS`]): a built-in one, or a file read through
/// `origin`; errors name `file` and the scenario's `key`.
pub fn load_adapter(
    origin: &Origin,
    value: &str,
    on_error: impl Fn(String) -> SpecError,
) -> Result<Option<EstimatorAdapter>, SpecError> {
    if value == OURS {
        return Ok(None);
    }
    let (source, text) = model_text(origin, value, &built_in()).map_err(&on_error)?;
    let here = if is_preset_name(value) {
        source_tree().join("scenarios/catalog/estimators")
    } else {
        origin
            .path_of(value)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    };
    EstimatorAdapter::parse(&text, &source, &here).map(Some)
}

impl Scenario {
    /// The outside estimator this scenario runs (`estimator_adapter`), `None` for ours.
    pub(super) fn load_estimator_adapter(&self) -> Result<Option<EstimatorAdapter>, SpecError> {
        let Some(value) = &self.spec.estimator_adapter else {
            return Ok(None);
        };
        let adapter = load_adapter(&self.origin, value, |m| self.error(KEY, m))?;
        if let Some(a) = &adapter
            && a.input == AdapterInput::AslImages
            && self.spec.camera.mode != super::CameraMode::Rendered
        {
            return Err(self.error(
                KEY,
                format!(
                    "adapter `{}` reads images (input = \"asl_images\") and this scenario's cameras are feature-level: set camera.mode = \"rendered\", or use an adapter that reads the feature tracks",
                    a.name
                ),
            ));
        }
        Ok(adapter)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<EstimatorAdapter, SpecError> {
        EstimatorAdapter::parse(text, "a.toml", Path::new("/adapters"))
    }

    const GOOD: &str = "name = \"x\"\ncommand = [\"{here}/run.sh\", \"{dataset}\", \"{out}\", \"{seed}\"]\ninput = \"asl_features\"\n";

    #[test]
    fn an_adapter_fills_its_placeholders() {
        let a = parse(GOOD).unwrap();
        assert_eq!(a.trajectory, Path::new("estimate.tum"));
        assert_eq!(a.time_limit_s, 600.0);
        let argv = a.argv(&AdapterValues {
            dataset: Path::new("/d"),
            bag: Path::new("/b.mcap"),
            out: Path::new("/o"),
            seed: 7,
            suite: "stereo_imu",
        });
        assert_eq!(argv, ["/adapters/run.sh", "/d", "/o", "7"]);
    }

    #[test]
    fn bad_adapters_are_refused_naming_key_and_line() {
        let cases = [
            (
                GOOD.replace("{seed}", "{sede}"),
                "command",
                "unknown placeholder `{sede}`",
            ),
            (
                GOOD.replace("{seed}", "{seed"),
                "command",
                "without its `}`",
            ),
            (
                GOOD.replace("{dataset}", "{bag}"),
                "command",
                "not written for input",
            ),
            (
                GOOD.replace(
                    "[\"{here}/run.sh\", \"{dataset}\", \"{out}\", \"{seed}\"]",
                    "[]",
                ),
                "command",
                "expected the program",
            ),
            (
                GOOD.to_string() + "trajectory = \"../x.tum\"\n",
                "trajectory",
                "no `..`",
            ),
            (
                GOOD.to_string() + "covariance = \"/tmp/c.txt\"\n",
                "covariance",
                "relative, no `..`",
            ),
            (
                GOOD.to_string() + "time_limit_s = 0\n",
                "time_limit_s",
                "expected seconds",
            ),
            (
                GOOD.to_string() + "time_limit_s = inf\n",
                "time_limit_s",
                "expected seconds",
            ),
            (
                GOOD.to_string() + "comand = []\n",
                "comand",
                "unknown field",
            ),
            (
                GOOD.replace("asl_features", "images"),
                "input",
                "unknown variant",
            ),
        ];
        for (text, key, message) in cases {
            let e = parse(&text).unwrap_err();
            assert_eq!(e.file, "a.toml", "{text}");
            assert_eq!(e.key, key, "{text}: {e}");
            assert!(e.line.is_some(), "{text}: {e}");
            assert!(e.message.contains(message), "{text}: {e}");
        }
    }

    #[test]
    fn every_built_in_adapter_loads() {
        for name in catalog::estimator_adapter_names() {
            let a = load_adapter(&Origin::Catalog, name, |m| SpecError::at("t", "", KEY, m))
                .unwrap_or_else(|e| panic!("{name}: {e}"))
                .expect("an outside estimator");
            assert_eq!(a.name, name);
        }
        assert_eq!(
            load_adapter(&Origin::Catalog, OURS, |m| SpecError::at("t", "", KEY, m)).unwrap(),
            None
        );
    }
}
