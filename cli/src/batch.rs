//! `vbap batch MISSION --seeds K`: run a mission for K seeds, write a table (one row per
//! seed) and an aggregate, and judge the batch against pass/fail criteria.
//!
//! Seeds are the mission's seed, seed + 1, …, seed + K − 1. Each seed runs into its own run
//! directory `OUT/seed_<seed>/`, either in this process with the reference simulator
//! (`--in-process`) or as a full multi-process `vbap run` (the default), `--jobs J` at a
//! time. Two multi-process runs of one mission name cannot run at once (the name is the
//! IPC domain), so each seed's mission is renamed `<name>_s<seed>` and written to
//! `OUT/missions/seed_<seed>.toml`.
//!
//! Outputs in `OUT` (default `runs/<name>-batch-<UTC timestamp>/`):
//! - `batch.csv`: `seed,converged,time_to_converge_s,final_distance_to_optimum,
//!   final_grad_norm,max_V_over_VU,in_set_m,wall_time_s,status,verdict,max_V_seen_over_VU,
//!   min_pair_ratio,near_collision_ticks,worst_slot_error,alive_at_end,in_formation_at_end,
//!   longest_contact_gap_s,stalled_s,share_V_above_VU_after_contact` (empty = not
//!   applicable; `max_V_over_VU` is the true figure, the formation columns are the run's
//!   `summary.json` `formation` object, the contact gap the longest over its vehicles, the
//!   last column the share of ticks with the true V above V_U once every vehicle was heard);
//! - `batch.json`: the aggregate: convergence rate, distributions (n, min, mean, p50, p90,
//!   p99, max) of the time to converge (converged runs), the final distance to the optimum
//!   and the final gradient norm (completed runs), the rate of every run verdict
//!   (`verdicts`), the share of runs that ended with every live vehicle in formation, had a
//!   near collision or stalled, distributions of the seen V/V_U, the closest pair and the
//!   worst slot error, the criteria and the batch's pass/fail verdict.
//!
//! # Pass/fail criteria
//!
//! An optional `[batch]` table in the mission file (read by `vbap batch` only, and removed
//! from the per-seed missions):
//!
//! ```toml
//! [batch]
//! min_convergence_rate = 0.9    # fraction of the seeds that must converge (0..1)
//! max_final_distance = 0.5      # length unit: every completed run must end this close
//! max_time_to_converge = 60.0   # s: every converged run must have converged by then
//! ```
//!
//! A run that fails (no summary) counts as not converged and fails the batch. A failing
//! batch exits with code 1 and names every criterion it failed.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use vbap_mission::config::Mission;
use vbap_mission::rundir::{Percentiles, RunDir, Summary};

use crate::errors::InvalidInput;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct BatchArgs {
    /// The mission file (may hold a [batch] table of pass/fail criteria).
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
    /// Output directory (default: runs/<mission>-batch-<UTC timestamp>/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print no line per finished seed.
    #[arg(long)]
    pub quiet: bool,
    /// Set a mission key on top of the file for every seed, e.g. `--set control.law=paper`
    /// (repeatable; validated as if the file said it).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub sets: Vec<vbap_mission::config::KeySet>,
}

/// The pass/fail criteria of the `[batch]` table, each optional.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Criteria {
    /// Smallest acceptable fraction of converged seeds, in [0, 1].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_convergence_rate: Option<f64>,
    /// Largest acceptable final distance to the optimum of any completed run (length
    /// unit), ≥ 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_final_distance: Option<f64>,
    /// Largest acceptable time to converge of any converged run, s, ≥ 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_time_to_converge: Option<f64>,
}

/// The keys of the `[batch]` table.
pub const CRITERIA_KEYS: [&str; 3] = [
    "min_convergence_rate",
    "max_final_distance",
    "max_time_to_converge",
];

