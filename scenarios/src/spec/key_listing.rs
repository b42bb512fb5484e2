//! Every key a scenario file may set, read from the spec types' JSON schema (`schemars`, which
//! follows their serde attributes): its dotted path, type, unit, default and description, for
//! `vio settings --keys`. Generated, so it cannot drift from what the parser accepts.

use serde_json::{Map, Value};

use super::ScenarioSpec;

/// One key of the scenario schema.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyDoc {
    /// Dotted path; `[]` marks an array of tables (`rig.cameras[].name`).
    pub key: String,
    /// What the value is: `number`, `string`, `[number; 3]`, `"a" | "b"`, `table` ….
    pub kind: String,
    /// Unit of a number (or of an array's numbers); `None` for text, switches, counts and
    /// ratios, which [`UNITLESS`] names.
    pub unit: Option<&'static str>,
    /// The value a file that leaves the key out gets, when the schema states one.
    pub default: Option<String>,
    /// Whether a file must set it (within its table).
    pub required: bool,
    /// The field's documentation, on one line.
    pub description: String,
}

/// What a key that takes a model by name, by file or inline has in the schema (for the
/// listing only: the key is read as a `toml::Value` and resolved when the run is built).
#[derive(schemars::JsonSchema)]
#[schemars(untagged)]
pub enum NameOrTable<T> {
    /// A built-in model's name or a `.toml` file relative to the scenario.
    Name(String),
    /// The model's table itself.
    Table(T),
}

/// Unit suffixes of key names, longest first: the project names a number's unit in its key.
const SUFFIX_UNITS: [(&str, &str); 20] = [
    ("_m_s2", "m/s²"),
    ("_rad_s", "rad/s"),
    ("_deg_s", "deg/s"),
    ("_m_s", "m/s"),
    ("_hz", "Hz"),
    ("_ms", "ms"),
    ("_ns", "ns"),
    ("_us", "µs"),
    ("_mm", "mm"),
    ("_px", "px"),
    ("_deg", "deg"),
    ("_rad", "rad"),
    ("_percent", "%"),
    ("_db", "dB"),
    ("_s", "s"),
    ("_m", "m"),
    ("_g", "g"),
    ("_k", "K"),
    ("_c", "°C"),
    ("_x", "× (a factor)"),
];

/// Numbers whose unit is not in their name, by the key's last part (or its whole path): the
/// IMU's densities and rate (datasheet units accepted, [`super::units`]), the camera's
/// intrinsics and resolution, the motions' centres and boxes.
const NAMED_UNITS: [(&str, &str); 15] = [
    ("gyroscope_noise_density", "rad/s/√Hz, or datasheet units"),
    (
        "accelerometer_noise_density",
        "m/s²/√Hz, or datasheet units",
    ),
    ("gyroscope_random_walk", "rad/s²/√Hz, or datasheet units"),
    ("accelerometer_random_walk", "m/s³/√Hz, or datasheet units"),
    ("rig.imu.rate_hz", "Hz, or datasheet units"),
    ("rig.imu.gyro_range_rad_s", "rad/s, or datasheet units"),
    ("rig.imu.accel_range_m_s2", "m/s², or datasheet units"),
    ("intrinsics", "px"),
    ("drift_px", "px/√frame"),
    ("sliding_drift_px", "px/√frame"),
    ("resolution", "px"),
    ("center", "m"),
    ("trajectory.waypoints.min", "m"),
    ("trajectory.waypoints.max", "m"),
    ("landmark_density", "1/m²"),
];

/// Numeric keys without a physical unit, by the key's last part (for an expectation, the
/// metric's name), each with its reason.
pub const UNITLESS: [(&str, &str); 19] = [
    ("seed", "a random seed"),
    ("cam_id", "a camera's index in the rig"),
    ("probability", "a probability"),
    ("slip_ratio", "a ratio"),
    ("quaternion_xyzw", "a unit quaternion"),
    ("rotation", "a rotation matrix"),
    ("distortion", "the lens model's coefficients"),
    ("alpha", "the double-sphere model's α"),
    ("xi", "the Mei / double-sphere model's ξ"),
    ("max_features", "a count of features"),
    ("max_track_length", "a count of frames"),
    ("resets", "a count of estimator resets"),
    ("suite_switches", "a count of suite switches"),
    ("imu_samples_excluded", "a count of IMU samples"),
    ("imu_samples_saturated", "a count of IMU samples"),
    ("frontend_features_min", "a count of features"),
    ("tracking_fraction", "a fraction of frames"),
    ("sliding_fraction", "a fraction of tracks"),
    ("frontend_wrong_after_ransac", "a fraction of tracks"),
];

/// Every key of the scenario schema, in file order of the tables (alphabetical within one).
pub fn scenario_keys() -> Vec<KeyDoc> {
    let schema = schemars::schema_for!(ScenarioSpec);
    let root = schema.as_value();
    let empty = Map::new();
    let defs = root
        .get("$defs")
        .and_then(Value::as_object)
        .unwrap_or(&empty);
    let mut out = Vec::new();
    walk(root, defs, "", &mut out);
    out
}

