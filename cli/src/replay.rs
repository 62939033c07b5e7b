//! `vbap replay RUN_DIR`: re-run the planner offline on a run's recorded inputs and check
//! that it reproduces `body.csv` bit for bit.
//!
//! The coordinator records the arguments of every [`Planner::step`] in
//! `planner_inputs.csv` (see [`Recorder::inputs`]): role `both` (the report is a member's
//! latest and was delivered this tick), `member` (last known report, not fresh), `fresh`
//! (delivered this tick, not the member's latest) or `joined` (that member was admitted
//! back at this tick). A tick without any report has no row.
//! Replay rebuilds the planner from the resolved `mission.toml` exactly as the coordinator
//! does, steps it once per tick on the recorded arguments and writes the body rows with
//! the same [`Recorder`] the coordinator uses, into `RUN_DIR/replay/` (or `--out DIR`).
//! Floats are read with `str::parse::<f64>`, the exact inverse of the `Display` they were
//! written with, so the inputs are the planner's inputs to the last bit.
//!
//! Exit code: 0 when the replayed `body.csv` is byte-identical to the recorded one, 1 when
//! it is not (the first differing line is printed), 2 when the run directory is unusable.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use coordinator::planner::{Planner, PlannerParams, Report};
use coordinator::record::Recorder;
use serde::Deserialize;
use vbap_ipc::process::{EXIT_FAILURE, EXIT_OK};
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::rundir::{RunDir, Summary, INPUTS_HEADER};

use crate::errors::InvalidInput;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// The run directory (it needs mission.toml, planner_inputs.csv and body.csv).
    pub run_dir: PathBuf,
    /// Where to write the replayed files (default: RUN_DIR/replay/; replaced if present).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// What a replay found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ReplayOutcome {
    /// Ticks replayed.
    pub ticks: u64,
    /// Planner-input rows read.
    pub input_rows: u64,
    /// The replayed `body.csv`.
    pub body: PathBuf,
    /// `None` when the replayed `body.csv` equals the recorded one byte for byte, else the
    /// first difference.
    pub body_diff: Option<Difference>,
    /// `None` when re-recording the parsed inputs gives `planner_inputs.csv` back byte for
    /// byte (the parse was exact), else the first difference.
    pub inputs_diff: Option<Difference>,
}

/// The first differing line of two files.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Difference {
    /// 1-based line number.
    pub line: usize,
    /// The recorded line (`None`: the recorded file ended before).
    pub recorded: Option<String>,
    /// The replayed line (`None`: the replayed file ended before).
    pub replayed: Option<String>,
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let show = |l: &Option<String>| l.clone().unwrap_or_else(|| "(end of file)".into());
        write!(
            f,
            "first difference at line {}\n  recorded: {}\n  replayed: {}",
            self.line,
            show(&self.recorded),
            show(&self.replayed)
        )
    }
}

/// Runs the command; returns the exit code.
pub fn main(args: &ReplayArgs) -> Result<i32> {
    let outcome = replay(&args.run_dir, args.out.as_deref())?;
    println!(
        "replayed {} ticks ({} planner-input rows) of {}",
        outcome.ticks,
        outcome.input_rows,
        args.run_dir.display()
    );
    match &outcome.inputs_diff {
        None => println!("planner_inputs.csv: parsed exactly (re-recorded byte for byte)"),
        Some(d) => println!("planner_inputs.csv: NOT re-recorded identically, {d}"),
    }
    match &outcome.body_diff {
        None => {
            println!(
                "body.csv: identical ({} rows) -> {}",
                outcome.ticks,
                outcome.body.display()
            );
            Ok(EXIT_OK)
        }
        Some(d) => {
            println!(
                "body.csv: DIFFERS, {d}\n  replayed file: {}",
                outcome.body.display()
            );
            Ok(EXIT_FAILURE)
        }
    }
}