impl Criteria {
    /// The criteria of `mission`'s `[batch]` table (none without one), checked: every key
    /// known, every value a finite number in its range. An error names the mission file and
    /// the key (`batch.<key>`).
    pub fn of(mission: &Mission) -> Result<Criteria, InvalidInput> {
        let origin = &mission.origin;
        let Some(table) = &mission.batch else {
            return Ok(Criteria::default());
        };
        if let Some(key) = table.keys().find(|k| !CRITERIA_KEYS.contains(&k.as_str())) {
            return Err(InvalidInput(format!(
                "{origin}: batch.{key}: unknown key; known: {}",
                CRITERIA_KEYS.join(", ")
            )));
        }
        // toml names the key of a value that is no number ("... in `max_final_distance`").
        let criteria: Criteria =
            toml::Value::Table(table.clone())
                .try_into()
                .map_err(|e: toml::de::Error| {
                    let why = e.to_string().replace('\n', " ");
                    InvalidInput(format!("{origin}: [batch]: {}", why.trim()))
                })?;
        criteria.check(origin)?;
        Ok(criteria)
    }

    /// Every given value finite and in its range.
    fn check(&self, origin: &str) -> Result<(), InvalidInput> {
        for (key, value) in [
            ("min_convergence_rate", self.min_convergence_rate),
            ("max_final_distance", self.max_final_distance),
            ("max_time_to_converge", self.max_time_to_converge),
        ] {
            let Some(v) = value else { continue };
            let why = if !v.is_finite() {
                "must be a finite number"
            } else if key == "min_convergence_rate" && !(0.0..=1.0).contains(&v) {
                "must be between 0 and 1"
            } else if v < 0.0 {
                "must be >= 0"
            } else {
                continue;
            };
            return Err(InvalidInput(format!("{origin}: batch.{key} = {v}: {why}")));
        }
        Ok(())
    }
}

/// One row of `batch.csv`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SeedResult {
    pub seed: u64,
    pub converged: bool,
    pub time_to_converge_s: Option<f64>,
    pub final_distance_to_optimum: Option<f64>,
    pub final_grad_norm: Option<f64>,
    #[serde(rename = "max_V_over_VU")]
    pub max_v_over_vu: Option<f64>,
    pub in_set_m: Option<bool>,
    pub wall_time_s: f64,
    /// "ok", or why the run failed.
    pub status: String,
    /// The seed's run directory.
    pub run_dir: PathBuf,
    /// The run's verdict (summary.json `verdict`).
    pub verdict: String,
    /// The formation figures of summary.json.
    #[serde(rename = "max_V_seen_over_VU")]
    pub max_v_seen_over_vu: Option<f64>,
    pub min_pair_ratio: Option<f64>,
    pub near_collision_ticks: Option<u64>,
    pub worst_slot_error: Option<f64>,
    pub alive_at_end: Option<usize>,
    pub in_formation_at_end: Option<usize>,
    pub longest_contact_gap_s: Option<f64>,
    pub stalled_s: Option<f64>,
    /// Share of ticks with the true V above V_U once every vehicle was heard.
    #[serde(rename = "share_V_above_VU_after_contact")]
    pub share_v_above_vu_after_contact: Option<f64>,
}

impl SeedResult {
    fn from_summary(seed: u64, s: &Summary, run_dir: PathBuf) -> Self {
        let f = s.formation.as_ref();
        Self {
            seed,
            converged: s.converged,
            time_to_converge_s: s.time_to_converge_s,
            final_distance_to_optimum: s.final_distance_to_optimum,
            final_grad_norm: Some(s.final_grad_norm),
            max_v_over_vu: Some(s.max_v_over_vu),
            in_set_m: s.in_set_m,
            wall_time_s: s.wall_time_s,
            status: "ok".into(),
            run_dir,
            verdict: s.verdict.clone(),
            max_v_seen_over_vu: f.map(|f| f.max_v_seen_over_vu),
            min_pair_ratio: f.and_then(|f| f.min_pair_ratio),
            near_collision_ticks: f.map(|f| f.near_collision_ticks),
            worst_slot_error: f.and_then(|f| f.worst_slot_error),
            alive_at_end: f.map(|f| f.alive_at_end),
            in_formation_at_end: f.map(|f| f.in_formation_at_end),
            longest_contact_gap_s: f.and_then(|f| {
                f.longest_contact_gap_s
                    .iter()
                    .flatten()
                    .copied()
                    .reduce(f64::max)
            }),
            stalled_s: f.map(|f| f.stalled_s),
            share_v_above_vu_after_contact: f
                .and_then(|f| f.share_ticks_v_true_above_vu_after_contact),
        }
    }
    fn failed(seed: u64, why: String, wall: f64, run_dir: PathBuf) -> Self {
        Self {
            seed,
            wall_time_s: wall,
            status: why,
            run_dir,
            ..Self::default()
        }
    }
    fn ok(&self) -> bool {
        self.status == "ok"
    }
}