/// The definition `schema` refers to, or itself.
fn resolve<'a>(schema: &'a Value, defs: &'a Map<String, Value>) -> &'a Value {
    match schema.get("$ref").and_then(Value::as_str) {
        Some(r) => r
            .strip_prefix("#/$defs/")
            .and_then(|name| defs.get(name))
            .map_or(schema, |d| resolve(d, defs)),
        None => schema,
    }
}

/// The alternatives of `schema` that are not `null` (an `Option`'s other side).
fn non_null<'a>(schema: &'a Value, defs: &'a Map<String, Value>) -> &'a Value {
    let s = resolve(schema, defs);
    for k in ["anyOf", "oneOf"] {
        if let Some(alts) = s.get(k).and_then(Value::as_array) {
            let rest: Vec<&Value> = alts
                .iter()
                .filter(|a| a.get("type").and_then(Value::as_str) != Some("null"))
                .collect();
            if rest.len() == 1 {
                return non_null(rest[0], defs);
            }
        }
    }
    s
}

/// The keys under a table schema, prefixed by `path`.
fn walk(table: &Value, defs: &Map<String, Value>, path: &str, out: &mut Vec<KeyDoc>) {
    let table = non_null(table, defs);
    let Some(props) = table.get("properties").and_then(Value::as_object) else {
        return;
    };
    let required: Vec<&str> = table
        .get("required")
        .and_then(Value::as_array)
        .map(|r| r.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default();
    for (name, prop) in props {
        let key = if path.is_empty() {
            name.clone()
        } else {
            format!("{path}.{name}")
        };
        let target = non_null(prop, defs);
        let description = [prop, resolve(prop, defs), target]
            .iter()
            .find_map(|s| s.get("description").and_then(Value::as_str))
            .unwrap_or("");
        let description = plain(description);
        // A name, a file or the table itself: the key, then the table's keys under it.
        if let Some(table) = target
            .get("anyOf")
            .and_then(Value::as_array)
            .and_then(|alts| {
                alts.iter()
                    .map(|a| non_null(a, defs))
                    .find(|a| a.get("properties").is_some())
            })
        {
            out.push(KeyDoc {
                key: key.clone(),
                kind: "string (a built-in name or a .toml file), or a table".into(),
                unit: None,
                default: None,
                required: required.contains(&name.as_str()),
                description,
            });
            walk(table, defs, &key, out);
            continue;
        }
        // A bound on a metric, `{ min, max }`: one key, in the metric's unit.
        if let Some(p) = target.get("properties").and_then(Value::as_object)
            && p.len() == 2
            && p.contains_key("min")
            && p.contains_key("max")
        {
            out.push(KeyDoc {
                unit: unit_of(&key, &p["max"], defs),
                kind: "{ min = number, max = number }".into(),
                default: None,
                required: required.contains(&name.as_str()),
                description,
                key,
            });
            continue;
        }
        let sub_table = target.get("properties").is_some();
        let items = target.get("items").map(|i| non_null(i, defs));
        if sub_table {
            walk(target, defs, &key, out);
            continue;
        }
        if let Some(items) = items
            && items.get("properties").is_some()
        {
            walk(items, defs, &format!("{key}[]"), out);
            continue;
        }
        out.push(KeyDoc {
            unit: unit_of(&key, target, defs),
            kind: kind_of(target, defs),
            default: prop
                .get("default")
                .filter(|d| !d.is_null())
                .map(|d| d.to_string()),
            required: required.contains(&name.as_str()),
            description,
            key,
        });
    }
}

/// A doc comment on one line, its rustdoc links as plain code (`[`x`]` as `x`, without
/// `super::`).
fn plain(doc: &str) -> String {
    doc.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace("[`", "`")
        .replace("`]", "`")
        .replace("`super::", "`")
}

/// The base type of a schema: `number`, `integer`, `string`, `boolean`, `array`, `object`.
fn type_of(schema: &Value) -> Option<&str> {
    match schema.get("type") {
        Some(Value::String(t)) => Some(t),
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).find(|t| *t != "null"),
        _ => None,
    }
}

