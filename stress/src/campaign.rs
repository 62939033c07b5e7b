//! The campaign: sample every mission, fly each (under each law) on `jobs` worker threads,
//! judge it, shrink it when it failed, append its result line, and make the table.
//!
//! Files of the campaign directory `OUT/`:
//! - `plan.json`: what the campaign is (missions, seed, laws, bound, shrink, `--set`s); a
//!   campaign started again on `OUT` with the same plan resumes, another plan is refused;
//! - `grid.nc`: the synthetic grid of the `grid` draws (written once);
//! - `results.jsonl`: one [`FlightResult`] line per flight, appended as each finishes; a
//!   resumed campaign skips every flight with a whole line (a torn last line is flown again);
//! - `runs/m<i>_<law>/`: a flight's run directory, deleted when it passed;
//! - `failures/m<i>_<law>.toml` (and `.shrunk.toml`): the failing missions, resolved, for
//!   `vbap sim FILE.toml`;
//! - `stress.json`, `stress.md`: the table.

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use anyhow::{Context, Result};

use vbap_mission::config::{ConfigError, KeySet, Mission};
use vbap_mission::rundir::{RunDir, Summary};

use crate::draw::Draw;
use crate::grid::{write_grid, GRID_FILE};
use crate::judge::{judge_dir, Judgement, CRITERIA};
use crate::results::{flight_name, Dims, FlightResult, Plan, ShrunkResult};
use crate::shrink::{shrink, Shrunk};
use crate::space::Space;
use crate::table::Table;

/// Flies a mission into a run directory (the in-process simulator in `vbap`), returning
/// its summary. It must write `summary.json` and `truth.csv` there as `vbap sim` does.
pub type Flyer<'a> = &'a (dyn Fn(&Mission, &RunDir) -> Result<Summary> + Sync);

/// Most attempts at drawing a valid mission for one index.
pub const MAX_ATTEMPTS: u64 = 100;
/// The plan file.
pub const PLAN_FILE: &str = "plan.json";
/// The results file, one JSON line per flight.
pub const RESULTS_FILE: &str = "results.jsonl";

/// Bad input to a campaign (exit 2 in `vbap stress`): the message names what is wrong.
#[derive(Debug)]
pub struct BadInput(pub String);

impl std::fmt::Display for BadInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BadInput {}

/// What a campaign runs.
#[derive(Clone, Debug)]
pub struct Config {
    /// Missions sampled (indices 0..missions).
    pub missions: u64,
    /// The campaign seed S: mission i is a pure function of (S, i).
    pub seed: u64,
    /// The campaign directory.
    pub out: PathBuf,
    /// Worker threads.
    pub jobs: usize,
    /// The laws every mission flies under (`control.law` values).
    pub laws: Vec<String>,
    /// The bound on the true V ÷ V_U after first contact.
    pub v_bound: f64,
    /// Shrink every failure.
    pub shrink: bool,
    /// Keys set on every sampled mission (`--set`).
    pub sets: Vec<KeySet>,
    /// The space.
    pub space: Space,
    /// Print a line per flight on stderr.
    pub verbose: bool,
    /// Fly only these indices of 0..missions (sorted, distinct); empty: all of them.
    /// Mission i is the same draw with or without it, so a failure of a large campaign
    /// is flown again alone.
    pub only: Vec<u64>,
}

impl Plan {
    fn of(c: &Config) -> Plan {
        Plan {
            missions: c.missions,
            seed: c.seed,
            laws: c.laws.clone(),
            v_bound: c.v_bound,
            shrink: c.shrink,
            sets: c.sets.iter().map(|s| s.to_string()).collect(),
            space: c.space.to_string(),
            only: c.only.clone(),
        }
    }
}

/// One sampled mission: its draw, and how many invalid draws came before it, by the
/// validator's key.
#[derive(Clone, Debug)]
pub struct Sampled {
    pub draw: Draw,
    pub redraws: Vec<String>,
}