/// Header of `batch.csv`.
pub const BATCH_HEADER: &str = "seed,converged,time_to_converge_s,final_distance_to_optimum,final_grad_norm,max_V_over_VU,in_set_m,wall_time_s,status,verdict,max_V_seen_over_VU,min_pair_ratio,near_collision_ticks,worst_slot_error,alive_at_end,in_formation_at_end,longest_contact_gap_s,stalled_s,share_V_above_VU_after_contact";

fn csv_row(r: &SeedResult) -> String {
    use vbap_mission::rundir::Num;
    fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
        v.map(|v| v.to_string()).unwrap_or_default()
    }
    let quote = |text: &str| {
        if text.contains([',', '"', '\n']) {
            format!("\"{}\"", text.replace('"', "\"\"").replace('\n', " "))
        } else {
            text.to_string()
        }
    };
    let status = quote(&r.status);
    let verdict = quote(&r.verdict);
    format!(
        "{},{},{},{},{},{},{},{},{status},{verdict},{},{},{},{},{},{},{},{},{}",
        r.seed,
        r.converged,
        opt(r.time_to_converge_s.map(Num)),
        opt(r.final_distance_to_optimum.map(Num)),
        opt(r.final_grad_norm.map(Num)),
        opt(r.max_v_over_vu.map(Num)),
        opt(r.in_set_m),
        Num(r.wall_time_s),
        opt(r.max_v_seen_over_vu.map(Num)),
        opt(r.min_pair_ratio.map(Num)),
        opt(r.near_collision_ticks),
        opt(r.worst_slot_error.map(Num)),
        opt(r.alive_at_end),
        opt(r.in_formation_at_end),
        opt(r.longest_contact_gap_s.map(Num)),
        opt(r.stalled_s.map(Num)),
        opt(r.share_v_above_vu_after_contact.map(Num))
    )
}

/// A distribution over the runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Distribution {
    pub n: usize,
    pub min: f64,
    pub mean: f64,
    pub p50: f64,
    pub p90: f64,
    pub p99: f64,
    pub max: f64,
}

impl Distribution {
    /// Of `values` (zeros when empty).
    pub fn of(mut values: Vec<f64>) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        let n = values.len();
        let mean = values.iter().sum::<f64>() / n as f64;
        let p = Percentiles::of(&mut values);
        Self {
            n,
            min: values[0],
            mean,
            p50: p.p50,
            p90: p.p90,
            p99: p.p99,
            max: p.max,
        }
    }
}

/// `batch.json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Aggregate {
    pub mission: String,
    pub mode: String,
    pub first_seed: u64,
    pub runs: usize,
    pub completed: usize,
    pub failed_runs: usize,
    pub converged: usize,
    pub convergence_rate: f64,
    /// Over the converged runs, s.
    pub time_to_converge_s: Distribution,
    /// Over the completed runs that have an optimum.
    pub final_distance_to_optimum: Distribution,
    /// Over the completed runs.
    pub final_grad_norm: Distribution,
    /// Over the completed runs.
    #[serde(rename = "max_V_over_VU")]
    pub max_v_over_vu: Distribution,
    /// Fraction of the completed runs that ended in the set M of Theorem 5.1.
    pub in_set_m_rate: Option<f64>,
    /// Share of the runs (all, failed ones included) per verdict.
    pub verdicts: std::collections::BTreeMap<String, f64>,
    /// Fraction of the completed runs that ended with every live vehicle in formation.
    pub formation_kept_rate: Option<f64>,
    /// Fraction of the completed runs with at least one near-collision tick.
    pub near_collision_rate: Option<f64>,
    /// Fraction of the completed runs that stalled at some point.
    pub stall_rate: Option<f64>,
    /// Over the completed runs: the coordinator's own max V/V_U, the closest pair and the
    /// worst slot error (÷ design spacing).
    #[serde(rename = "max_V_seen_over_VU")]
    pub max_v_seen_over_vu: Distribution,
    pub min_pair_ratio: Distribution,
    pub worst_slot_error: Distribution,
    /// Wall time per run, s.
    pub wall_time_s: Distribution,
    /// Wall time of the whole batch, s.
    pub batch_wall_time_s: f64,
    pub jobs: usize,
    pub criteria: Criteria,
    pub passed: bool,
    /// Every failed criterion, in words.
    pub failures: Vec<String>,
}