/// A short name of what a value is.
fn kind_of(schema: &Value, defs: &Map<String, Value>) -> String {
    let s = non_null(schema, defs);
    if let Some(alts) = s
        .get("oneOf")
        .or_else(|| s.get("anyOf"))
        .and_then(Value::as_array)
    {
        let names: Vec<String> = alts
            .iter()
            .filter_map(|a| a.get("const").and_then(Value::as_str))
            .map(|c| format!("\"{c}\""))
            .collect();
        if names.len() == alts.len() && !names.is_empty() {
            return names.join(" | ");
        }
    }
    if let Some(choices) = s.get("enum").and_then(Value::as_array) {
        return choices
            .iter()
            .map(Value::to_string)
            .collect::<Vec<_>>()
            .join(" | ");
    }
    match type_of(s) {
        Some("array") => {
            let inner = s.get("items").map_or("value".into(), |i| kind_of(i, defs));
            match (s.get("minItems"), s.get("maxItems")) {
                (Some(a), Some(b)) if a == b => format!("[{inner}; {a}]"),
                _ => format!("[{inner}, …]"),
            }
        }
        Some("object") => "table (its keys and values: `vio settings`)".into(),
        Some(t) => t.to_string(),
        None => "value".into(),
    }
}

/// Whether a schema holds numbers (itself, or an array's items at any depth).
fn is_numeric(schema: &Value, defs: &Map<String, Value>) -> bool {
    let s = non_null(schema, defs);
    match type_of(s) {
        Some("number" | "integer") => true,
        Some("array") => s.get("items").is_some_and(|i| is_numeric(i, defs)),
        _ => false,
    }
}

/// The part of a key that names its unit: its last part.
fn unit_name(key: &str) -> &str {
    key.rsplit('.').next().unwrap_or(key)
}

/// The unit of a numeric key: from the keys whose unit is not in their name, else its name's
/// suffix; `None` for a key that is not numeric or has no unit.
fn unit_of(key: &str, schema: &Value, defs: &Map<String, Value>) -> Option<&'static str> {
    let name = unit_name(key);
    if let Some((_, u)) = NAMED_UNITS.iter().find(|(k, _)| *k == name || *k == key) {
        return Some(u);
    }
    if !is_numeric(schema, defs) {
        return None;
    }
    SUFFIX_UNITS
        .iter()
        .find(|(suffix, _)| name.ends_with(suffix))
        .map(|(_, u)| *u)
}

/// Why a numeric key has no unit ([`UNITLESS`]); `None` for a key not listed there.
pub fn unitless_reason(key: &str) -> Option<&'static str> {
    let name = unit_name(key);
    UNITLESS.iter().find(|(k, _)| *k == name).map(|(_, r)| *r)
}

/// Whether a key's value holds numbers.
pub fn numeric(doc: &KeyDoc) -> bool {
    doc.kind.contains("number") || doc.kind.contains("integer")
}

/// A run metric in words with its unit, for a plot's axis: its `expectations` key's
/// description without the parenthesized asides, and the unit in brackets (`ate_rmse_m`:
/// "Position ATE RMSE after alignment [m]"); the name itself for a metric no expectation
/// bounds.
pub fn metric_label(metric: &str) -> String {
    let key = format!("expectations.{metric}");
    let Some(doc) = scenario_keys().into_iter().find(|k| k.key == key) else {
        return metric.to_string();
    };
    let mut words = String::new();
    let mut depth = 0usize;
    for c in doc.description.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            _ if depth == 0 => words.push(c),
            _ => {}
        }
    }
    let words = words.split_whitespace().collect::<Vec<_>>().join(" ");
    let words = words.trim_end_matches('.').trim_end().replace(" ,", ",");
    match doc.unit {
        Some(u) => format!("{words} [{u}]"),
        None => words,
    }
}

/// The listing `vio settings --keys` prints: one line per key, `key  kind  [unit]  (default
/// …)  description`.
pub fn listing_text(keys: &[KeyDoc]) -> String {
    let width = keys.iter().map(|k| k.key.len()).max().unwrap_or(0);
    let mut s = String::from(
        "# Every key of a scenario file: its type, [unit], default, and what it is. `a.b` is key \
         `b` of table `[a]`; `a[].b` is key `b` of each `[[a]]` table. The estimator's, front \
         end's and renderer's own settings: `vio settings`.\n\n",
    );
    for k in keys {
        let mut what = k.kind.clone();
        if let Some(u) = k.unit {
            what += &format!(" [{u}]");
        }
        if k.required {
            what += " (required)";
        } else if let Some(d) = &k.default {
            what += &format!(" (default {d})");
        } else {
            what += " (optional)";
        }
        if k.unit.is_none()
            && numeric(k)
            && let Some(why) = unitless_reason(&k.key)
        {
            what += &format!(" [no unit: {why}]");
        }
        s += &format!(
            "{:width$}  {what}\n{:width$}  {}\n",
            k.key, "", k.description
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::metric_label;

    #[test]
    fn a_metric_is_labelled_in_words_with_its_unit() {
        assert_eq!(
            metric_label("ate_rmse_m"),
            "Position ATE RMSE after alignment [m]"
        );
        assert_eq!(
            metric_label("gnss_aligned_at_s"),
            "Time at which the GNSS alignment was initialized [s]"
        );
        assert_eq!(
            metric_label("tracking_fraction"),
            "Fraction of processed frames in tracking state"
        );
        assert_eq!(metric_label("no_such_metric"), "no_such_metric");
    }
}