/// The mission of `draw` flying `law`, with `sets` on top, parsed and validated by the
/// real mission parser (as `vbap check`).
pub fn mission_of(
    draw: &Draw,
    law: &str,
    grid: &Path,
    sets: &[KeySet],
) -> Result<Mission, ConfigError> {
    let origin = format!("stress mission {} ({law})", draw.index);
    Mission::from_toml_str_with(&draw.toml(law, grid), &origin, sets)
}

/// Draws mission `index` of campaign `seed`, redrawing (deterministically: attempt 1, 2, …)
/// while it does not validate under every law of `laws`; the invalid draws are counted by
/// the validator's key. A schema error (an unknown or mistyped key, e.g. from a `--set`) is
/// bad input, not a redraw.
pub fn sample(
    space: &Space,
    seed: u64,
    index: u64,
    laws: &[String],
    grid: &Path,
    sets: &[KeySet],
) -> Result<Sampled, BadInput> {
    let mut redraws = Vec::new();
    let mut last = String::new();
    for attempt in 0..MAX_ATTEMPTS {
        let draw = Draw::sample(space, seed, index, attempt);
        let invalid = laws
            .iter()
            .find_map(|law| mission_of(&draw, law, grid, sets).err());
        match invalid {
            None => return Ok(Sampled { draw, redraws }),
            Some(e @ ConfigError::Invalid { .. }) => {
                redraws.push(e.key().unwrap_or("?").to_string());
                last = e.to_string();
            }
            Some(e) => return Err(BadInput(format!("mission {index}: {e}"))),
        }
    }
    Err(BadInput(format!(
        "mission {index}: no valid draw in {MAX_ATTEMPTS} attempts (a --set the space cannot satisfy?); the last: {last}"
    )))
}

/// What a finished campaign gives.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// Every flight's result, ordered by (mission, law).
    pub results: Vec<FlightResult>,
    /// The table.
    pub table: Table,
    /// Flights flown now (the rest were resumed).
    pub flown: usize,
}

impl Outcome {
    /// True when every flight passed.
    pub fn all_passed(&self) -> bool {
        self.results.iter().all(|r| r.pass)
    }
}

/// Checks `out` for `plan`, writing nothing: `Ok(true)` when it holds the same plan (a
/// resumed campaign), `Ok(false)` when it holds none; another plan is refused.
fn check_plan(out: &Path, plan: &Plan) -> Result<bool, BadInput> {
    let shown = out.display();
    let file = out.join(PLAN_FILE);
    if file.exists() {
        let recorded: Plan = std::fs::read_to_string(&file)
            .map_err(|e| e.to_string())
            .and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string()))
            .map_err(|e| BadInput(format!("--out {shown}: {PLAN_FILE} unreadable: {e}")))?;
        if recorded != *plan {
            return Err(BadInput(format!(
                "--out {shown}: holds another stress campaign (its {PLAN_FILE} differs: missions, seed, laws, v-bound, shrink, --set or the space); resume it with the same arguments or choose another directory"
            )));
        }
        return Ok(true);
    }
    if out.join(RESULTS_FILE).exists() {
        return Err(BadInput(format!(
            "--out {shown}: holds {RESULTS_FILE} without {PLAN_FILE}; choose an empty directory"
        )));
    }
    Ok(false)
}

/// Writes `plan` into `out`.
fn write_plan(out: &Path, plan: &Plan) -> Result<(), BadInput> {
    let shown = out.display();
    let file = out.join(PLAN_FILE);
    let text = serde_json::to_string_pretty(plan).map_err(|e| BadInput(e.to_string()))? + "\n";
    let tmp = out.join(".plan.json.tmp");
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, &file))
        .map_err(|e| BadInput(format!("--out {shown}: writing {PLAN_FILE}: {e}")))
}