/// The fraction of `rows` for which `test` is true, among those where it is known.
fn rate_of(rows: &[&SeedResult], test: impl Fn(&SeedResult) -> Option<bool>) -> Option<f64> {
    let known: Vec<bool> = rows.iter().filter_map(|r| test(r)).collect();
    (!known.is_empty()).then(|| known.iter().filter(|b| **b).count() as f64 / known.len() as f64)
}

/// Aggregates the rows and judges them against `criteria`.
pub fn aggregate(rows: &[SeedResult], criteria: &Criteria) -> Aggregate {
    let done: Vec<&SeedResult> = rows.iter().filter(|r| r.ok()).collect();
    let converged: Vec<&SeedResult> = done.iter().copied().filter(|r| r.converged).collect();
    let runs = rows.len();
    let rate = if runs == 0 {
        0.0
    } else {
        converged.len() as f64 / runs as f64
    };
    let with_m: Vec<bool> = done.iter().filter_map(|r| r.in_set_m).collect();
    let mut a = Aggregate {
        runs,
        completed: done.len(),
        failed_runs: runs - done.len(),
        converged: converged.len(),
        convergence_rate: rate,
        time_to_converge_s: Distribution::of(
            converged
                .iter()
                .filter_map(|r| r.time_to_converge_s)
                .collect(),
        ),
        final_distance_to_optimum: Distribution::of(
            done.iter()
                .filter_map(|r| r.final_distance_to_optimum)
                .collect(),
        ),
        final_grad_norm: Distribution::of(done.iter().filter_map(|r| r.final_grad_norm).collect()),
        max_v_over_vu: Distribution::of(done.iter().filter_map(|r| r.max_v_over_vu).collect()),
        in_set_m_rate: (!with_m.is_empty())
            .then(|| with_m.iter().filter(|b| **b).count() as f64 / with_m.len() as f64),
        verdicts: {
            let mut m = std::collections::BTreeMap::new();
            for r in rows {
                let v = if r.ok() {
                    r.verdict.clone()
                } else {
                    "failed".to_string()
                };
                *m.entry(v).or_insert(0.0) += 1.0 / runs as f64;
            }
            m
        },
        formation_kept_rate: rate_of(&done, |r| {
            r.alive_at_end
                .zip(r.in_formation_at_end)
                .map(|(a, i)| a == i)
        }),
        near_collision_rate: rate_of(&done, |r| r.near_collision_ticks.map(|n| n > 0)),
        stall_rate: rate_of(&done, |r| r.stalled_s.map(|s| s > 0.0)),
        max_v_seen_over_vu: Distribution::of(
            done.iter().filter_map(|r| r.max_v_seen_over_vu).collect(),
        ),
        min_pair_ratio: Distribution::of(done.iter().filter_map(|r| r.min_pair_ratio).collect()),
        worst_slot_error: Distribution::of(
            done.iter().filter_map(|r| r.worst_slot_error).collect(),
        ),
        wall_time_s: Distribution::of(rows.iter().map(|r| r.wall_time_s).collect()),
        criteria: criteria.clone(),
        ..Aggregate::default()
    };
    let failures = criteria_failures(rows, &a, criteria);
    a.passed = failures.is_empty();
    a.failures = failures;
    a
}

