//! `--set KEY=VALUE`: a mission key set from the command line, on top of the file, and
//! validated exactly as if the file said it.

use std::str::FromStr;

use super::{read_mission_file, ConfigError, Mission};

/// One `KEY=VALUE`: a dotted mission key (`control.law`, `links.loss`) and a TOML value
/// (`0.2`, `[1.0, 2.0]`, `"robust"`; a bare word is taken as a string: `control.law=paper`).
#[derive(Clone, Debug, PartialEq)]
pub struct KeySet {
    /// The dotted key, e.g. `links.loss`.
    pub key: String,
    /// Its value.
    pub value: toml::Value,
}

impl FromStr for KeySet {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (key, value) = s
            .split_once('=')
            .ok_or_else(|| format!("{s:?}: expected KEY=VALUE, e.g. links.loss=0.2"))?;
        let key = key.trim();
        let valid_part =
            |p: &str| !p.is_empty() && p.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if !key.split('.').all(valid_part) {
            return Err(format!(
                "{key:?}: a key is dotted words of [A-Za-z0-9_], e.g. control.law"
            ));
        }
        let value = value.trim();
        let parsed = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"));
        Ok(Self {
            key: key.to_string(),
            value: parsed.unwrap_or_else(|| toml::Value::String(value.to_string())),
        })
    }
}

impl std::fmt::Display for KeySet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}={}", self.key, self.value)
    }
}

impl Mission {
    /// Reads the mission file at `path`, sets `sets` on top of it (in order) and parses and
    /// validates the result; errors name the file, the `--set`s and the key.
    pub fn load_with(path: &std::path::Path, sets: &[KeySet]) -> Result<Mission, ConfigError> {
        let text = read_mission_file(path)?;
        Mission::from_toml_str_with(&text, &path.display().to_string(), sets)
    }

    /// [`Mission::from_toml_str`] with `sets` on top of `text`.
    pub fn from_toml_str_with(
        text: &str,
        origin: &str,
        sets: &[KeySet],
    ) -> Result<Mission, ConfigError> {
        if sets.is_empty() {
            return Mission::from_toml_str(text, origin);
        }
        let mut table: toml::Table = match text.parse() {
            Ok(t) => t,
            // The file's own error, told as for the file alone.
            Err(e) => {
                return Err(Mission::from_toml_str(text, origin)
                    .err()
                    .unwrap_or_else(|| ConfigError::Syntax {
                        origin: origin.to_string(),
                        line: 1,
                        column: 1,
                        message: e.to_string(),
                    }))
            }
        };
        let named: Vec<String> = sets.iter().map(|s| format!("--set {s}")).collect();
        let with = format!("{origin} with {}", named.join(" "));
        for set in sets {
            put(&mut table, set).map_err(|reason| ConfigError::Invalid {
                origin: with.clone(),
                key: set.key.clone(),
                value: set.value.to_string(),
                reason,
            })?;
        }
        let text = toml::to_string(&table).map_err(|e| ConfigError::Invalid {
            origin: with.clone(),
            key: named.join(" "),
            value: String::new(),
            reason: e.to_string(),
        })?;
        Mission::from_toml_str(&text, &with)
    }
}

/// Sets `set` into `table`, creating the tables on its path.
fn put(table: &mut toml::Table, set: &KeySet) -> Result<(), String> {
    let parts: Vec<&str> = set.key.split('.').collect();
    let (last, path) = parts.split_last().expect("a key has at least one part");
    let mut here = table;
    for (i, part) in path.iter().enumerate() {
        let entry = here
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        here = match entry {
            toml::Value::Table(t) => t,
            _ => {
                return Err(format!(
                    "{} is not a table: cannot set a key inside it",
                    parts[..=i].join(".")
                ))
            }
        };
    }
    here.insert(last.to_string(), set.value.clone());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[links]\nloss = 0.1\n";

    fn set(s: &str) -> KeySet {
        s.parse().unwrap()
    }

    #[test]
    fn values_are_toml_and_bare_words_are_strings() {
        assert_eq!(set("links.loss=0.2").value, toml::Value::Float(0.2));
        assert_eq!(set("vehicles.count = 5").value, toml::Value::Integer(5));
        assert_eq!(
            set("control.law=paper").value,
            toml::Value::String("paper".into())
        );
        assert_eq!(
            set("control.law=\"paper\"").value,
            toml::Value::String("paper".into())
        );
        assert!(matches!(
            set("vehicles.start=[1.0, 2.0]").value,
            toml::Value::Array(_)
        ));
        assert!("links.loss".parse::<KeySet>().is_err());
        assert!("links..loss=1".parse::<KeySet>().is_err());
        assert!("=1".parse::<KeySet>().is_err());
    }

    #[test]
    fn a_set_overrides_the_file_and_adds_missing_sections() {
        let m = Mission::from_toml_str_with(
            BASE,
            "m.toml",
            &[
                set("links.loss=0.3"),
                set("control.law=paper"),
                set("mission.seed=7"),
            ],
        )
        .unwrap();
        assert_eq!(m.links.loss, 0.3);
        assert_eq!(m.control.law, crate::config::LawKind::Paper);
        assert_eq!(m.mission.seed, 7);
        // Later sets win.
        let m = Mission::from_toml_str_with(
            BASE,
            "m.toml",
            &[set("links.loss=0.3"), set("links.loss=0.4")],
        )
        .unwrap();
        assert_eq!(m.links.loss, 0.4);
    }

    #[test]
    fn a_bad_set_is_refused_naming_the_key_and_the_set() {
        for (s, key) in [
            ("links.loss=2.0", "links.loss"),
            ("control.law=fast", "control.law"),
            ("links.lost=0.1", "lost"),
            ("mission.name.x=1", "mission.name"),
        ] {
            let e = Mission::from_toml_str_with(BASE, "m.toml", &[set(s)])
                .unwrap_err()
                .to_string();
            assert!(e.contains(key), "{s}: {e}");
            assert!(e.contains("m.toml with --set"), "{s}: {e}");
        }
    }
}
