//! A value set at a scenario's dotted key (`rig.cameras[1].pixel_sigma_px`): what a sweep's
//! axes and `--set KEY=VALUE` do to a scenario before it is parsed and checked as written.

use super::{Origin, Scenario, SpecError};
use crate::catalog;

/// Sets `value` at a dotted key with array indices (`rig.cameras[1].T_b_c.translation_m[1]`),
/// creating missing tables; the key's last part may be new, its parents' arrays must exist.
pub fn set_key(doc: &mut toml::Table, key: &str, value: toml::Value) -> Result<(), String> {
    let mut parts: Vec<(String, Vec<usize>)> = Vec::new();
    for part in key.split('.') {
        let (name, rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        let idx = rest
            .split(['[', ']'])
            .filter(|s| !s.is_empty())
            .map(|s| s.parse::<usize>().map_err(|_| format!("bad index `{s}`")))
            .collect::<Result<Vec<_>, _>>()?;
        if name.is_empty() {
            return Err("empty key part".into());
        }
        parts.push((name.to_string(), idx));
    }
    let mut table = doc;
    let last = parts.len() - 1;
    for (n, (name, idx)) in parts.into_iter().enumerate() {
        if n == last && idx.is_empty() {
            table.insert(name, value);
            return Ok(());
        }
        let mut cur = table
            .entry(name.clone())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        for (m, &i) in idx.iter().enumerate() {
            let arr = cur
                .as_array_mut()
                .ok_or_else(|| format!("`{name}` is not an array"))?;
            let len = arr.len();
            let slot = arr
                .get_mut(i)
                .ok_or_else(|| format!("`{name}` has {len} elements, no [{i}]"))?;
            if n == last && m == idx.len() - 1 {
                *slot = value;
                return Ok(());
            }
            cur = slot;
        }
        table = cur
            .as_table_mut()
            .ok_or_else(|| format!("`{name}` is not a table"))?;
    }
    Ok(())
}

/// `KEY=VALUE` of a `--set`: the value as TOML (`2.5`, `true`, `"x"`, `[1, 2]`), or else as the
/// string written (`estimator_adapter=ours`).
pub fn parse_setting(arg: &str) -> Result<(String, toml::Value), String> {
    let (key, value) = arg
        .split_once('=')
        .ok_or_else(|| format!("--set {arg}: expected KEY=VALUE"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(format!("--set {arg}: the key is empty"));
    }
    let value = value.trim();
    let parsed = format!("v = {value}")
        .parse::<toml::Table>()
        .ok()
        .and_then(|mut t| t.remove("v"));
    Ok((
        key.to_string(),
        parsed.unwrap_or_else(|| toml::Value::String(value.to_string())),
    ))
}

impl Scenario {
    /// [`Scenario::load`] with `settings` set at their keys first; the scenario is then
    /// checked as if written so (an error names the key and says `--set` set it).
    pub fn load_with_settings(
        name_or_path: &str,
        settings: &[(String, toml::Value)],
    ) -> Result<Self, SpecError> {
        let plain = Self::load(name_or_path)?;
        if settings.is_empty() {
            return Ok(plain);
        }
        let original = match &plain.origin {
            Origin::File(path) => sim::input_file::read_to_string(path)
                .map_err(|e| plain.error("", format!("cannot read the scenario file: {e}")))?,
            _ => catalog::get(&plain.name)
                .map(|e| e.text.to_string())
                .ok_or_else(|| plain.error("", "not a catalog scenario"))?,
        };
        let mut doc: toml::Table = original
            .parse()
            .map_err(|e: toml::de::Error| plain.error("", e.message().trim().to_string()))?;
        for (key, value) in settings {
            set_key(&mut doc, key, value.clone())
                .map_err(|m| plain.error("", format!("--set {key}: {m}")))?;
        }
        let text = toml::to_string(&doc).map_err(|e| plain.error("", e.to_string()))?;
        // A file a setting names on a catalog scenario is read from the working folder.
        let origin = match &plain.origin {
            Origin::Catalog => {
                Origin::CatalogBeside(std::env::current_dir().unwrap_or_default().join("--set"))
            }
            o => o.clone(),
        };
        let label = plain.file_label();
        Self::parse(&plain.name, origin, &text).map_err(|e| {
            let set = settings.iter().any(|(k, _)| e.key.starts_with(k.as_str()));
            SpecError {
                // The rewritten text's lines are not the file's; another file's (an adapter's,
                // a model's) are its own.
                line: if e.file == label { None } else { e.line },
                message: if set {
                    format!("{} (set by --set)", e.message)
                } else {
                    e.message
                },
                ..e
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_setting_is_toml_or_else_a_string() {
        assert_eq!(
            parse_setting("a.b=2.5").unwrap(),
            ("a.b".into(), toml::Value::Float(2.5))
        );
        assert_eq!(
            parse_setting("estimator_adapter=ours").unwrap().1,
            toml::Value::String("ours".into())
        );
        assert_eq!(
            parse_setting("k=\"x=y\"").unwrap().1,
            toml::Value::String("x=y".into())
        );
        assert!(parse_setting("novalue").is_err());
        assert!(parse_setting("=3").is_err());
    }

    #[test]
    fn a_set_key_is_checked_as_written() {
        let s = Scenario::load_with_settings(
            "room_figure8_stereo_imu",
            &[parse_setting("rig.cameras[0].pixel_sigma_px=0.5").unwrap()],
        )
        .unwrap();
        assert_eq!(s.spec.rig.cameras[0].pixel_sigma_px, 0.5);
        let e = Scenario::load_with_settings(
            "room_figure8_stereo_imu",
            &[parse_setting("rig.cameras[0].pixel_sigma_pxx=0.5").unwrap()],
        )
        .unwrap_err();
        assert!(
            e.message.contains("unknown field") && e.message.contains("--set"),
            "{e}"
        );
    }
}