/// What `rows` fail: failed runs, then each criterion of `criteria` not met (aggregate
/// `a` of the rows holds the counts).
fn criteria_failures(rows: &[SeedResult], a: &Aggregate, criteria: &Criteria) -> Vec<String> {
    let done: Vec<&SeedResult> = rows.iter().filter(|r| r.ok()).collect();
    let converged: Vec<&SeedResult> = done.iter().copied().filter(|r| r.converged).collect();
    let (runs, rate) = (a.runs, a.convergence_rate);
    let mut failures = Vec::new();
    if a.failed_runs > 0 {
        let seeds: Vec<String> = rows
            .iter()
            .filter(|r| !r.ok())
            .map(|r| r.seed.to_string())
            .collect();
        failures.push(format!(
            "{} run(s) failed (seeds {})",
            a.failed_runs,
            seeds.join(", ")
        ));
    }
    if let Some(min) = criteria.min_convergence_rate {
        if rate < min {
            failures.push(format!(
                "min_convergence_rate: {} of {} seeds converged (rate {rate:.3} < {min})",
                a.converged, runs
            ));
        }
    }
    if let Some(max) = criteria.max_final_distance {
        let over: Vec<String> = done
            .iter()
            .filter(|r| r.final_distance_to_optimum.is_none_or(|d| d > max))
            .map(|r| match r.final_distance_to_optimum {
                Some(d) => format!("seed {}: {d:.4}", r.seed),
                None => format!("seed {}: no optimum to measure against", r.seed),
            })
            .collect();
        if !over.is_empty() {
            failures.push(format!(
                "max_final_distance: {} run(s) ended farther than {max} ({})",
                over.len(),
                over.join("; ")
            ));
        }
    }
    if let Some(max) = criteria.max_time_to_converge {
        let over: Vec<String> = converged
            .iter()
            .filter_map(|r| {
                r.time_to_converge_s
                    .filter(|t| *t > max)
                    .map(|t| format!("seed {}: {t} s", r.seed))
            })
            .collect();
        if !over.is_empty() {
            failures.push(format!(
                "max_time_to_converge: {} converged run(s) took longer than {max} s ({})",
                over.len(),
                over.join("; ")
            ));
        }
    }
    failures
}

/// A name for seed `seed` of mission `name`: `<name>_s<seed>`, the name cut to fit.
pub fn seed_name(name: &str, seed: u64) -> String {
    crate::child_run::suffixed_name(name, &format!("_s{seed}"))
}

/// Runs the command; returns the exit code.
pub fn main(args: &BatchArgs) -> Result<i32> {
    if args.seeds == 0 {
        return Err(InvalidInput("--seeds 0: need at least one seed".into()).into());
    }
    if args.jobs == 0 {
        return Err(InvalidInput("--jobs 0: need at least one job".into()).into());
    }
    let mission = Mission::load_with(&args.mission, &args.sets)?;
    let criteria = Criteria::of(&mission)?;
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
    if out.join("batch.csv").exists() {
        return Err(InvalidInput(format!(
            "--out {}: already holds a batch (batch.csv exists); choose an empty directory",
            out.display()
        ))
        .into());
    }
    std::fs::create_dir_all(&out)
        .map_err(|e| InvalidInput(format!("--out {}: {e}", out.display())))?;

    let seeds: Vec<u64> = (0..args.seeds).map(|i| first + i).collect();
    let start = Instant::now();
    let jobs = args.jobs.min(seeds.len());
    let exe = std::env::current_exe().context("locating the vbap executable")?;
    let rows = run_seeds(args, &mission, &seeds, jobs, &exe, &out);
    write_table(&rows, &out)?;
    let mut agg = aggregate(&rows, &criteria);
    agg.mission = mission.mission.name.clone();
    agg.mode = if args.in_process {
        "in-process"
    } else {
        "multi-process"
    }
    .into();
    agg.first_seed = first;
    agg.jobs = jobs;
    agg.batch_wall_time_s = start.elapsed().as_secs_f64();
    let json = serde_json::to_string_pretty(&agg)? + "\n";
    std::fs::write(out.join("batch.json"), &json).context("writing batch.json")?;
    print!("{json}");
    let _ = std::io::stdout().flush();
    eprintln!(
        "batch of {} seeds: {} converged ({:.0}%), {} failed; table {}, aggregate {}",
        agg.runs,
        agg.converged,
        100.0 * agg.convergence_rate,
        agg.failed_runs,
        out.join("batch.csv").display(),
        out.join("batch.json").display()
    );
    Ok(crate::child_run::pass_or_fail(agg.passed, &agg.failures))
}

/// Every seed, `jobs` at a time, in this process or as `vbap run`; the rows by seed.
fn run_seeds(
    args: &BatchArgs,
    mission: &Mission,
    seeds: &[u64],
    jobs: usize,
    exe: &Path,
    out: &Path,
) -> Vec<SeedResult> {
    let results: Mutex<Vec<SeedResult>> = Mutex::new(Vec::with_capacity(seeds.len()));
    let next = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&seed) = seeds.get(i) else { break };
                let row = if args.in_process {
                    run_in_process(mission, seed, out)
                } else {
                    run_process(exe, mission, seed, out)
                };
                if !args.quiet {
                    eprintln!("{}", describe(&row));
                }
                results.lock().expect("results lock").push(row);
            });
        }
    });
    let mut rows = results.into_inner().expect("results lock");
    rows.sort_by_key(|r| r.seed);
    rows
}

