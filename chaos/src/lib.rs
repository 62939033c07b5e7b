//! `vbap chaos MISSION`: a fault campaign with real signals. Runs the real `vbap run` many
//! times — every (pace, policy) combination, `--runs` seeds each — and, while each runs,
//! sends real SIGKILLs and SIGSTOPs (SIGCONT after a pause) to processes of its set at
//! seeded random wall times; then reads the run directory and judges every action.
//!
//! # A run of the campaign
//!
//! The mission is rewritten per run (`OUT/missions/NNN.toml`): name `<name>_cNNN` (its own
//! iceoryx2 domain), `mission.seed` the campaign seed of the run, `[mission] pace` the
//! run's pace, `[restart] vehicles` the run's policy (the coordinator's and the field
//! server's policies stay the mission's own), scheduled `kill` faults removed (every kill
//! is the campaign's), other faults kept when they fit the shortened mission. Duration:
//! paced runs last `pace × (window + TAIL)` mission seconds, `window + TAIL` s of wall
//! time; lockstep runs get enough ticks for the same wall time at the rate measured by a
//! first, unharmed lockstep run (the calibration run, judged for leftovers like every
//! other run).
//!
//! The actions (`--kills` SIGKILLs and `--stops` SIGSTOPs per run) happen at seeded random
//! wall times in [0.5 s, window] after the whole process set is up (every agent's log says
//! `agent up`). Each action picks, seeded, a target kind among `--targets` that has a
//! candidate, then a candidate: a live process of the set that is up by its own log (a
//! restarted agent once it was admitted back) and not SIGSTOPped. Agents
//! are candidates for a kill only while more than dim + 1 of them are alive (the fewest
//! that still estimate a gradient), and a vehicle is either killed or stopped in a run,
//! never both, and stopped at most once, so every loss of a vehicle in `events.jsonl`
//! belongs to exactly one action. An action finds no target, or
//! the mission already over, is listed as not sent.
//!
//! Compound faults (`--compound N` per run, at seeded times in the same window, each of a
//! seeded case, whatever `--targets` says): a kill of the coordinator (or the field server)
//! followed 30 ms later by the kill of an agent, inside the restart; or a SIGSTOP of an
//! agent followed 0.3 s later by the SIGKILL of that same stopped process (never
//! continued). Each of their actions is judged as a single one of its kind would be (the
//! stop of a stopped-then-killed agent by its kill only), and listed with its case
//! (`compound` in `chaos.json`, `act+` in the table).
//!
//! # Rules of the table
//!
//! - **Agent kill, detected**: the coordinator wrote a death of that vehicle: a `lost`
//!   event of any cause but a scheduled kill or `stopped` (a lockstep coordinator loses a
//!   stopped member, which is no death), or a `died` event (the process of a vehicle lost
//!   while stopped died: out already, it needs no detection and has no `detection_ms`).
//!   The i-th kill of a vehicle in a run is matched to its i-th death. `detected_t`: the
//!   event's mission time. `detection_ms`: wall time from the SIGKILL to the coordinator's
//!   first publication after it of the command of the event's tick (the first after its
//!   verdict; from the `sent_ns` of the agents' message records, same host clock); without
//!   message records (`RUST_LOG=info`), to the coordinator's warning about that vehicle.
//! - **Agent kill, recovered**: detected, the run completed, and then — policy `never`: a
//!   `reconfigured` event at or after the loss (for a `died` vehicle, the stop's loss)
//!   whose formation leaves the vehicle out; `on-failure` / `always`: a `rejoin` event of
//!   the vehicle after its death in `events.jsonl` (it was admitted back).
//! - **Coordinator or field server kill, detected**: the supervisor started a new process
//!   in its place (seen by the campaign); `detection_ms` is then the time to that new
//!   process (restart backoff included). **Recovered**: detected and the mission went on
//!   to its last tick (`summary.json` `ticks` equals the mission's) with `vbap run`
//!   exiting 0.
//! - **Stop** (SIGSTOP, SIGCONT after a seeded pause in [0.2 s, `--max-stop`]): the
//!   stopped process must still be alive when continued and the run must complete; a
//!   stopped agent declared lost (a `lost` event of its vehicle) must be admitted back (a
//!   `rejoin` event) — a silent process is not a dead one.
//! - **Judged**: an action the mission outlived by at least `MARGIN` s of wall time (the
//!   coordinator's `coordinator done` line, else the end of `vbap run`) is judged; a later
//!   one that was not detected and recovered anyway is listed as unjudged and fails
//!   nothing.
//! - **Leftovers**: after each run, any file of the run's iceoryx2 domain left in
//!   /dev/shm or under /tmp/iceoryx2 ([`vbap_ipc::topics::Domain::files`]) and any live
//!   process started with the run's mission file is a leftover; the campaign reports it,
//!   then removes it (SIGKILL by pid, file by file).
//! - The run's **verdict**: `summary.json` `verdict` (and `reasons`) when present, else
//!   `converged` / `not converged`; reported, not judged (campaign runs are short).
//!
//! The campaign fails (exit 1) when a judged kill went undetected (or, with
//! `--max-detection-ms`, was detected later than that), a judged recovery failed, a run
//! failed (no summary, or `vbap run` exit ≠ 0) or anything was left behind.
//!
//! Outputs in `OUT` (default `runs/<name>-chaos-<UTC timestamp>/`): `chaos.json` (the
//! campaign, every run with its figures and actions, totals, failures), `chaos.csv` (a row
//! per action), `missions/NNN.toml`, `runs/NNN/` (each run directory, with `vbap.log`).

