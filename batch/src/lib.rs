//! `vbap batch MISSION --seeds K [--sweep KEY=V1,V2,…]…`: run a mission for K seeds at every
//! point of a grid of mission keys, write a table (one row per run), an aggregate (the
//! whole batch and every grid point), plots against the swept keys, and judge the batch
//! against pass/fail criteria.
//!
//! Seeds are the mission's seed, seed + 1, …, seed + K − 1. The grid is every combination
//! of the swept keys' values (the first key varying slowest; no sweep: one point, the
//! mission itself); `--set KEY=VALUE` applies to every run, the swept keys on top. Each run
//! goes into its own run directory, `OUT/seed_<seed>/` without a sweep and
//! `OUT/p<i>_<key>=<value>_…/seed_<seed>/` with one, either in this process with the
//! reference simulator (`--in-process`) or as a full multi-process `vbap run` (the default;
//! see [`run`] for the renamed missions), `--jobs J` at a time.
//!
//! Resumable ([`resume`]): `OUT/plan.json` records the batch; started again on the same
//! `OUT`, a batch skips every run whose `summary.json` is whole, and refuses a different
//! mission, sweep, seeds or mode.
//!
//! Outputs in `OUT` (default `runs/<name>-batch-<UTC timestamp>/`):
//! - `batch.csv`: `seed,converged,time_to_converge_s,final_distance_to_optimum,
//!   final_grad_norm,max_V_over_VU,in_set_m,wall_time_s,status,verdict,max_V_seen_over_VU,
//!   min_pair_ratio,near_collision_ticks,worst_slot_error,alive_at_end,in_formation_at_end,
//!   longest_contact_gap_s,stalled_s,share_V_above_VU_after_contact,messages_sent,
//!   messages_delivered`, then a column per swept key (its value at the run's grid point)
//!   (empty = not applicable; `max_V_over_VU` is the true figure, the formation columns are
//!   the run's `summary.json` `formation` object, the contact gap the longest over its
//!   vehicles, `share_V_above_VU_after_contact` the share of ticks with the true V above
//!   V_U once every vehicle was heard, the message counts the run's `messages`);
//! - `batch.json`: the aggregate of the whole batch: convergence rate, distributions (n,
//!   min, mean, p50, p90, p99, max) of the time to converge (converged runs), the final
//!   distance to the optimum and the final gradient norm (completed runs), the rate of every
//!   run verdict (`verdicts`), the share of runs that ended with every live vehicle in
//!   formation, had a near collision or stalled, distributions of the seen V/V_U, the
//!   closest pair and the worst slot error, the criteria and the batch's pass/fail verdict;
//!   then `sweep` (the keys and values) and `points`, the figures of every grid point
//!   ([`points::PointAggregate`]: success rate with its 95 % Wilson interval ([`stats::wilson`]), time to
//!   converge, true max V/V_U, formation intact, messages delivered);
//! - with a sweep: the grid points side by side on stderr and in `points.txt`, and
//!   `sweep_<key>.svg` per swept key ([`plot`]).
//!
//! # The `[batch]` table
//!
//! An optional `[batch]` table in the mission file (read by `vbap batch` only, and removed
//! from the per-run missions) holds pass/fail criteria and a sweep:
//!
//! ```toml
//! [batch]
//! min_convergence_rate = 0.9    # fraction of the runs that must converge (0..1)
//! max_final_distance = 0.5      # length unit: every completed run must end this close
//! max_time_to_converge = 60.0   # s: every converged run must have converged by then
//!
//! [batch.sweep]                 # mission keys and their values, as --sweep
//! "links.loss" = [0.0, 0.1, 0.2]
//! "control.law" = ["paper", "robust"]
//! ```
//!
//! A `--sweep` of a key replaces the table's values of that key. A run that fails (no
//! summary) counts as not converged and fails the batch. A failing batch exits with code 1
//! and names every criterion it failed.

pub mod aggregate;
pub mod criteria;
pub mod plot;
pub mod points;
pub mod resume;
pub mod row;
pub mod run;
pub mod stats;
pub mod sweep;
#[cfg(test)]
mod tests;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result};
use vbap_mission::config::{read_mission_file, Mission};

pub use aggregate::{aggregate, Aggregate};
pub use criteria::{Criteria, CRITERIA_KEYS};
pub use row::{csv_row, header, SeedResult, BATCH_HEADER};
pub use run::seed_name;
pub use stats::Distribution;
pub use sweep::SweepArg;

