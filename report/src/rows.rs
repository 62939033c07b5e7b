//! The rows of the run directory's CSV files as the reports read them: by column name
//! (serde row structs over the header), so a column added or moved does not shift a figure.
//! A partial last line of an interrupted run (fewer fields than the header) is skipped.

use std::io::Read;
use std::path::Path;

use anyhow::{Context, Result};
use serde::de::DeserializeOwned;
use serde::Deserialize;

/// A row struct of a CSV file: deserialised by column name; [`CsvRow::COLUMNS`] must all be
/// in the header (an `Option` field would silently read a missing column as empty).
pub trait CsvRow: DeserializeOwned {
    /// The columns the file must have.
    const COLUMNS: &'static [&'static str];
}

/// A row of `body.csv` (`vbap_wire::rundir::BODY_HEADER`); the estimator and truth columns are
/// optional (older runs have none).
#[derive(Clone, Debug, Deserialize)]
pub struct BodyCsv {
    pub t: f64,
    pub k: u64,
    pub sdot: f64,
    pub rx: f64,
    pub ry: f64,
    pub rz: f64,
    pub scale: f64,
    pub grad_x: f64,
    pub grad_y: f64,
    pub grad_z: f64,
    #[serde(rename = "V")]
    pub v: f64,
    pub n_vehicles: f64,
    #[serde(default)]
    pub p_trace: Option<f64>,
    #[serde(default)]
    pub true_grad_x: Option<f64>,
    #[serde(default)]
    pub true_grad_y: Option<f64>,
    #[serde(default)]
    pub true_grad_z: Option<f64>,
}

impl CsvRow for BodyCsv {
    const COLUMNS: &'static [&'static str] = &[
        "t",
        "k",
        "sdot",
        "rx",
        "ry",
        "rz",
        "scale",
        "grad_x",
        "grad_y",
        "grad_z",
        "V",
        "n_vehicles",
    ];
}

/// The body centre of a row of `body.csv`: what the mission plot needs.
#[derive(Clone, Debug, Deserialize)]
pub struct BodyPathCsv {
    pub t: f64,
    pub k: u64,
    pub rx: f64,
    pub ry: f64,
    pub rz: f64,
}

impl CsvRow for BodyPathCsv {
    const COLUMNS: &'static [&'static str] = &["t", "k", "rx", "ry", "rz"];
}

/// A row of `vehicles.csv` (`vbap_wire::rundir::VEHICLES_HEADER`), the columns the plot needs.
#[derive(Clone, Debug, Deserialize)]
pub struct VehicleCsv {
    pub k: u64,
    pub id: u32,
    pub x: f64,
    pub y: f64,
}

impl CsvRow for VehicleCsv {
    const COLUMNS: &'static [&'static str] = &["k", "id", "x", "y"];
}

/// A row of `formation.csv` (`vbap_wire::rundir::FORMATION_HEADER`); an empty field is `None`.
#[derive(Clone, Debug, Deserialize)]
pub struct FormationCsv {
    pub t: f64,
    pub k: u64,
    pub id: u32,
    pub contact: String,
    pub info_age_s: Option<f64>,
    pub slot_error: Option<f64>,
    #[allow(dead_code)]
    pub nearest_ratio: Option<f64>,
    pub in_formation: u8,
}

impl CsvRow for FormationCsv {
    const COLUMNS: &'static [&'static str] = &[
        "t",
        "k",
        "id",
        "contact",
        "info_age_s",
        "slot_error",
        "nearest_ratio",
        "in_formation",
    ];
}

/// A row of `truth.csv` (`vbap_wire::rundir::TRUTH_HEADER`); an empty field is `None`.
#[derive(Clone, Debug, Deserialize)]
#[allow(non_snake_case)]
pub struct TruthCsv {
    pub t: f64,
    pub V_true_over_VU: Option<f64>,
    pub V_seen_over_VU: Option<f64>,
    pub min_pair_ratio: Option<f64>,
    pub max_slot_error: Option<f64>,
    pub n_alive: Option<f64>,
    pub n_in_formation: Option<f64>,
}