/// `batch.csv`: the header, a row per seed.
fn write_table(rows: &[SeedResult], out: &Path) -> Result<()> {
    let mut csv = String::from(BATCH_HEADER);
    csv.push('\n');
    for r in rows {
        csv.push_str(&csv_row(r));
        csv.push('\n');
    }
    std::fs::write(out.join("batch.csv"), csv).context("writing batch.csv")
}

fn describe(r: &SeedResult) -> String {
    if !r.ok() {
        return format!("seed {}: FAILED: {}", r.seed, r.status);
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
        "seed {}: {outcome}, final distance {d}, max V/V_U {:.3} ({:.1} s)",
        r.seed,
        r.max_v_over_vu.unwrap_or(0.0),
        r.wall_time_s
    )
}

fn default_batch_dir(name: &str) -> Result<PathBuf> {
    crate::rundirs::default_run_dir(&format!("{name}-batch"))
}

fn seed_dir(out: &Path, seed: u64) -> PathBuf {
    out.join(format!("seed_{seed}"))
}

/// One seed with the in-process simulator.
fn run_in_process(mission: &Mission, seed: u64, out: &Path) -> SeedResult {
    let root = seed_dir(out, seed);
    let wall = Instant::now();
    let result = (|| -> Result<Summary> {
        let mut m = mission.clone();
        m.mission.seed = seed;
        m.validate()?;
        let dir = RunDir::create(&root).with_context(|| format!("creating {}", root.display()))?;
        std::fs::write(dir.mission(), m.to_toml_string()).context("writing mission.toml")?;
        crate::sim::simulate(&m, &dir, &mut |_, _, _, _| {})
    })();
    match result {
        Ok(s) => SeedResult::from_summary(seed, &s, root),
        Err(e) => SeedResult::failed(seed, format!("{e:#}"), wall.elapsed().as_secs_f64(), root),
    }
}