/// The whole result lines of `OUT/results.jsonl` (a torn or foreign line is skipped).
pub fn read_results(out: &Path) -> Vec<FlightResult> {
    std::fs::read_to_string(out.join(RESULTS_FILE))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// The first failed criterion, in [`CRITERIA`] order.
fn first_criterion(failed: &[String]) -> Option<String> {
    CRITERIA
        .iter()
        .find(|c| failed.iter().any(|f| f == *c))
        .map(|c| c.to_string())
}

/// Flies `mission` in a fresh run directory `dir`, judges it; a panic of the flyer is an
/// error of the flight.
fn fly(mission: &Mission, dir: &Path, flyer: Flyer<'_>, v_bound: f64) -> Judgement {
    let go = || -> Result<Judgement> {
        if dir.exists() {
            std::fs::remove_dir_all(dir).with_context(|| format!("clearing {}", dir.display()))?;
        }
        let run = RunDir::create(dir).with_context(|| format!("creating {}", dir.display()))?;
        std::fs::write(run.mission(), mission.to_toml_string()).context("writing mission.toml")?;
        let summary = flyer(mission, &run)?;
        Ok(judge_dir(&summary, dir, v_bound))
    };
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(go)) {
        Ok(Ok(j)) => j,
        Ok(Err(e)) => Judgement::error(&format!("{e:#}")),
        Err(_) => Judgement::error("the flight panicked"),
    }
}

/// Writes `text` to `path` through a temporary file.
fn write_atomic(path: &Path, text: &str) -> Result<()> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text)
        .and_then(|()| std::fs::rename(&tmp, path))
        .with_context(|| format!("writing {}", path.display()))
}

struct Job<'a> {
    sampled: &'a Sampled,
    law: &'a str,
}

/// Flies one job: judges it, keeps a failure's run directory and mission file, shrinks it.
fn run_job(config: &Config, grid: &Path, job: &Job<'_>, flyer: Flyer<'_>) -> Result<FlightResult> {
    let draw = &job.sampled.draw;
    let name = flight_name(draw.index, job.law);
    let wall = std::time::Instant::now();
    let mission = mission_of(draw, job.law, grid, &config.sets)
        .map_err(|e| anyhow::anyhow!("mission {}: {e}", draw.index))?;
    let dir = config.out.join("runs").join(&name);
    let judgement = fly(&mission, &dir, flyer, config.v_bound);
    let pass = judgement.pass();
    let mut file = None;
    let mut shrunk = None;
    if pass {
        std::fs::remove_dir_all(&dir).with_context(|| format!("removing {}", dir.display()))?;
    } else {
        let failures = config.out.join("failures");
        std::fs::create_dir_all(&failures)?;
        let rel = format!("failures/{name}.toml");
        write_atomic(&config.out.join(&rel), &mission.to_toml_string())?;
        file = Some(rel);
        if let (true, Some(criterion)) = (config.shrink, first_criterion(&judgement.failed)) {
            let scratch = config.out.join("shrinking").join(&name);
            let mut k = 0;
            let mut fails = |d: &Draw| -> Option<Vec<String>> {
                let m = mission_of(d, job.law, grid, &config.sets).ok()?;
                k += 1;
                let j = fly(&m, &scratch.join(format!("s{k}")), flyer, config.v_bound);
                let _ = std::fs::remove_dir_all(scratch.join(format!("s{k}")));
                (!j.failed.iter().any(|c| c == "error") || criterion == "error").then_some(j.failed)
            };
            let s: Shrunk = shrink(draw, &criterion, &mut fails);
            let _ = std::fs::remove_dir_all(&scratch);
            let m = mission_of(&s.draw, job.law, grid, &config.sets)
                .map_err(|e| anyhow::anyhow!("shrunk mission {}: {e}", draw.index))?;
            let rel = format!("failures/{name}.shrunk.toml");
            let header = format!(
                "# shrunk from {name}.toml: still fails {} after {} ({} flights)\n",
                s.criterion,
                if s.steps.is_empty() {
                    "no simplification".to_string()
                } else {
                    s.steps.join(", ")
                },
                s.flights
            );
            write_atomic(&config.out.join(&rel), &(header + &m.to_toml_string()))?;
            shrunk = Some(ShrunkResult {
                file: rel,
                criterion: s.criterion,
                steps: s.steps,
                flights: s.flights,
                dims: Dims::of(&s.draw),
            });
        }
    }
    Ok(FlightResult {
        mission: draw.index,
        law: job.law.to_string(),
        pass,
        judgement,
        dims: Dims::of(draw),
        file,
        shrunk,
        wall_s: wall.elapsed().as_secs_f64(),
    })
}

