//! `vbap compare A B`: are two run directories the same run? Every file a run writes from
//! mission time alone is compared byte for byte; `summary.json` is compared as JSON without
//! its wall-clock fields. Used to show that a change of the code left the results alone
//! (`deploy/compare_with.sh`), and that `vbap run` equals `vbap sim`.

use std::path::{Path, PathBuf};

use anyhow::Result;
use serde_json::Value;
use vbap_ipc::process::{EXIT_FAILURE, EXIT_OK};

use crate::errors::InvalidInput;

/// Arguments of `vbap compare`.
#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// The first run directory.
    pub a: PathBuf,
    /// The second run directory.
    pub b: PathBuf,
    /// Compare the track files only (`vehicles.csv`, `body.csv`, `events.jsonl`,
    /// `formation.csv`, `truth.csv`): what `vbap sim` and a lockstep `vbap run` share
    /// (their summaries differ in `mode` and message counts, their pictures in nothing).
    #[arg(long)]
    pub tracks: bool,
    /// A top-level field of `summary.json` to leave out as well (repeatable), e.g.
    /// `messages` for runs with a SIGKILL: how far the victim read ahead before it died
    /// is wall-clock timing.
    #[arg(long = "ignore", value_name = "FIELD")]
    pub ignore: Vec<String>,
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
}

/// The files of a run that depend on mission time only, compared byte for byte.
pub const DETERMINISTIC_FILES: [&str; 11] = [
    "vehicles.csv",
    "body.csv",
    "events.jsonl",
    "formation.csv",
    "truth.csv",
    "planner_inputs.csv",
    "mission.toml",
    "plot.svg",
    "timeseries_formation.svg",
    "timeseries_estimate.svg",
    "contact.svg",
];

/// The track files: what every way of running a mission writes alike.
pub const TRACK_FILES: [&str; 5] = [
    "vehicles.csv",
    "body.csv",
    "events.jsonl",
    "formation.csv",
    "truth.csv",
];

/// Fields of `summary.json` measured with the wall clock (left out of the comparison).
pub const WALL_CLOCK_FIELDS: [&str; 4] = [
    "wall_time_s",
    "latency_us",
    "detection_latency_ms",
    "rejoin_latency_ms",
];

/// How one file of the two runs compares.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(tag = "outcome", rename_all = "snake_case")]
pub enum FileOutcome {
    /// Identical (for `summary.json`: apart from the wall-clock fields).
    Same,
    /// Different; the first differing line (1-based) when both are text.
    Differs { line: Option<usize> },
    /// In one run directory only.
    OnlyIn { dir: char },
    /// In neither: not compared.
    Absent,
}

/// One row of the comparison.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FileComparison {
    pub file: String,
    #[serde(flatten)]
    pub outcome: FileOutcome,
}

/// Compares the run directories `a` and `b` (the track files only if `tracks_only`;
/// `summary.json` without its wall-clock fields and the fields `ignore`).
pub fn compare(
    a: &Path,
    b: &Path,
    tracks_only: bool,
    ignore: &[String],
) -> Result<Vec<FileComparison>> {
    for dir in [a, b] {
        if !dir.join("mission.toml").is_file() {
            return Err(InvalidInput(format!(
                "{}: not a run directory (no mission.toml)",
                dir.display()
            ))
            .into());
        }
    }
    let files: &[&str] = if tracks_only {
        &TRACK_FILES
    } else {
        &DETERMINISTIC_FILES
    };
    let mut rows: Vec<FileComparison> = files
        .iter()
        .map(|f| FileComparison {
            file: (*f).to_string(),
            outcome: compare_bytes(&a.join(f), &b.join(f)),
        })
        .collect();
    if !tracks_only {
        rows.push(FileComparison {
            file: "summary.json".into(),
            outcome: compare_summaries(&a.join("summary.json"), &b.join("summary.json"), ignore)?,
        });
    }
    Ok(rows)
}

/// Byte comparison of two files that may be missing.
fn compare_bytes(a: &Path, b: &Path) -> FileOutcome {
    match (std::fs::read(a), std::fs::read(b)) {
        (Ok(x), Ok(y)) if x == y => FileOutcome::Same,
        (Ok(x), Ok(y)) => FileOutcome::Differs {
            line: first_differing_line(&x, &y),
        },
        (Ok(_), Err(_)) => FileOutcome::OnlyIn { dir: 'A' },
        (Err(_), Ok(_)) => FileOutcome::OnlyIn { dir: 'B' },
        (Err(_), Err(_)) => FileOutcome::Absent,
    }
}

/// The first line (1-based) where two texts differ, or None when either is not UTF-8.
fn first_differing_line(x: &[u8], y: &[u8]) -> Option<usize> {
    let (x, y) = (std::str::from_utf8(x).ok()?, std::str::from_utf8(y).ok()?);
    let mut xs = x.lines();
    let mut ys = y.lines();
    let mut n = 0;
    loop {
        n += 1;
        match (xs.next(), ys.next()) {
            (Some(p), Some(q)) if p == q => continue,
            (None, None) => return None,
            _ => return Some(n),
        }
    }
}