/// One seed as a multi-process `vbap run`, its output in `OUT/seed_<seed>/vbap.log`.
fn run_process(exe: &Path, mission: &Mission, seed: u64, out: &Path) -> SeedResult {
    let root = seed_dir(out, seed);
    let wall = Instant::now();
    let result = (|| -> Result<Summary> {
        let mut m = mission.clone();
        m.mission.seed = seed;
        m.mission.name = seed_name(&mission.mission.name, seed);
        m.validate()?;
        let missions = out.join("missions");
        std::fs::create_dir_all(&missions)?;
        let file = missions.join(format!("seed_{seed}.toml"));
        std::fs::write(&file, m.to_toml_string())
            .with_context(|| format!("writing {}", file.display()))?;
        std::fs::create_dir_all(&root)?;
        let (mut cmd, log_path) = crate::child_run::vbap_run(exe, &file, &root)?;
        let status = cmd
            .status()
            .with_context(|| format!("starting {}", exe.display()))?;
        if !status.success() {
            anyhow::bail!("vbap run exited with {status}; see {}", log_path.display());
        }
        Summary::read(&RunDir { root: root.clone() })
            .with_context(|| format!("reading {}/summary.json", root.display()))
    })();
    match result {
        Ok(s) => SeedResult::from_summary(seed, &s, root),
        Err(e) => SeedResult::failed(seed, format!("{e:#}"), wall.elapsed().as_secs_f64(), root),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use vbap_mission::config::MAX_NAME_LEN;

    /// A mission with a `[batch]` table after `table` (TOML lines).
    fn mission(table: &str) -> Result<Mission, vbap_mission::config::ConfigError> {
        let text = format!(
            "[mission]\nname = \"b\"\n[field]\ncenter = [1.0, 2.0]\namplitude = 1.0\nwidth = 2.0\n{table}"
        );
        Mission::from_toml_str(&text, "m.toml")
    }

    #[test]
    fn the_batch_table_is_read_into_the_criteria() {
        let m = mission(
            "[batch]  # criteria\nmin_convergence_rate = 0.9 # most\nmax_final_distance = 1_000\n",
        )
        .unwrap();
        let c = Criteria::of(&m).unwrap();
        assert_eq!(c.min_convergence_rate, Some(0.9));
        assert_eq!(c.max_final_distance, Some(1000.0));
        assert_eq!(c.max_time_to_converge, None);
        assert!(!m.to_toml_string().contains("batch"));
        let none = mission("").unwrap();
        assert_eq!(Criteria::of(&none).unwrap(), Criteria::default());
    }

    #[test]
    fn bad_batch_tables_name_the_key() {
        for (table, needle) in [
            (
                "[batch]\nmin_rate = 1\n",
                "m.toml: batch.min_rate: unknown key",
            ),
            (
                "[batch]\n[batch.sub]\nx = 1\n",
                "m.toml: batch.sub: unknown key",
            ),
            (
                "[batch]\nmin_convergence_rate = 2\n",
                "m.toml: batch.min_convergence_rate = 2: must be between 0 and 1",
            ),
            (
                "[batch]\nmax_final_distance = \"x\"\n",
                "m.toml: [batch]: invalid type: string \"x\", expected f64 in `max_final_distance`",
            ),
            (
                "[batch]\nmax_time_to_converge = nan\n",
                "m.toml: batch.max_time_to_converge = NaN: must be a finite number",
            ),
            (
                "[batch]\nmax_final_distance = -1\n",
                "m.toml: batch.max_final_distance = -1: must be >= 0",
            ),
        ] {
            let m = mission(table).unwrap();
            let e = Criteria::of(&m).unwrap_err().to_string();
            assert!(e.contains(needle), "{table:?}: {e}");
        }
        // A key given twice is no TOML.
        let e = mission("[batch]\nmax_final_distance = 1\nmax_final_distance = 2\n").unwrap_err();
        assert!(
            e.to_string()
                .contains("m.toml: line 9, column 1: invalid TOML"),
            "{e}"
        );
    }

    #[test]
    fn seed_names_fit() {
        assert_eq!(seed_name("paper", 3), "paper_s3");
        let long = "a".repeat(32);
        let n = seed_name(&long, 12345);
        assert_eq!(n.len(), MAX_NAME_LEN);
        assert!(n.ends_with("_s12345"));
    }

    fn row(seed: u64, converged: bool, t: Option<f64>, d: f64) -> SeedResult {
        SeedResult {
            seed,
            converged,
            time_to_converge_s: t,
            final_distance_to_optimum: Some(d),
            final_grad_norm: Some(d),
            max_v_over_vu: Some(0.2),
            in_set_m: Some(converged),
            wall_time_s: 1.0,
            status: "ok".into(),
            run_dir: PathBuf::new(),
            ..SeedResult::default()
        }
    }

    #[test]
    fn aggregate_and_criteria() {
        let rows = vec![
            row(1, true, Some(40.0), 0.1),
            row(2, true, Some(50.0), 0.2),
            row(3, false, None, 3.0),
            SeedResult::failed(4, "boom".into(), 0.5, PathBuf::new()),
        ];
        let ok = aggregate(&rows[..2], &Criteria::default());
        assert!(ok.passed);
        assert_eq!(ok.convergence_rate, 1.0);
        assert_eq!(ok.time_to_converge_s.p50, 40.0);
        assert_eq!(ok.time_to_converge_s.max, 50.0);
        assert_eq!(ok.time_to_converge_s.mean, 45.0);
        let c = Criteria {
            min_convergence_rate: Some(0.75),
            max_final_distance: Some(1.0),
            max_time_to_converge: Some(45.0),
        };
        let a = aggregate(&rows, &c);
        assert!(!a.passed);
        assert_eq!(a.runs, 4);
        assert_eq!(a.completed, 3);
        assert_eq!(a.convergence_rate, 0.5);
        assert_eq!(a.in_set_m_rate, Some(2.0 / 3.0));
        let all = a.failures.join("\n");
        for needle in [
            "1 run(s) failed (seeds 4)",
            "min_convergence_rate: 2 of 4",
            "max_final_distance: 1 run(s)",
            "seed 3: 3.0000",
            "max_time_to_converge: 1 converged run(s)",
            "seed 2: 50 s",
        ] {
            assert!(all.contains(needle), "{needle} in {all}");
        }
        assert_eq!(
            csv_row(&rows[2]),
            "3,false,,3,3,0.2,false,1,ok,,,,,,,,,,",
            "empty cells for missing values"
        );
        assert_eq!(csv_row(&rows[3]), "4,false,,,,,,0.5,boom,,,,,,,,,,");
    }
}