/// Runs (or resumes) the campaign `config`, flying each mission with `flyer`.
pub fn run(config: &Config, flyer: Flyer<'_>) -> Result<Outcome> {
    check_config(config)?;
    let plan = Plan::of(config);
    let resumed = check_plan(&config.out, &plan)?;
    let (out, grid) = prepare_out(&config.out)?;
    let config = Config {
        out: out.clone(),
        ..config.clone()
    };
    // Every mission is sampled (and validated) before the plan is written: bad input (a
    // --set the missions refuse) leaves no campaign behind.
    let sampled: Vec<Sampled> = (0..config.missions)
        .filter(|i| config.only.is_empty() || config.only.contains(i))
        .map(|i| {
            sample(
                &config.space,
                config.seed,
                i,
                &config.laws,
                &grid,
                &config.sets,
            )
        })
        .collect::<Result<_, _>>()?;
    if !resumed {
        write_plan(&out, &plan)?;
    }
    let jobs = pending_jobs(&sampled, &config.laws, &out);
    let total = jobs.len();
    let ledger = Ledger::open(out.join(RESULTS_FILE), total, config.verbose)?;
    let errors = fly_jobs(&config, &grid, &jobs, flyer, ledger);
    if let Some(first) = errors.first() {
        anyhow::bail!(
            "{} flights could not be recorded; the first: {first}",
            errors.len()
        );
    }
    let _ = std::fs::remove_dir(out.join("shrinking"));
    let _ = std::fs::remove_dir(out.join("runs"));
    let (results, table) = tabulate(&out, &plan, &sampled, &config.laws)?;
    Ok(Outcome {
        results,
        table,
        flown: total,
    })
}

/// Refuses a campaign without missions, jobs or laws, or with a speed bound that is not
/// finite and > 0.
fn check_config(config: &Config) -> Result<()> {
    if config.laws.is_empty() || config.jobs == 0 || config.missions == 0 {
        return Err(BadInput("--missions, --jobs and the laws must not be empty".into()).into());
    }
    if !(config.v_bound > 0.0 && config.v_bound.is_finite()) {
        return Err(BadInput(format!("--v-bound {}: must be > 0", config.v_bound)).into());
    }
    if let Some(i) = config.only.iter().find(|&&i| i >= config.missions) {
        return Err(BadInput(format!(
            "--only {i}: not a mission of this campaign (indices 0..{})",
            config.missions
        ))
        .into());
    }
    Ok(())
}

/// Creates the campaign directory `out` and its grid file (once): returns the directory,
/// canonical, and the grid file's path.
fn prepare_out(out: &Path) -> Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(out).map_err(|e| BadInput(format!("--out {}: {e}", out.display())))?;
    let out = std::fs::canonicalize(out).with_context(|| format!("--out {}", out.display()))?;
    let grid = out.join(GRID_FILE);
    if !grid.exists() {
        let tmp = out.join(".grid.nc.tmp");
        write_grid(&tmp)
            .and_then(|()| std::fs::rename(&tmp, &grid))
            .with_context(|| format!("writing {}", grid.display()))?;
    }
    Ok((out, grid))
}

/// The flights of `sampled` under each of `laws` that `out`'s results file has no whole
/// line of yet, in (mission, law) order.
fn pending_jobs<'a>(sampled: &'a [Sampled], laws: &'a [String], out: &Path) -> Vec<Job<'a>> {
    let done: BTreeSet<(u64, String)> = read_results(out)
        .into_iter()
        .map(|r| (r.mission, r.law))
        .collect();
    sampled
        .iter()
        .flat_map(|s| laws.iter().map(move |l| (s, l)))
        .filter(|(s, l)| !done.contains(&(s.draw.index, l.to_string())))
        .map(|(s, l)| Job {
            sampled: s,
            law: l.as_str(),
        })
        .collect()
}

/// The results file as the worker threads share it: result lines appended as flights end,
/// the errors met on the way, the progress count.
struct Ledger {
    /// `OUT/results.jsonl`.
    path: PathBuf,
    file: Mutex<std::fs::File>,
    errors: Mutex<Vec<String>>,
    finished: AtomicUsize,
    /// Flights to fly now.
    total: usize,
    /// Print a line per finished flight.
    verbose: bool,
}