mod args;
mod evaluate;
mod output;
mod procs;
mod report;
mod run;
#[cfg(test)]
mod tests;
mod timing;

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use vbap_mission::config::{FaultKind, Mission, Overrides, Pace, RestartPolicy};

pub use args::{compound_plan, plan, run_name, ChaosArgs, Compound};
pub use output::{table, CSV_HEADER};
pub use procs::{slot_of, Slot, Target};
pub use report::{Action, Campaign, RunReport, Totals};
pub use timing::{MARGIN, TAIL};

use args::{policy_name, run_mission, target_name};
use procs::json_lines;
use run::{run_one, RunSpec};
use vbap_ipc::process::InvalidInput;

/// Ticks of the calibration run.
const CALIBRATION_TICKS: u64 = 4000;

/// Runs the command; returns the exit code.
pub fn main(args: &ChaosArgs) -> Result<i32> {
    let (policies, targets) = args::check(args)?;
    let mut base = Mission::load(&args.mission)?.with_overrides(&Overrides {
        vehicles: args.vehicles,
        ..Overrides::default()
    })?;
    base.faults.retain(|f| f.kind != FaultKind::Kill);
    let out = output_dir(args, &base)?;
    let exe = std::env::current_exe().context("locating the vbap executable")?;
    let start = Instant::now();
    let mut campaign = new_campaign(args, &base, &policies, &targets);
    let mut index = 0usize;
    if args.paces.contains(&Pace::Lockstep) {
        // Calibration: how many lockstep ticks a wall second holds on this machine now.
        let mut m = base.clone();
        m.mission.duration = CALIBRATION_TICKS as f64 * m.mission.dt;
        m.faults.retain(|f| f.at <= m.mission.duration);
        let spec = RunSpec {
            index,
            pace: Pace::Lockstep,
            policy: base.restart.vehicles,
            seed: args.seed,
            plan: &[],
            compounds: &[],
            calibration: true,
            targets: &targets,
        };
        let report = run_one(&exe, &out, m, &spec)?;
        campaign.lockstep_ticks_per_s = lockstep_rate(&report);
        finished(args, &mut campaign, report);
        index += 1;
    }
    for pace in &args.paces {
        for policy in &policies {
            for r in 0..args.runs {
                let seed = args.seed + r as u64;
                let m = run_mission(&base, *pace, args.window, campaign.lockstep_ticks_per_s);
                let plan = plan(
                    seed,
                    index,
                    args.kills,
                    args.stops,
                    args.window,
                    args.max_stop,
                );
                let compounds = compound_plan(seed, index, args.compound, args.window);
                let spec = RunSpec {
                    index,
                    pace: *pace,
                    policy: *policy,
                    seed,
                    plan: &plan,
                    compounds: &compounds,
                    calibration: false,
                    targets: &targets,
                };
                let report = run_one(&exe, &out, m, &spec)?;
                finished(args, &mut campaign, report);
                index += 1;
            }
        }
    }
    campaign.wall_s = start.elapsed().as_secs_f64();
    if let Some(limit) = args.max_detection_ms {
        for r in &mut campaign.runs {
            report::apply_detection_limit(r, limit);
        }
    }
    campaign.max_detection_ms = args.max_detection_ms;
    report::judge(&mut campaign);
    write_outputs(&campaign, &out)?;
    Ok(vbap_ipc::process::pass_or_fail(
        campaign.passed,
        &campaign.failures,
    ))
}