/// Replays the run in `run_dir`, writing into `out` (default `run_dir/replay`), and
/// compares the replayed `body.csv` and `planner_inputs.csv` with the recorded ones.
pub fn replay(run_dir: &Path, out: Option<&Path>) -> Result<ReplayOutcome> {
    let run = RunDir {
        root: run_dir.to_path_buf(),
    };
    for (file, what) in [
        (run.mission(), "mission.toml"),
        (run.planner_inputs(), "planner_inputs.csv"),
        (run.body(), "body.csv"),
    ] {
        if !file.is_file() {
            return Err(InvalidInput(format!(
                "{}: not a replayable run directory (no {what})",
                run_dir.display()
            ))
            .into());
        }
    }
    let mission = Mission::load(&run.mission())?;
    let out_root = match out {
        Some(p) => {
            if p.join("summary.json").exists() || same_dir(p, run_dir) {
                return Err(InvalidInput(format!(
                    "--out {}: holds a run; choose another directory",
                    p.display()
                ))
                .into());
            }
            p.to_path_buf()
        }
        None => run_dir.join("replay"),
    };
    std::fs::create_dir_all(&out_root)
        .with_context(|| format!("creating {}", out_root.display()))?;
    let replayed = RunDir { root: out_root };
    // The recorder appends: start from empty files.
    for f in [
        replayed.body(),
        replayed.vehicles(),
        replayed.planner_inputs(),
        replayed.events(),
    ] {
        if f.exists() {
            std::fs::remove_file(&f).with_context(|| format!("removing {}", f.display()))?;
        }
    }

    let ticks = recorded_ticks(&run)?;
    let dt = mission.mission.dt;
    let ids: Vec<u32> = (0..mission.vehicles.count as u32).collect();
    let mut planner = Planner::new(
        PlannerParams::from_mission(&mission),
        mission.start_vec(),
        &ids,
    )?;
    let mut recorder = Recorder::open(&mission, &replayed)
        .with_context(|| format!("opening the files of {}", replayed.root.display()))?;
    let mut inputs = InputsReader::open(&run.planner_inputs())?;
    let mut members = Vec::new();
    let mut fresh = Vec::new();
    let mut joined = Vec::new();
    for k in 0..ticks {
        inputs.tick(k, &mut members, &mut fresh, &mut joined)?;
        let command = planner
            .step(k, &members, &fresh, &joined, dt)
            .with_context(|| format!("replaying tick {k}"))?;
        recorder.inputs(k, &members, &fresh, &joined)?;
        // No truth is needed for body.csv: the true gradient comes from the mission's field.
        recorder.tick(k, &[], &[], &command)?;
    }
    inputs.finish(ticks)?;
    recorder.flush()?;
    drop(recorder);

    Ok(ReplayOutcome {
        ticks,
        input_rows: inputs.rows,
        body: replayed.body(),
        body_diff: first_difference(&run.body(), &replayed.body())?,
        inputs_diff: first_difference(&run.planner_inputs(), &replayed.planner_inputs())?,
    })
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}

/// The number of ticks the run recorded: `summary.json`'s `ticks`, or, for a run that
/// ended without a summary, the number of rows of `body.csv`.
fn recorded_ticks(run: &RunDir) -> Result<u64> {
    if let Ok(s) = Summary::read(run) {
        return Ok(s.ticks);
    }
    let file =
        File::open(run.body()).with_context(|| format!("opening {}", run.body().display()))?;
    let mut csv = csv::ReaderBuilder::new().flexible(true).from_reader(file);
    let width = csv
        .headers()
        .with_context(|| format!("reading {}", run.body().display()))?
        .len();
    let mut rows = 0u64;
    for record in csv.records() {
        let record = record.with_context(|| format!("reading {}", run.body().display()))?;
        // A run killed mid-write may leave a partial last line.
        if record.len() == width {
            rows += 1;
        }
    }
    Ok(rows)
}