use run::{Job, Outcome};
use vbap_ipc::process::InvalidInput;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct BatchArgs {
    /// The mission file (may hold a [batch] table of pass/fail criteria and a sweep).
    pub mission: PathBuf,
    /// Number of seeds: the mission's seed, seed + 1, ...
    #[arg(long)]
    pub seeds: u64,
    /// Runs at a time.
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// Run each seed with the in-process simulator instead of the multi-process system.
    #[arg(long)]
    pub in_process: bool,
    /// Output directory (default: runs/<mission>-batch-<UTC timestamp>/). A directory of
    /// the same batch, interrupted, is resumed.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print no line per finished run.
    #[arg(long)]
    pub quiet: bool,
    /// Set a mission key on top of the file for every run, e.g. `--set control.law=paper`
    /// (repeatable; validated as if the file said it).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<vbap_mission::config::KeySet>,
    /// Sweep a mission key over values, e.g. `--sweep links.loss=0,0.1,0.2` (repeatable:
    /// every combination; each value validated as if the file said it).
    #[arg(long = "sweep", value_name = "KEY=V1,V2,...")]
    pub sweep: Vec<SweepArg>,
    /// Print nothing (not a command-line flag: the Python package reads the files).
    #[arg(skip)]
    pub silent: bool,
}

/// Runs the command; returns the exit code.
pub fn main(args: &BatchArgs) -> Result<i32> {
    if args.seeds == 0 {
        return Err(InvalidInput("--seeds 0: need at least one seed".into()).into());
    }
    if args.jobs == 0 {
        return Err(InvalidInput("--jobs 0: need at least one job".into()).into());
    }
    let text = read_mission_file(&args.mission)?;
    let origin = args.mission.display().to_string();
    let mission = Mission::from_toml_str_with(&text, &origin, &args.sets)?;
    let criteria = Criteria::of(&mission)?;
    let keys = sweep::resolve(&args.sweep, &mission)?;
    let key_names: Vec<String> = keys.iter().map(|k| k.key.clone()).collect();
    let points = sweep::grid(&keys);
    let missions = sweep::missions(&text, &origin, &args.sets, &keys, &points)?;
    let first = mission.mission.seed;
    if first
        .checked_add(args.seeds - 1)
        .is_none_or(|s| s > i64::MAX as u64)
    {
        return Err(InvalidInput(format!(
            "--seeds {}: seed {first} + {} overflows",
            args.seeds,
            args.seeds - 1
        ))
        .into());
    }
    let out = match &args.out {
        Some(p) => p.clone(),
        None => default_batch_dir(&mission.mission.name)?,
    };
    let mode = if args.in_process {
        "in-process"
    } else {
        "multi-process"
    };
    let plan = resume::Plan {
        // Without the header comment, which names the file as given (relative or not).
        mission: mission
            .to_toml_string()
            .lines()
            .filter(|l| !l.starts_with('#'))
            .collect::<Vec<_>>()
            .join("\n"),
        sweep: sweep::swept(&keys),
        first_seed: first,
        seeds: args.seeds,
        mode: mode.into(),
    };
    let resuming = resume::prepare(&out, &plan)?;

    let jobs: Vec<Job<'_>> = points
        .iter()
        .zip(&missions)
        .flat_map(|(point, m)| {
            (0..args.seeds).map(|i| Job {
                point,
                mission: m,
                seed: first + i,
                dir: run::run_dir(&out, point, first + i),
            })
        })
        .collect();
    let start = Instant::now();
    let workers = args.jobs.min(jobs.len());
    let exe = std::env::current_exe().context("locating the vbap executable")?;
    let (rows, skipped) = run_all(args, &jobs, workers, &exe, &out);
    write_table(&rows, &key_names, &out)?;
    let mut agg = aggregate(&rows, &criteria);
    agg.mission = mission.mission.name.clone();
    agg.mode = mode.into();
    agg.first_seed = first;
    agg.jobs = workers;
    agg.batch_wall_time_s = start.elapsed().as_secs_f64();
    agg.sweep = plan.sweep.clone();
    agg.points = points::per_point(&rows, &points, &key_names);
    let json = serde_json::to_string_pretty(&agg)? + "\n";
    std::fs::write(out.join("batch.json"), &json).context("writing batch.json")?;
    if !args.silent {
        print!("{json}");
        let _ = std::io::stdout().flush();
    }
    if !keys.is_empty() {
        let table = points::table(&agg.points, &key_names);
        std::fs::write(out.join("points.txt"), &table).context("writing points.txt")?;
        if !args.silent {
            eprint!("{table}");
        }
        plot::write(&out, &agg.mission, &agg.sweep, &agg.points)?;
    }
    if args.silent {
        return Ok(if agg.passed {
            vbap_ipc::process::EXIT_OK
        } else {
            vbap_ipc::process::EXIT_FAILURE
        });
    }
    if resuming {
        eprintln!(
            "resumed {}: {skipped} run(s) complete already, {} run now",
            out.display(),
            rows.len() - skipped
        );
    }
    eprintln!(
        "batch of {} runs ({} grid point(s) x {} seeds): {} converged ({:.0}%), {} failed; \
         table {}, aggregate {}",
        agg.runs,
        points.len(),
        args.seeds,
        agg.converged,
        100.0 * agg.convergence_rate,
        agg.failed_runs,
        out.join("batch.csv").display(),
        out.join("batch.json").display()
    );
    Ok(vbap_ipc::process::pass_or_fail(agg.passed, &agg.failures))
}

