//! The sweep of a batch: mission keys, each with a list of values, from `--sweep
//! KEY=V1,V2,…` and the mission file's `[batch.sweep]` table; the grid of all their
//! combinations, each grid point a mission.

use std::str::FromStr;

use serde::{Deserialize, Serialize};
use vbap_mission::config::{KeySet, Mission};

use super::criteria::SWEEP_KEY;
use vbap_ipc::process::InvalidInput;

/// One `--sweep KEY=V1,V2,…`: a dotted mission key and its values (TOML, a bare word a
/// string, as `--set`; the list is split at the commas outside brackets and quotes).
#[derive(Clone, Debug, PartialEq)]
pub struct SweepArg {
    /// The dotted key, e.g. `links.loss`.
    pub key: String,
    /// Its values, at least one.
    pub values: Vec<toml::Value>,
}

impl FromStr for SweepArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let (key, list) = s
            .split_once('=')
            .ok_or_else(|| format!("{s:?}: expected KEY=V1,V2,..., e.g. links.loss=0,0.1,0.2"))?;
        let key = key.trim();
        if list.trim().is_empty() {
            return Err(format!("{key}: empty list of values"));
        }
        let mut values = Vec::new();
        for part in split_list(list) {
            if part.trim().is_empty() {
                return Err(format!("{key}: an empty value in {list:?}"));
            }
            let set: KeySet = format!("{key}={part}").parse()?;
            values.push(set.value);
        }
        Ok(Self {
            key: key.to_string(),
            values,
        })
    }
}

/// `list` split at its top-level commas (not inside `[...]`, `{...}` or quotes).
fn split_list(list: &str) -> Vec<&str> {
    let (mut depth, mut quote, mut start) = (0i32, None::<char>, 0);
    let mut parts = Vec::new();
    for (i, c) in list.char_indices() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), _) => {}
            (None, '"' | '\'') => quote = Some(c),
            (None, '[' | '{') => depth += 1,
            (None, ']' | '}') => depth -= 1,
            (None, ',') if depth == 0 => {
                parts.push(&list[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&list[start..]);
    parts
}

/// A value as a label: a string without its quotes, anything else as TOML writes it.
pub fn label(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// A swept key and its values as labels (`batch.json`, `plan.json`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SweptKey {
    pub key: String,
    pub values: Vec<String>,
}

/// The sweep of a batch: the file's `[batch.sweep]` keys, then the command line's (a key
/// given on the command line replaces the file's list of that key).
pub fn resolve(cli: &[SweepArg], mission: &Mission) -> Result<Vec<SweepArg>, InvalidInput> {
    let origin = &mission.origin;
    let mut keys: Vec<SweepArg> = Vec::new();
    if let Some(table) = mission.batch.as_ref().and_then(|b| b.get(SWEEP_KEY)) {
        let toml::Value::Table(table) = table else {
            return Err(InvalidInput(format!(
                "{origin}: batch.{SWEEP_KEY}: must be a table of KEY = [values]"
            )));
        };
        flatten(table, "", origin, &mut keys)?;
    }
    for (i, arg) in cli.iter().enumerate() {
        if cli[..i].iter().any(|a| a.key == arg.key) {
            return Err(InvalidInput(format!(
                "--sweep {}: the key is swept twice",
                arg.key
            )));
        }
        match keys.iter_mut().find(|k| k.key == arg.key) {
            Some(k) => k.values = arg.values.clone(),
            None => keys.push(arg.clone()),
        }
    }
    for k in &keys {
        if k.key == "mission.seed" {
            return Err(InvalidInput(format!(
                "--sweep {}: the seed is swept by --seeds",
                k.key
            )));
        }
        let labels: Vec<String> = k.values.iter().map(label).collect();
        if let Some((_, l)) = labels
            .iter()
            .enumerate()
            .find(|(i, l)| labels[..*i].contains(l))
        {
            return Err(InvalidInput(format!(
                "--sweep {}: the value {l} is given twice",
                k.key
            )));
        }
    }
    Ok(keys)
}

/// The keys of a `[batch.sweep]` table (nested tables make dotted keys), each a non-empty
/// list.
fn flatten(
    table: &toml::Table,
    prefix: &str,
    origin: &str,
    out: &mut Vec<SweepArg>,
) -> Result<(), InvalidInput> {
    for (k, v) in table {
        let key = format!("{prefix}{k}");
        match v {
            toml::Value::Table(t) => flatten(t, &format!("{key}."), origin, out)?,
            toml::Value::Array(a) if !a.is_empty() => out.push(SweepArg {
                key,
                values: a.clone(),
            }),
            _ => {
                return Err(InvalidInput(format!(
                    "{origin}: batch.{SWEEP_KEY}.{key}: must be a non-empty list of values"
                )))
            }
        }
    }
    Ok(())
}

/// One grid point: one value of every swept key.
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// Its place in the grid (the first key varies slowest).
    pub index: usize,
    /// The keys set at this point, in the sweep's key order.
    pub sets: Vec<KeySet>,
}