/// `--out` (or the default), new and empty of a campaign, with `missions/` and `runs/`;
/// canonical.
fn output_dir(args: &ChaosArgs, base: &Mission) -> Result<PathBuf> {
    let out = match &args.out {
        Some(p) => p.clone(),
        None => vbap_mission::rundir::default_run_dir(&format!("{}-chaos", base.mission.name))?,
    };
    if out.join("chaos.json").exists() {
        return Err(InvalidInput(format!(
            "--out {}: already holds a campaign (chaos.json exists); choose an empty directory",
            out.display()
        ))
        .into());
    }
    std::fs::create_dir_all(out.join("missions"))
        .and_then(|_| std::fs::create_dir_all(out.join("runs")))
        .map_err(|e| InvalidInput(format!("--out {}: {e}", out.display())))?;
    std::fs::canonicalize(&out).context("resolving --out")
}

/// The campaign's header: what was asked, where, when; no run yet.
fn new_campaign(
    args: &ChaosArgs,
    base: &Mission,
    policies: &[RestartPolicy],
    targets: &[Target],
) -> Campaign {
    Campaign {
        mission: args.mission.display().to_string(),
        command: std::env::args().collect::<Vec<_>>().join(" "),
        started_utc: utc_now(),
        host: host_description(),
        seed: args.seed,
        kills_per_run: args.kills,
        compound_per_run: args.compound,
        stops_per_run: args.stops,
        paces: args.paces.iter().map(|p| p.to_string()).collect(),
        policies: policies
            .iter()
            .map(|p| policy_name(*p).to_string())
            .collect(),
        targets: targets
            .iter()
            .map(|t| target_name(*t).to_string())
            .collect(),
        window_s: args.window,
        tail_s: TAIL,
        margin_s: MARGIN,
        vehicles: base.vehicles.count,
        ..Campaign::default()
    }
}

/// A run is over: its line (unless `--quiet`), into the campaign.
fn finished(args: &ChaosArgs, campaign: &mut Campaign, report: RunReport) {
    if !args.quiet {
        eprintln!("{}", output::describe(&report));
    }
    campaign.runs.push(report);
}

/// `chaos.json`, `chaos.csv`, the table on stdout, where they are on stderr.
fn write_outputs(campaign: &Campaign, out: &Path) -> Result<()> {
    let json = serde_json::to_string_pretty(campaign)? + "\n";
    std::fs::write(out.join("chaos.json"), &json).context("writing chaos.json")?;
    std::fs::write(out.join("chaos.csv"), output::csv(campaign)).context("writing chaos.csv")?;
    let mut stdout = std::io::stdout();
    let _ = write!(stdout, "{}", table(campaign));
    let _ = stdout.flush();
    eprintln!(
        "campaign: table {}, details {}",
        out.join("chaos.csv").display(),
        out.join("chaos.json").display()
    );
    Ok(())
}

/// Ticks per wall second of a run, between the coordinator's `coordinator up` and
/// `coordinator done` lines (start-up excluded), else over the whole run.
fn lockstep_rate(r: &RunReport) -> Option<f64> {
    let ticks = r.ticks? as f64;
    let log = json_lines(&r.run_dir.join("logs").join("coordinator.jsonl"));
    let at = |msg: &str| {
        log.iter()
            .find(|l| procs::message(l) == Some(msg))
            .and_then(|l| vbap_report::analyze::parse_utc(l.get("timestamp")?.as_str()?))
    };
    let span = match (at("coordinator up"), at("coordinator done")) {
        (Some(a), Some(b)) if b > a => b - a,
        _ => r.wall_s,
    };
    (span > 0.0).then(|| ticks / span)
}

fn utc_now() -> String {
    let now = time::OffsetDateTime::now_utc();
    time::format_description::parse_borrowed::<2>("[year]-[month]-[day]T[hour]:[minute]:[second]Z")
        .ok()
        .and_then(|f| now.format(&f).ok())
        .unwrap_or_default()
}

fn host_description() -> String {
    let cpus = std::thread::available_parallelism().map_or(0, |n| n.get());
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
        .map(|s| s.trim().to_string())
        .unwrap_or_default();
    format!("{cpus} CPUs, {model}, Linux {kernel}")
}