/// `summary.json` of both runs as JSON, without the wall-clock fields and `ignore`.
fn compare_summaries(a: &Path, b: &Path, ignore: &[String]) -> Result<FileOutcome> {
    let read = |p: &Path| -> Result<Option<Value>> {
        match std::fs::read_to_string(p) {
            Ok(text) => {
                let mut v: Value = serde_json::from_str(&text)
                    .map_err(|e| InvalidInput(format!("{}: not JSON: {e}", p.display())))?;
                if let Some(map) = v.as_object_mut() {
                    for f in WALL_CLOCK_FIELDS {
                        map.remove(f);
                    }
                    for f in ignore {
                        map.remove(f);
                    }
                }
                Ok(Some(v))
            }
            Err(_) => Ok(None),
        }
    };
    Ok(match (read(a)?, read(b)?) {
        (Some(x), Some(y)) if x == y => FileOutcome::Same,
        (Some(_), Some(_)) => FileOutcome::Differs { line: None },
        (Some(_), None) => FileOutcome::OnlyIn { dir: 'A' },
        (None, Some(_)) => FileOutcome::OnlyIn { dir: 'B' },
        (None, None) => FileOutcome::Absent,
    })
}

/// `vbap compare`: prints the comparison; exit 0 when every file present is the same, 1
/// otherwise, 2 when a directory is not a run directory.
pub fn main(args: &CompareArgs) -> Result<i32> {
    let rows = compare(&args.a, &args.b, args.tracks, &args.ignore)?;
    let same = rows
        .iter()
        .all(|r| matches!(r.outcome, FileOutcome::Same | FileOutcome::Absent));
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        println!("A = {}\nB = {}", args.a.display(), args.b.display());
        for r in &rows {
            let what = match &r.outcome {
                FileOutcome::Same => "same".to_string(),
                FileOutcome::Differs { line: Some(l) } => format!("DIFFERS (first at line {l})"),
                FileOutcome::Differs { line: None } => "DIFFERS".to_string(),
                FileOutcome::OnlyIn { dir } => format!("only in {dir}"),
                FileOutcome::Absent => "in neither".to_string(),
            };
            println!("  {:<26} {what}", r.file);
        }
        println!(
            "{}",
            if same {
                "the same run"
            } else {
                "different runs"
            }
        );
    }
    Ok(if same { EXIT_OK } else { EXIT_FAILURE })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run_dir(files: &[(&str, &str)]) -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("mission.toml"), "[mission]\n").unwrap();
        for (name, text) in files {
            std::fs::write(d.path().join(name), text).unwrap();
        }
        d
    }

    fn outcome(rows: &[FileComparison], file: &str) -> FileOutcome {
        rows.iter()
            .find(|r| r.file == file)
            .unwrap()
            .outcome
            .clone()
    }

    #[test]
    fn wall_clock_fields_are_left_out_and_everything_else_counts() {
        let a = run_dir(&[
            ("body.csv", "k,x\n0,1\n1,2\n"),
            (
                "summary.json",
                r#"{"verdict":"converged","wall_time_s":1.0,"latency_us":{}}"#,
            ),
        ]);
        let b = run_dir(&[
            ("body.csv", "k,x\n0,1\n1,3\n"),
            (
                "summary.json",
                r#"{"verdict":"converged","wall_time_s":9.5,"latency_us":{"a":1}}"#,
            ),
            ("plot.svg", "<svg/>"),
        ]);
        let rows = compare(a.path(), b.path(), false, &[]).unwrap();
        assert_eq!(outcome(&rows, "summary.json"), FileOutcome::Same);
        assert_eq!(
            outcome(&rows, "body.csv"),
            FileOutcome::Differs { line: Some(3) }
        );
        assert_eq!(outcome(&rows, "plot.svg"), FileOutcome::OnlyIn { dir: 'B' });
        assert_eq!(outcome(&rows, "truth.csv"), FileOutcome::Absent);
        assert_eq!(outcome(&rows, "mission.toml"), FileOutcome::Same);
    }

    #[test]
    fn a_verdict_that_differs_is_a_different_run() {
        let a = run_dir(&[("summary.json", r#"{"verdict":"converged"}"#)]);
        let b = run_dir(&[("summary.json", r#"{"verdict":"stalled"}"#)]);
        let rows = compare(a.path(), b.path(), false, &[]).unwrap();
        assert_eq!(
            outcome(&rows, "summary.json"),
            FileOutcome::Differs { line: None }
        );
    }

    #[test]
    fn an_ignored_field_is_left_out() {
        let a = run_dir(&[(
            "summary.json",
            r#"{"verdict":"converged","messages":{"sent":5}}"#,
        )]);
        let b = run_dir(&[(
            "summary.json",
            r#"{"verdict":"converged","messages":{"sent":7}}"#,
        )]);
        let rows = compare(a.path(), b.path(), false, &["messages".into()]).unwrap();
        assert_eq!(outcome(&rows, "summary.json"), FileOutcome::Same);
        let rows = compare(a.path(), b.path(), false, &[]).unwrap();
        assert_eq!(
            outcome(&rows, "summary.json"),
            FileOutcome::Differs { line: None }
        );
    }

    #[test]
    fn a_directory_without_mission_toml_is_refused() {
        let a = run_dir(&[]);
        let b = tempfile::tempdir().unwrap();
        let e = compare(a.path(), b.path(), false, &[]).unwrap_err();
        assert!(e.downcast_ref::<InvalidInput>().is_some(), "{e}");
        assert!(e.to_string().contains("no mission.toml"), "{e}");
    }
}
