//! Reading and parsing a mission file: the size limit, TOML syntax, the schema (unknown,
//! mistyped and missing keys, each located by dotted key, line and column) and the keys
//! every mission must give. Value checks are in [`super::validate`].

use std::path::Path;

use super::sections::FieldKind;
use super::validate::Check;
use super::{ConfigError, Mission, MAX_FILE_BYTES};

/// 1-based (line, column) of byte offset `pos` in `text`.
fn line_column(text: &str, pos: usize) -> (usize, usize) {
    let pos = pos.min(text.len());
    let before = text.get(..pos).unwrap_or(text);
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

/// Whether a span contains byte offset `pos` (an empty span contains its start).
fn span_has(span: &std::ops::Range<usize>, pos: usize) -> bool {
    span.contains(&pos) || (span.is_empty() && span.start == pos)
}

/// Dotted path (`field.bumps[1].width`) of the innermost key or value at byte offset `pos`.
fn key_path_at(table: &toml::de::DeTable<'_>, pos: usize) -> Option<String> {
    use toml::de::DeValue;
    fn in_value(v: &toml::Spanned<DeValue<'_>>, pos: usize, path: String) -> Option<String> {
        match v.get_ref() {
            DeValue::Table(t) => {
                if let Some(inner) = key_path_at(t, pos) {
                    return Some(format!("{path}.{inner}"));
                }
            }
            DeValue::Array(a) => {
                for (i, e) in a.iter().enumerate() {
                    if let Some(p) = in_value(e, pos, format!("{path}[{i}]")) {
                        return Some(p);
                    }
                }
            }
            _ => {}
        }
        span_has(&v.span(), pos).then_some(path)
    }
    for (k, v) in table.iter() {
        if span_has(&k.span(), pos) {
            return Some(k.get_ref().to_string());
        }
        if let Some(p) = in_value(v, pos, k.get_ref().to_string()) {
            return Some(p);
        }
    }
    None
}

/// Whether the document `table` has the key at the dotted path `path`.
fn has_key(table: &toml::de::DeTable<'_>, path: &[&str]) -> bool {
    use toml::de::DeValue;
    let Some((first, rest)) = path.split_first() else {
        return true;
    };
    let Some((_, v)) = table.iter().find(|(k, _)| k.get_ref() == first) else {
        return false;
    };
    match (rest.is_empty(), v.get_ref()) {
        (true, _) => true,
        (false, DeValue::Table(t)) => has_key(t, rest),
        _ => false,
    }
}

/// Reads a mission file, refusing one larger than [`MAX_FILE_BYTES`] after reading at most
/// one byte more (so `/dev/zero` or a wrong multi-gigabyte path fails at once).
pub fn read_mission_file(path: &Path) -> Result<String, ConfigError> {
    use std::io::Read;
    let origin = path.display().to_string();
    let read_err = |source| ConfigError::Read {
        origin: origin.clone(),
        source,
    };
    let file = std::fs::File::open(path).map_err(read_err)?;
    let mut bytes = Vec::new();
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(read_err)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(ConfigError::TooLarge {
            origin,
            limit: MAX_FILE_BYTES,
        });
    }
    String::from_utf8(bytes).map_err(|e| {
        read_err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text ({e})"),
        ))
    })
}

impl Mission {
    /// Reads, parses and validates the mission file at `path`.
    pub fn load(path: &Path) -> Result<Mission, ConfigError> {
        let text = read_mission_file(path)?;
        Mission::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses and validates a mission from TOML `text`; `origin` names it in errors (a path,
    /// or something like `<string>`).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Mission, ConfigError> {
        // Syntax first, so syntax errors are told apart from schema errors.
        let doc = toml::de::DeTable::parse(text).map_err(|e| {
            let (line, column) = line_column(text, e.span().map_or(0, |s| s.start));
            ConfigError::Syntax {
                origin: origin.to_string(),
                line,
                column,
                message: e.message().to_string(),
            }
        })?;
        let mut mission: Mission = toml::from_str(text).map_err(|e| {
            let pos = e.span().map_or(0, |s| s.start);
            let (line, column) = line_column(text, pos);
            let message = e.message().to_string();
            let mut key = key_path_at(doc.get_ref(), pos).unwrap_or_else(|| "(top level)".into());
            // "missing field `at`" points at the table: name the missing key.
            if let Some(missing) = message
                .strip_prefix("missing field `")
                .and_then(|m| m.strip_suffix('`'))
            {
                key = if key == "(top level)" {
                    missing.to_string()
                } else {
                    format!("{key}.{missing}")
                };
            }
            ConfigError::Schema {
                origin: origin.to_string(),
                key,
                line,
                column,
                message,
            }
        })?;
        mission.origin = origin.to_string();
        mission.require_keys(doc.get_ref())?;
        mission.validate()?;
        // A grid file is named relative to the mission file (`origin` is its path, perhaps
        // followed by " with --set ...").
        let path = origin.split(" with --set ").next().unwrap_or(origin);
        mission.load_grid(Path::new(path).parent())?;
        Ok(mission)
    }

    /// Refuses a document without `[mission] name` or without the `[field]` keys its kind
    /// needs ([`FieldKind::required_keys`]): those have no meaningful default.
    fn require_keys(&self, doc: &toml::de::DeTable<'_>) -> Result<(), ConfigError> {
        let c = Check {
            origin: &self.origin,
        };
        if !has_key(doc, &["mission", "name"]) {
            return Err(c.fail(
                "mission.name",
                "(missing)",
                format!(
                    "required: a mission file gives at least [mission] name and the [field] keys of \
                     its field.kind (\"gaussian\", the default: {}); an empty or comment-only file is no mission",
                    FieldKind::Gaussian.required_keys().join(", ")
                ),
            ));
        }
        let kind = self.field.kind;
        let given = has_key(doc, &["field", "kind"]);
        for key in kind.required_keys() {
            if !has_key(doc, &["field", key]) {
                return Err(c.fail(
                    &format!("field.{key}"),
                    "(missing)",
                    format!(
                        "required for field.kind = {:?}{} (no meaningful default); it needs {}",
                        kind.as_str(),
                        if given { "" } else { " (the default kind)" },
                        kind.required_keys().join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }
}