/// What `vbap check` checks of `mission`'s `[batch]` table (the file at `path` with `sets`):
/// the criteria, and the sweep (every value, and every grid point's mission, valid).
pub fn check(path: &Path, sets: &[vbap_mission::config::KeySet], mission: &Mission) -> Result<()> {
    Criteria::of(mission)?;
    let keys = sweep::resolve(&[], mission)?;
    if !keys.is_empty() {
        let text = read_mission_file(path)?;
        let origin = path.display().to_string();
        sweep::missions(&text, &origin, sets, &keys, &sweep::grid(&keys))?;
    }
    Ok(())
}

/// Every job, `workers` at a time, in this process or as `vbap run`; the rows in job order
/// (grid point, then seed), and how many were skipped (complete already).
fn run_all(
    args: &BatchArgs,
    jobs: &[Job<'_>],
    workers: usize,
    exe: &Path,
    out: &Path,
) -> (Vec<SeedResult>, usize) {
    let results: Mutex<Vec<(usize, SeedResult)>> = Mutex::new(Vec::with_capacity(jobs.len()));
    let next = AtomicUsize::new(0);
    let skipped = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(job) = jobs.get(i) else { break };
                let row = match run::run(job, args.in_process, exe, out) {
                    Outcome::Ran(row) => {
                        if !args.quiet {
                            eprintln!("{}", describe(&row, &job.point.describe()));
                        }
                        row
                    }
                    Outcome::Skipped(row) => {
                        skipped.fetch_add(1, Ordering::Relaxed);
                        row
                    }
                };
                results.lock().expect("results lock").push((i, row));
            });
        }
    });
    let mut rows = results.into_inner().expect("results lock");
    rows.sort_by_key(|(i, _)| *i);
    let rows = rows.into_iter().map(|(_, r)| r).collect();
    (rows, skipped.into_inner())
}

/// `batch.csv`: the header, a row per run.
fn write_table(rows: &[SeedResult], keys: &[String], out: &Path) -> Result<()> {
    let mut csv = header(keys);
    csv.push('\n');
    for r in rows {
        csv.push_str(&csv_row(r));
        csv.push('\n');
    }
    std::fs::write(out.join("batch.csv"), csv).context("writing batch.csv")
}

/// A finished run in a line (`at`: its grid point in words, empty without a sweep).
fn describe(r: &SeedResult, at: &str) -> String {
    let who = if at.is_empty() {
        format!("seed {}", r.seed)
    } else {
        format!("seed {} [{at}]", r.seed)
    };
    if !r.ok() {
        return format!("{who}: FAILED: {}", r.status);
    }
    let outcome = match (r.converged, r.time_to_converge_s) {
        (true, Some(t)) => format!("converged at t = {t:.2} s"),
        _ if !r.verdict.is_empty() => r.verdict.clone(),
        _ => "not converged".into(),
    };
    let d = r
        .final_distance_to_optimum
        .map_or("n/a".into(), |d| format!("{d:.4}"));
    format!(
        "{who}: {outcome}, final distance {d}, max V/V_U {:.3} ({:.1} s)",
        r.max_v_over_vu.unwrap_or(0.0),
        r.wall_time_s
    )
}

/// Where a batch of mission `name` writes without `--out`: `runs/<name>-batch-<UTC time>/`.
pub fn default_batch_dir(name: &str) -> Result<PathBuf> {
    Ok(vbap_mission::rundir::default_run_dir(&format!(
        "{name}-batch"
    ))?)
}
