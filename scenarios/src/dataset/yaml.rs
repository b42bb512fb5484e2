//! A reader for the small YAML subset of EuRoC/Kalibr `sensor.yaml` files: `key: value` maps
//! (nested by indentation), scalars, and flow lists `[a, b, c]` that may span several lines.
//! Comments start at a `#` at the beginning of a line or after whitespace.

use super::RowResult;

/// One `key: value` entry with its dotted path (`T_BS.data`) and 1-based line; a key with no
/// inline value may own a block sequence (`- [a, b]` lines), as Kalibr writes its matrices.
#[derive(Debug, Clone)]
pub(crate) struct Entry {
    pub key: String,
    pub value: String,
    pub line: usize,
    /// Block-sequence items `(text, line)`.
    pub items: Vec<(String, usize)>,
}

/// A parsed document: entries in file order (no hashing, so iteration is deterministic).
#[derive(Debug, Default)]
pub(crate) struct Doc {
    pub entries: Vec<Entry>,
}

fn strip_comment(line: &str) -> &str {
    // A quote opens a quoted scalar only where a scalar starts (after `:`, `[`, `,` or at the
    // start); inside double quotes a backslash escapes the next character.
    let mut quote: Option<char> = None;
    let mut escaped = false;
    let mut prev = ' ';
    let mut prev_non_ws = ':';
    for (i, c) in line.char_indices() {
        match quote {
            Some(_) if escaped => escaped = false,
            Some('"') if c == '\\' => escaped = true,
            Some('\'') if c == '\'' && line[i + 1..].starts_with('\'') => escaped = true,
            Some(q) if c == q => quote = None,
            Some(_) => {}
            None if (c == '"' || c == '\'') && matches!(prev_non_ws, ':' | '[' | ',') => {
                quote = Some(c)
            }
            None if c == '#' && prev.is_whitespace() => return &line[..i],
            None => {}
        }
        prev = c;
        if !c.is_whitespace() {
            prev_non_ws = c;
        }
    }
    line
}

impl Doc {
    /// Parses the subset; errors carry the 1-based line.
    pub fn parse(text: &str) -> Result<Doc, (usize, String)> {
        let mut entries = Vec::new();
        // Stack of (indent, key) of open mappings.
        let mut stack: Vec<(usize, String)> = Vec::new();
        let mut lines = text.lines().enumerate().peekable();
        while let Some((i, raw)) = lines.next() {
            let line_no = i + 1;
            let content = strip_comment(raw).trim_end();
            if content.trim().is_empty() || content.trim() == "---" {
                continue;
            }
            if content.contains('\t') {
                return Err((line_no, "tabs are not allowed for YAML indentation".into()));
            }
            let indent = content.len() - content.trim_start().len();
            let body = content.trim_start();
            if let Some(item) = body.strip_prefix("- ") {
                // An item of the block sequence of the innermost open key (at its indentation
                // or deeper, as YAML allows).
                while stack.last().is_some_and(|(ind, _)| *ind > indent) {
                    stack.pop();
                }
                let owner = stack
                    .iter()
                    .map(|(_, k)| k.as_str())
                    .collect::<Vec<_>>()
                    .join(".");
                let Some(entry) = entries
                    .iter_mut()
                    .rev()
                    .find(|e: &&mut Entry| e.key == owner && e.value.is_empty())
                else {
                    return Err((line_no, format!("a sequence item outside a key: `{body}`")));
                };
                entry.items.push((item.trim().to_string(), line_no));
                continue;
            }
            let Some((key, value)) = body.split_once(':') else {
                return Err((line_no, format!("expected `key: value`, found `{body}`")));
            };
            let key = key.trim();
            if key.is_empty() || key.starts_with('-') {
                return Err((line_no, format!("unsupported YAML line `{body}`")));
            }
            let mut value = value.trim().to_string();
            // Flow lists may continue over several lines until the bracket closes.
            if value.starts_with('[') {
                while !value.contains(']') {
                    let Some((_, next)) = lines.next() else {
                        return Err((line_no, format!("list of `{key}` is not closed with `]`")));
                    };
                    value.push(' ');
                    value.push_str(strip_comment(next).trim());
                }
                if !value.ends_with(']') {
                    return Err((
                        line_no,
                        format!("unexpected text after the list of `{key}`"),
                    ));
                }
            }
            while stack.last().is_some_and(|(ind, _)| *ind >= indent) {
                stack.pop();
            }
            let mut path: Vec<&str> = stack.iter().map(|(_, k)| k.as_str()).collect();
            path.push(key);
            let full = path.join(".");
            if entries.iter().any(|e: &Entry| e.key == full) {
                return Err((line_no, format!("duplicate key `{full}`")));
            }
            if value.is_empty() {
                stack.push((indent, key.to_string()));
            }
            entries.push(Entry {
                key: full,
                value,
                line: line_no,
                items: Vec::new(),
            });
        }
        Ok(Doc { entries })
    }