impl Ledger {
    /// Opens the results file `path` to append (created if absent); a torn last line (an
    /// interrupted campaign) is ended first so that it does not swallow the next one.
    fn open(path: PathBuf, total: usize, verbose: bool) -> Result<Ledger> {
        let mut file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .read(true)
            .open(&path)
            .with_context(|| format!("opening {}", path.display()))?;
        let existing = std::fs::read(&path).unwrap_or_default();
        if existing.last().is_some_and(|b| *b != b'\n') {
            file.write_all(b"\n")?;
        }
        Ok(Ledger {
            path,
            file: Mutex::new(file),
            errors: Mutex::new(Vec::new()),
            finished: AtomicUsize::new(0),
            total,
            verbose,
        })
    }

    /// Keeps `error` for the end of the campaign.
    fn error(&self, error: String) {
        if let Ok(mut errs) = self.errors.lock() {
            errs.push(error);
        }
    }

    /// Appends the line of `r` (and counts and shows it).
    fn record(&self, r: &FlightResult) {
        let line = match serde_json::to_string(r) {
            Ok(l) => l + "\n",
            Err(e) => {
                self.error(e.to_string());
                return;
            }
        };
        if let Ok(mut f) = self.file.lock() {
            if let Err(e) = f.write_all(line.as_bytes()).and_then(|()| f.flush()) {
                self.error(format!("{}: {e}", self.path.display()));
            }
        }
        let n = self.finished.fetch_add(1, Ordering::Relaxed) + 1;
        if self.verbose {
            eprintln!(
                "[{n}/{}] {} {}{}",
                self.total,
                flight_name(r.mission, &r.law),
                if r.pass { "pass" } else { "FAIL " },
                if r.pass {
                    String::new()
                } else {
                    format!("{}: {}", r.judgement.failed.join(","), r.judgement.why)
                }
            );
        }
    }

    /// The errors kept.
    fn into_errors(self) -> Vec<String> {
        self.errors.into_inner().unwrap_or_default()
    }
}

/// Flies `jobs` on `config.jobs` worker threads, each taking the next job not taken yet,
/// recording each result in `ledger`; returns the errors met.
fn fly_jobs(
    config: &Config,
    grid: &Path,
    jobs: &[Job<'_>],
    flyer: Flyer<'_>,
    ledger: Ledger,
) -> Vec<String> {
    let next = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..config.jobs.min(jobs.len().max(1)) {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(job) = jobs.get(k) else { break };
                match run_job(config, grid, job, flyer) {
                    Ok(r) => ledger.record(&r),
                    Err(e) => ledger.error(format!("{e:#}")),
                }
            });
        }
    });
    ledger.into_errors()
}

/// The table of the campaign in `out`, made from its results file alone (so a resumed
/// campaign gives the same), written to `stress.json` and `stress.md`; with the results of
/// the planned flights (`sampled` under each of `laws`), ordered by (mission, law).
fn tabulate(
    out: &Path,
    plan: &Plan,
    sampled: &[Sampled],
    laws: &[String],
) -> Result<(Vec<FlightResult>, Table)> {
    let wanted: BTreeSet<(u64, String)> = sampled
        .iter()
        .flat_map(|s| laws.iter().map(move |l| (s.draw.index, l.clone())))
        .collect();
    let mut by_flight: BTreeMap<(u64, String), FlightResult> = BTreeMap::new();
    for r in read_results(out) {
        let key = (r.mission, r.law.clone());
        if wanted.contains(&key) {
            by_flight.entry(key).or_insert(r);
        }
    }
    let results: Vec<FlightResult> = by_flight.into_values().collect();
    let mut redraws: BTreeMap<String, usize> = BTreeMap::new();
    for s in sampled {
        for k in &s.redraws {
            *redraws.entry(k.clone()).or_default() += 1;
        }
    }
    let table = Table::of(plan, &results, redraws);
    write_atomic(
        &out.join("stress.json"),
        &(serde_json::to_string_pretty(&table)? + "\n"),
    )?;
    write_atomic(&out.join("stress.md"), &table.markdown())?;
    Ok((results, table))
}