impl CsvRow for TruthCsv {
    const COLUMNS: &'static [&'static str] = &[
        "t",
        "k",
        "V_true_over_VU",
        "V_seen_over_VU",
        "min_pair_ratio",
        "max_slot_error",
        "n_alive",
        "n_in_formation",
        "sdot_over_v0",
    ];
}

/// Streams the complete rows of the CSV text `reader` (`path` names it in errors) to `row`
/// as `T`, read by column name, with the 1-based line number. An error names the file, the
/// line and the field (a missing column, a value that does not parse).
pub fn for_each_row<T: CsvRow>(
    path: &Path,
    reader: impl Read,
    mut row: impl FnMut(u64, T) -> Result<()>,
) -> Result<()> {
    let mut csv = csv::ReaderBuilder::new()
        .flexible(true)
        .buffer_capacity(1 << 16)
        .from_reader(reader);
    let header = csv
        .headers()
        .with_context(|| format!("reading {}", path.display()))?
        .clone();
    if header.is_empty() {
        anyhow::bail!("{}: empty file, no header", path.display());
    }
    if let Some(missing) = T::COLUMNS.iter().find(|c| !header.iter().any(|h| h == **c)) {
        anyhow::bail!("{}: no column {missing:?} in the header", path.display());
    }
    let mut record = csv::StringRecord::new();
    while csv
        .read_record(&mut record)
        .with_context(|| format!("reading {}", path.display()))?
    {
        if record.len() != header.len() {
            // A partial last line of an interrupted run.
            continue;
        }
        let line = record.position().map_or(0, |p| p.line());
        let value: T = record.deserialize(Some(&header)).map_err(|e| {
            let column = match e.kind() {
                csv::ErrorKind::Deserialize { err, .. } => err
                    .field()
                    .and_then(|f| header.get(f as usize))
                    .map(|name| format!(": column {name}"))
                    .unwrap_or_default(),
                _ => String::new(),
            };
            anyhow::anyhow!("{} line {line}{column}: {e}", path.display())
        })?;
        row(line, value)?;
    }
    Ok(())
}

/// [`for_each_row`] over the file at `path`.
pub fn for_each_row_of<T: CsvRow>(
    path: &Path,
    row: impl FnMut(u64, T) -> Result<()>,
) -> Result<()> {
    let file = std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
    for_each_row(path, file, row)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, PartialEq)]
    struct Row {
        b: f64,
        a: Option<f64>,
    }

    impl CsvRow for Row {
        const COLUMNS: &'static [&'static str] = &["a", "b"];
    }

    #[test]
    fn rows_are_read_by_name_and_partial_lines_skipped() {
        let text = "a,x,b\n1,zz,0.1\n,yy,2e-300\n3,ww";
        let mut rows = Vec::new();
        for_each_row(Path::new("f.csv"), text.as_bytes(), |line, r: Row| {
            rows.push((line, r));
            Ok(())
        })
        .unwrap();
        assert_eq!(
            rows,
            vec![
                (
                    2,
                    Row {
                        b: 0.1,
                        a: Some(1.0)
                    }
                ),
                (3, Row { b: 2e-300, a: None })
            ]
        );
        // Floats read back exactly (the files write the shortest round-trip form).
        let v = 0.1f64 + 0.2;
        let text = format!("a,b\n,{v}\n");
        for_each_row(Path::new("f.csv"), text.as_bytes(), |_, r: Row| {
            assert_eq!(r.b.to_bits(), v.to_bits());
            Ok(())
        })
        .unwrap();
    }

    #[test]
    fn a_missing_column_or_a_bad_value_names_file_and_line() {
        let err =
            for_each_row(Path::new("f.csv"), "b\n1\n".as_bytes(), |_, _: Row| Ok(())).unwrap_err();
        let msg = format!("{err:#}");
        assert!(msg.contains("f.csv") && msg.contains("\"a\""), "{msg}");
        let err = for_each_row(Path::new("g.csv"), "a,b\n1,x\n".as_bytes(), |_, _: Row| {
            Ok(())
        })
        .unwrap_err();
        let msg = format!("{err:#}");
        assert!(msg.contains("g.csv line 2: column b"), "{msg}");
    }
}