    pub fn get(&self, key: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.key == key)
    }
}

/// Unquotes a scalar (double quotes with `\\` escapes, single quotes with `''`).
pub(crate) fn scalar(v: &str) -> String {
    let v = v.trim();
    if v.len() >= 2 && v.starts_with('"') && v.ends_with('"') {
        let mut out = String::new();
        let mut chars = v[1..v.len() - 1].chars();
        while let Some(c) = chars.next() {
            if c == '\\' {
                match chars.next() {
                    Some('n') => out.push('\n'),
                    Some('t') => out.push('\t'),
                    Some(o) => out.push(o),
                    None => {}
                }
            } else {
                out.push(c);
            }
        }
        return out;
    }
    if v.len() >= 2 && v.starts_with('\'') && v.ends_with('\'') {
        return v[1..v.len() - 1].replace("''", "'");
    }
    v.to_string()
}

/// Splits a flow list `[a, b, c]` into trimmed items.
pub(crate) fn list(v: &str) -> RowResult<Vec<String>> {
    let v = v.trim();
    let inner = v
        .strip_prefix('[')
        .and_then(|r| r.strip_suffix(']'))
        .ok_or_else(|| format!("expected a list `[...]`, found `{v}`"))?;
    if inner.trim().is_empty() {
        return Ok(Vec::new());
    }
    Ok(inner.split(',').map(scalar).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_nested_and_multiline_lists() {
        let text = "# c\nsensor_type: camera\nT_BS:\n  cols: 4\n  data: [1, 2,\n         3, 4] # x\nrate_hz: 20\nintrinsics: [1.0, 2.0] #fu, fv\n";
        let d = Doc::parse(text).unwrap();
        assert_eq!(d.get("T_BS.cols").unwrap().value, "4");
        assert_eq!(
            list(&d.get("T_BS.data").unwrap().value).unwrap(),
            ["1", "2", "3", "4"]
        );
        assert_eq!(d.get("rate_hz").unwrap().line, 7);
        assert_eq!(list(&d.get("intrinsics").unwrap().value).unwrap().len(), 2);
    }

    #[test]
    fn block_sequences_of_flow_lists_belong_to_their_key() {
        let text = "cam0:\n  T_cam_imu:\n  - [1, 0] # r0\n  - [0, 1]\n  model: pinhole\n";
        let d = Doc::parse(text).unwrap();
        let t = d.get("cam0.T_cam_imu").unwrap();
        assert_eq!(t.items.len(), 2);
        assert_eq!(list(&t.items[1].0).unwrap(), ["0", "1"]);
        assert_eq!(t.items[1].1, 4);
        assert_eq!(d.get("cam0.model").unwrap().value, "pinhole");
        assert!(Doc::parse("- [1, 2]\n").is_err());
    }

    #[test]
    fn quotes_and_comments() {
        assert_eq!(strip_comment("a: x # c"), "a: x ");
        assert_eq!(strip_comment("a: x#y"), "a: x#y");
        assert_eq!(strip_comment(r#"a: "p \" # q" # c"#), r#"a: "p \" # q" "#);
        assert_eq!(strip_comment("a: don't # c"), "a: don't ");
        assert_eq!(strip_comment("a: 'it''s # x' # c"), "a: 'it''s # x' ");
        assert_eq!(scalar(r#""p \"q\" \\""#), r#"p "q" \"#);
        assert_eq!(scalar("'it''s'"), "it's");
    }
}
