//! [`SpecError`] and the lookups that give an error its key path and line.

use std::fmt;

/// A scenario error: names the file, the key path, the line when known, and what was wrong.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecError {
    /// The scenario file (or `catalog:<name>`).
    pub file: String,
    /// Dotted key path, e.g. `rig.cameras[1].intrinsics` (empty for the whole file).
    pub key: String,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// What was wrong / expected.
    pub message: String,
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        if !self.key.is_empty() {
            write!(f, ": key `{}`", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for SpecError {}

impl SpecError {
    /// An error at `key` of `file`, with the key's line in `text` when it is there.
    pub fn at(file: &str, text: &str, key: &str, message: impl Into<String>) -> Self {
        Self {
            file: file.into(),
            key: key.into(),
            line: line_of_key(text, key),
            message: message.into(),
        }
    }
}

/// The serde (snake_case) name of a fault kind.
pub(crate) fn serde_name(k: impl fmt::Debug) -> String {
    let dbg = format!("{k:?}");
    let mut out = String::new();
    for (i, ch) in dbg.chars().enumerate() {
        if ch.is_uppercase() {
            if i > 0 {
                out.push('_');
            }
            out.extend(ch.to_lowercase());
        } else {
            out.push(ch);
        }
    }
    out
}

/// 1-based line of a byte offset.
pub(crate) fn line_of_offset(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// A serde path as `a.b[2].c`.
pub(crate) fn path_string(path: &serde_path_to_error::Path) -> String {
    use serde_path_to_error::Segment;
    let mut s = String::new();
    for seg in path.iter() {
        match seg {
            Segment::Seq { index } => s.push_str(&format!("[{index}]")),
            Segment::Map { key } | Segment::Enum { variant: key } => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(key);
            }
            Segment::Unknown => {}
        }
    }
    s
}

/// Line of the deepest part of `key` (`a.b[2].c`) present in the document.
pub(crate) fn line_of_key(text: &str, key: &str) -> Option<usize> {
    let root = toml::de::DeTable::parse(text).ok()?;
    let mut span: Option<std::ops::Range<usize>> = None;
    let mut cur = toml::de::DeValue::Table(root.into_inner());
    'outer: for part in key.split('.').filter(|p| !p.is_empty()) {
        let (name, indices) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        let Some(next) = cur.get(name).cloned() else {
            break;
        };
        span = Some(next.span());
        cur = next.into_inner();
        for idx in indices
            .split(['[', ']'])
            .filter_map(|s| s.parse::<usize>().ok())
        {
            let Some(n) = cur.get(idx).cloned() else {
                break 'outer;
            };
            span = Some(n.span());
            cur = n.into_inner();
        }
    }
    span.map(|s| line_of_offset(text, s.start))
}

/// [`deserialize_toml`] of a table made from `text` (a preset laid under it): errors name the
/// key and the line of `text` that holds it, when it does.
pub(crate) fn deserialize_table<T: serde::de::DeserializeOwned>(
    table: toml::Table,
    text: &str,
    file: &str,
) -> Result<T, SpecError> {
    serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
        let key = path_string(e.path());
        let line = line_of_key(text, &key);
        SpecError {
            file: file.into(),
            key,
            line,
            message: e.into_inner().message().trim().to_string(),
        }
    })
}

/// Deserializes TOML `text` into `T`; a syntax or schema error names `file`, the key path and
/// the line (the error's own span, else the key's line).
pub(crate) fn deserialize_toml<T: serde::de::DeserializeOwned>(
    text: &str,
    file: &str,
) -> Result<T, SpecError> {
    let de = toml::Deserializer::parse(text).map_err(|e| SpecError {
        file: file.into(),
        key: String::new(),
        line: e.span().map(|s| line_of_offset(text, s.start)),
        message: e.message().trim().to_string(),
    })?;
    serde_path_to_error::deserialize(de).map_err(|e| {
        let key = path_string(e.path());
        let inner = e.into_inner();
        let line = inner
            .span()
            .map(|s| line_of_offset(text, s.start))
            .or_else(|| line_of_key(text, &key));
        SpecError {
            file: file.into(),
            key,
            line,
            message: inner.message().trim().to_string(),
        }
    })
}