/// Streams `planner_inputs.csv` tick by tick (rows are in tick order), read by column name.
struct InputsReader {
    path: PathBuf,
    csv: csv::Reader<File>,
    header: csv::StringRecord,
    record: csv::StringRecord,
    line_no: u64,
    pending: Option<(u64, Role, Report)>,
    rows: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Role {
    Both,
    Member,
    Fresh,
    Joined,
}

/// A row of `planner_inputs.csv` ([`INPUTS_HEADER`]).
#[derive(Deserialize)]
struct InputCsv {
    k: u64,
    role: Role,
    id: u32,
    tick: u64,
    x: f64,
    y: f64,
    z: f64,
    vx: f64,
    vy: f64,
    vz: f64,
    measurement: f64,
}

impl InputsReader {
    fn open(path: &Path) -> Result<Self> {
        let file = File::open(path).with_context(|| format!("opening {}", path.display()))?;
        let mut csv = csv::ReaderBuilder::new()
            .buffer_capacity(1 << 16)
            .from_reader(file);
        let header = csv
            .headers()
            .with_context(|| format!("reading {}", path.display()))?
            .clone();
        if let Some(missing) = INPUTS_HEADER
            .split(',')
            .find(|c| !header.iter().any(|h| h == *c))
        {
            return Err(InvalidInput(format!(
                "{}: line 1: no column {missing:?} in the header (expected {INPUTS_HEADER:?})",
                path.display()
            ))
            .into());
        }
        let mut reader = Self {
            path: path.to_path_buf(),
            csv,
            header,
            record: csv::StringRecord::new(),
            line_no: 1,
            pending: None,
            rows: 0,
        };
        reader.advance()?;
        Ok(reader)
    }

    fn bad(&self, why: String) -> anyhow::Error {
        InvalidInput(format!(
            "{}: line {}: {why}",
            self.path.display(),
            self.line_no
        ))
        .into()
    }

    /// Reads the next row into `pending`.
    fn advance(&mut self) -> Result<()> {
        self.pending = None;
        let more = match self.csv.read_record(&mut self.record) {
            Ok(more) => more,
            Err(e) => {
                self.line_no = e.position().map_or(self.line_no + 1, |p| p.line());
                return Err(self.bad(e.to_string()));
            }
        };
        if !more {
            return Ok(());
        }
        self.line_no = self
            .record
            .position()
            .map_or(self.line_no + 1, |p| p.line());
        let row: InputCsv = self.record.deserialize(Some(&self.header)).map_err(|e| {
            let column = match e.kind() {
                csv::ErrorKind::Deserialize { err, .. } => err
                    .field()
                    .and_then(|f| self.header.get(f as usize))
                    .map(|name| format!("column {name}: "))
                    .unwrap_or_default(),
                _ => String::new(),
            };
            self.bad(format!("{column}{e}"))
        })?;
        let report = Report {
            id: row.id,
            tick: row.tick,
            position: Vec3::new(row.x, row.y, row.z),
            velocity: Vec3::new(row.vx, row.vy, row.vz),
            measurement: row.measurement,
        };
        self.rows += 1;
        self.pending = Some((row.k, row.role, report));
        Ok(())
    }

    /// Fills `members`, `fresh` and `joined` with the planner arguments of tick `k`.
    fn tick(
        &mut self,
        k: u64,
        members: &mut Vec<Report>,
        fresh: &mut Vec<Report>,
        joined: &mut Vec<u32>,
    ) -> Result<()> {
        members.clear();
        fresh.clear();
        joined.clear();
        while let Some((row_k, role, report)) = self.pending {
            if row_k < k {
                return Err(self.bad(format!("tick {row_k} after tick {k}: rows out of order")));
            }
            if row_k > k {
                break;
            }
            match role {
                Role::Both => {
                    members.push(report);
                    fresh.push(report);
                }
                Role::Member => members.push(report),
                Role::Fresh => fresh.push(report),
                Role::Joined => joined.push(report.id),
            }
            self.advance()?;
        }
        Ok(())
    }