impl Point {
    /// The values as labels, in key order.
    pub fn labels(&self) -> Vec<String> {
        self.sets.iter().map(|s| label(&s.value)).collect()
    }
    /// `links.loss=0.1, control.law=paper` (empty without a sweep).
    pub fn describe(&self) -> String {
        let parts: Vec<String> = self
            .sets
            .iter()
            .map(|s| format!("{}={}", s.key, label(&s.value)))
            .collect();
        parts.join(", ")
    }
    /// The name of its directory in the batch's output: `p<index>_<key>=<value>_…` (the
    /// characters a file name should not hold as `-`); `None` without a sweep.
    pub fn dir_name(&self) -> Option<String> {
        if self.sets.is_empty() {
            return None;
        }
        let mut name = format!("p{}", self.index);
        for s in &self.sets {
            name.push('_');
            name.push_str(&format!("{}={}", s.key, label(&s.value)));
        }
        let safe = |c: char| c.is_ascii_alphanumeric() || "._=+-".contains(c);
        Some(
            name.chars()
                .map(|c| if safe(c) { c } else { '-' })
                .collect(),
        )
    }
}

/// Every combination of the keys' values, the first key varying slowest; one point with no
/// keys set without a sweep.
pub fn grid(keys: &[SweepArg]) -> Vec<Point> {
    let mut points = vec![Vec::<KeySet>::new()];
    for k in keys {
        points = points
            .into_iter()
            .flat_map(|sets| {
                k.values.iter().map(move |v| {
                    let mut s = sets.clone();
                    s.push(KeySet {
                        key: k.key.clone(),
                        value: v.clone(),
                    });
                    s
                })
            })
            .collect();
    }
    points
        .into_iter()
        .enumerate()
        .map(|(index, sets)| Point { index, sets })
        .collect()
}

/// The swept keys as labels.
pub fn swept(keys: &[SweepArg]) -> Vec<SweptKey> {
    keys.iter()
        .map(|k| SweptKey {
            key: k.key.clone(),
            values: k.values.iter().map(label).collect(),
        })
        .collect()
}

/// The mission of every grid point: the file's `text` with `sets`, then the point's keys,
/// validated. Every value of every key is first checked alone, so that an error names the
/// key and the value (`--sweep links.loss=2: …`).
pub fn missions(
    text: &str,
    origin: &str,
    sets: &[KeySet],
    keys: &[SweepArg],
    points: &[Point],
) -> Result<Vec<Mission>, InvalidInput> {
    let with = |extra: &[KeySet]| {
        let all: Vec<KeySet> = sets.iter().chain(extra).cloned().collect();
        Mission::from_toml_str_with(text, origin, &all)
    };
    for k in keys {
        for v in &k.values {
            let set = KeySet {
                key: k.key.clone(),
                value: v.clone(),
            };
            with(std::slice::from_ref(&set))
                .map_err(|e| InvalidInput(format!("--sweep {}={}: {e}", k.key, label(v))))?;
        }
    }
    points
        .iter()
        .map(|p| {
            with(&p.sets)
                .map_err(|e| InvalidInput(format!("--sweep at grid point {}: {e}", p.describe())))
        })
        .collect()
}
