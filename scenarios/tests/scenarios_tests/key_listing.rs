//! `vio settings --keys`: the listing of a scenario file's keys holds every key the parser
//! accepts and nothing else (probed table by table through serde's own "unknown field"
//! errors), and every numeric key states its unit or why it has none.

use std::collections::{BTreeMap, BTreeSet};

use crate::common;

use common::{default_text, vio_ok};
use scenarios::spec::ScenarioSpec;
use scenarios::spec::key_listing::{UNITLESS, numeric, scenario_keys, unitless_reason};

const PROBE: &str = "zz_probe";

/// The listing's keys grouped by table: `"rig.imu" → {"rate_hz", …}` (`""`: the top level).
fn listed_tables() -> BTreeMap<String, BTreeSet<String>> {
    let mut tables: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for k in scenario_keys() {
        // Each part of the path is a key of the table its prefix names.
        let parts: Vec<&str> = k.key.split('.').collect();
        for n in 0..parts.len() {
            tables
                .entry(parts[..n].join("."))
                .or_default()
                .insert(parts[n].trim_end_matches("[]").to_string());
        }
    }
    tables
}

/// `doc` with a table holding only the probe key at `path` (`rig.cameras[].calibration_error`:
/// the first camera's), creating what is missing.
fn with_probe(doc: &mut toml::Table, path: &str) {
    let probe: toml::Table = [(PROBE.to_string(), toml::Value::Integer(1))]
        .into_iter()
        .collect();
    if path.is_empty() {
        doc.extend(probe);
        return;
    }
    let parts: Vec<&str> = path.split('.').collect();
    let mut table = doc;
    for (n, part) in parts.iter().enumerate() {
        let last = n == parts.len() - 1;
        let (name, array) = match part.strip_suffix("[]") {
            Some(name) => (name, true),
            None => (*part, false),
        };
        if last {
            let value = toml::Value::Table(probe.clone());
            let value = if array {
                toml::Value::Array(vec![value])
            } else {
                value
            };
            table.insert(name.to_string(), value);
            return;
        }
        let slot = table.entry(name.to_string()).or_insert_with(|| {
            let t = toml::Value::Table(toml::Table::new());
            if array {
                toml::Value::Array(vec![t])
            } else {
                t
            }
        });
        let slot = if array {
            &mut slot.as_array_mut().expect("an array of tables")[0]
        } else {
            slot
        };
        table = slot.as_table_mut().expect("a table");
    }
}

/// The field names serde's "unknown field" error lists.
fn expected_fields(message: &str) -> BTreeSet<String> {
    let after = message
        .split_once(&format!("unknown field `{PROBE}`, expected"))
        .unwrap_or_else(|| panic!("not an unknown-field error: {message}"))
        .1;
    let line = after.lines().next().unwrap_or("");
    line.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

#[test]
fn the_listing_holds_every_key_the_parser_accepts_and_no_other() {
    let base: toml::Table = default_text(2.0).parse().unwrap();
    // The base parses: a probe's error is the probe's.
    toml::from_str::<ScenarioSpec>(&toml::to_string(&base).unwrap()).unwrap();
    let tables = listed_tables();
    assert!(tables.len() >= 20, "{} tables", tables.len());
    for (path, listed) in &tables {
        // A model given as a table is read after the scenario (a `toml::Value` there): its
        // type is probed alone.
        let message = if path.ends_with("tracker_error") {
            toml::from_str::<sim::tracker_error::TrackerErrorModel>(&format!("{PROBE} = 1"))
                .unwrap_err()
                .to_string()
        } else {
            let mut doc = base.clone();
            with_probe(&mut doc, path);
            let text = toml::to_string(&doc).unwrap();
            match toml::from_str::<ScenarioSpec>(&text) {
                Ok(_) => panic!("`{path}` took an unknown key:\n{text}"),
                Err(e) => e.to_string(),
            }
        };
        let accepted = expected_fields(&message);
        assert_eq!(
            &accepted, listed,
            "table `{path}`: accepted (left) vs listed (right)"
        );
    }
}

#[test]
fn every_numeric_key_states_its_unit_or_why_it_has_none() {
    let keys = scenario_keys();
    let mut unitless_used = BTreeSet::new();
    for k in &keys {
        if !numeric(k) || k.unit.is_some() {
            continue;
        }
        let why = unitless_reason(&k.key);
        assert!(
            why.is_some(),
            "`{}` ({}) is a number without a unit: name its unit in the key (`_m`, `_s`, …) or give the reason in key_listing::UNITLESS",
            k.key,
            k.kind
        );
        unitless_used.insert(k.key.rsplit('.').next().unwrap().to_string());
    }
    for (name, _) in UNITLESS {
        assert!(
            unitless_used.contains(name),
            "UNITLESS names `{name}`, which no key is"
        );
    }
    // The densities take datasheet units, and say so.
    let density = keys
        .iter()
        .find(|k| k.key == "rig.imu.gyroscope_noise_density")
        .unwrap();
    assert_eq!(density.unit, Some("rad/s/√Hz, or datasheet units"));
    assert!(density.required);
}

#[test]
fn vio_settings_keys_prints_every_key_with_its_unit() {
    let out = vio_ok(&["settings", "--keys"]).stdout;
    let text = String::from_utf8(out).unwrap();
    let keys = scenario_keys();
    for k in &keys {
        assert!(
            text.lines()
                .any(|l| l.split_whitespace().next() == Some(&k.key)),
            "{} missing from:\n{text}",
            k.key
        );
    }
    let line = text
        .lines()
        .find(|l| l.starts_with("rig.cameras[].T_b_c.translation_m "))
        .unwrap();
    assert!(line.contains("[number; 3] [m]"), "{line}");
    assert!(keys.len() >= 140, "{} keys", keys.len());
}