    /// Checks that no row is left beyond the last replayed tick.
    fn finish(&self, ticks: u64) -> Result<()> {
        match self.pending {
            Some((k, _, _)) => Err(self.bad(format!(
                "tick {k} is beyond the {ticks} ticks the run recorded"
            ))),
            None => Ok(()),
        }
    }
}

/// The first differing line of `recorded` and `replayed`, `None` when they are equal byte
/// for byte. Streams both files (`planner_inputs.csv` of a large fleet runs to gigabytes).
pub fn first_difference(recorded: &Path, replayed: &Path) -> Result<Option<Difference>> {
    let open = |p: &Path| -> Result<BufReader<File>> {
        Ok(BufReader::with_capacity(
            1 << 16,
            File::open(p).with_context(|| format!("opening {}", p.display()))?,
        ))
    };
    let (mut a, mut b) = (open(recorded)?, open(replayed)?);
    let (mut x, mut y) = (Vec::new(), Vec::new());
    let mut line = 0;
    loop {
        line += 1;
        x.clear();
        y.clear();
        let na = a
            .read_until(b'\n', &mut x)
            .with_context(|| format!("reading {}", recorded.display()))?;
        let nb = b
            .read_until(b'\n', &mut y)
            .with_context(|| format!("reading {}", replayed.display()))?;
        if na == 0 && nb == 0 {
            return Ok(None);
        }
        if x != y {
            let text = |l: &[u8], n: usize| {
                (n > 0).then(|| {
                    String::from_utf8_lossy(l)
                        .trim_end_matches('\n')
                        .to_string()
                })
            };
            return Ok(Some(Difference {
                line,
                recorded: text(&x, na),
                replayed: text(&y, nb),
            }));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An [`InputsReader`] of `text` (the file is removed once opened: the reader keeps it).
    fn reader(name: &str, text: &str) -> Result<InputsReader> {
        let path = std::env::temp_dir().join(format!("vbap-replay-{}-{name}", std::process::id()));
        std::fs::write(&path, text).unwrap();
        let r = InputsReader::open(&path);
        std::fs::remove_file(&path).unwrap();
        r
    }

    #[test]
    fn inputs_are_read_by_column_name() {
        // Columns in another order than INPUTS_HEADER read the same.
        let text = "role,k,id,tick,measurement,x,y,z,vx,vy,vz\nboth,0,3,0,0.1,1,2,0,0,0,0\nmember,1,3,0,0.1,1,2,0,0,0,0\njoined,1,4,1,7,0,0,0,0,0,0\n";
        let mut r = reader("ok.csv", text).unwrap();
        let (mut members, mut fresh, mut joined) = (Vec::new(), Vec::new(), Vec::new());
        r.tick(0, &mut members, &mut fresh, &mut joined).unwrap();
        assert_eq!((members.len(), fresh.len(), joined.len()), (1, 1, 0));
        assert_eq!(members[0].position, Vec3::new(1.0, 2.0, 0.0));
        assert_eq!(members[0].measurement.to_bits(), 0.1f64.to_bits());
        r.tick(1, &mut members, &mut fresh, &mut joined).unwrap();
        assert_eq!((members.len(), fresh.len(), joined), (1, 0, vec![4]));
        r.finish(2).unwrap();
        assert_eq!(r.rows, 3);
    }

    #[test]
    fn bad_inputs_name_the_file_line_and_column() {
        let missing = "k,role,id,tick,x,y,z,vx,vy,vz\n";
        let e = reader("missing.csv", missing).err().unwrap().to_string();
        assert!(
            e.contains("missing.csv") && e.contains("\"measurement\""),
            "{e}"
        );
        let bad =
            format!("{INPUTS_HEADER}\n0,both,0,0,1,1,0,0,0,0,1\n1,asleep,0,0,1,1,0,0,0,0,1\n");
        let mut r = reader("bad.csv", &bad).unwrap();
        let (mut m, mut f, mut j) = (Vec::new(), Vec::new(), Vec::new());
        let e = r.tick(0, &mut m, &mut f, &mut j).unwrap_err();
        assert!(e.downcast_ref::<InvalidInput>().is_some(), "exit code 2");
        let e = e.to_string();
        assert!(e.contains("line 3") && e.contains("asleep"), "{e}");
    }
}
