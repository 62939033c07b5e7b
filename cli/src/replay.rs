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
use std::io::{BufRead, BufReader, Lines};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use coordinator::planner::{Planner, PlannerParams, Report};
use coordinator::record::Recorder;
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
        recorder.tick(k, &[], &command)?;
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
    let mut rows = 0u64;
    for line in BufReader::new(file).lines().skip(1) {
        let line = line.with_context(|| format!("reading {}", run.body().display()))?;
        // A run killed mid-write may leave a partial last line.
        if line.split(',').count() == vbap_mission::rundir::BODY_HEADER.split(',').count() {
            rows += 1;
        }
    }
    Ok(rows)
}

/// Streams `planner_inputs.csv` tick by tick (rows are in tick order).
struct InputsReader {
    path: PathBuf,
    lines: Lines<BufReader<File>>,
    line_no: usize,
    pending: Option<(u64, Role, Report)>,
    rows: u64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Both,
    Member,
    Fresh,
    Joined,
}

impl InputsReader {
    fn open(path: &Path) -> Result<Self> {
        let file = File::open(path).with_context(|| format!("opening {}", path.display()))?;
        let mut lines = BufReader::new(file).lines();
        let header = lines
            .next()
            .transpose()
            .with_context(|| format!("reading {}", path.display()))?
            .unwrap_or_default();
        if header != INPUTS_HEADER {
            return Err(InvalidInput(format!(
                "{}: line 1: header is {header:?}, expected {INPUTS_HEADER:?}",
                path.display()
            ))
            .into());
        }
        let mut reader = Self {
            path: path.to_path_buf(),
            lines,
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
        let Some(line) = self.lines.next() else {
            return Ok(());
        };
        self.line_no += 1;
        let line = line.with_context(|| format!("reading {}", self.path.display()))?;
        let cols: Vec<&str> = line.split(',').collect();
        if cols.len() != INPUTS_HEADER.split(',').count() {
            return Err(self.bad(format!(
                "{} columns, expected {}",
                cols.len(),
                INPUTS_HEADER.split(',').count()
            )));
        }
        let int = |i: usize| {
            cols[i]
                .parse::<u64>()
                .map_err(|e| self.bad(format!("column {i} ({:?}): {e}", cols[i])))
        };
        let float = |i: usize| {
            cols[i]
                .parse::<f64>()
                .map_err(|e| self.bad(format!("column {i} ({:?}): {e}", cols[i])))
        };
        let role = match cols[1] {
            "both" => Role::Both,
            "member" => Role::Member,
            "fresh" => Role::Fresh,
            "joined" => Role::Joined,
            other => {
                return Err(self.bad(format!(
                    "role {other:?}: expected \"both\", \"member\", \"fresh\" or \"joined\""
                )))
            }
        };
        let k = int(0)?;
        let id = u32::try_from(int(2)?).map_err(|e| self.bad(format!("id: {e}")))?;
        let report = Report {
            id,
            tick: int(3)?,
            position: Vec3::new(float(4)?, float(5)?, float(6)?),
            velocity: Vec3::new(float(7)?, float(8)?, float(9)?),
            measurement: float(10)?,
        };
        self.rows += 1;
        self.pending = Some((k, role, report));
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
