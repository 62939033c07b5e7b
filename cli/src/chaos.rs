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
//! # Rules of the table
//!
//! - **Agent kill, detected**: the coordinator wrote a `lost` event for that vehicle (any
//!   cause but a scheduled kill). The i-th kill of a vehicle in a run is matched to its
//!   i-th `lost` event. `detected_t`: the event's mission time. `detection_ms`: wall time
//!   from the SIGKILL to the coordinator's publication of the command of the event's tick
//!   (the first it published after its verdict; from the `sent_ns` of the agents' message
//!   records, same host clock); without message records (`RUST_LOG=info`), to the
//!   coordinator's warning about that vehicle.
//! - **Agent kill, recovered**: detected, the run completed, and then — policy `never`: a
//!   `reconfigured` event at or after the loss whose formation leaves the vehicle out;
//!   `on-failure` / `always`: the vehicle's i-th `rejoin` event (it was admitted back).
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
//!   /dev/shm or under /tmp/iceoryx2 ([`crate::domain::leftover_files`]) and any live
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

use std::collections::{BTreeMap, BTreeSet};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result};
use nix::sys::signal::Signal;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::Serialize;
use serde_json::Value;
use vbap_ipc::process::{EXIT_FAILURE, EXIT_OK};
use vbap_ipc::topics::Domain;
use vbap_mission::config::{
    FaultKind, Mission, Overrides, Pace, RestartPolicy, MAX_NAME_LEN, MAX_TICKS,
};
use vbap_mission::rundir::Percentiles;

use crate::errors::InvalidInput;

/// Wall time a paced run lasts after the action window, s: room to detect, restart and
/// readmit the last action's target.
pub const TAIL: f64 = 5.0;
/// An action is judged when the mission went on at least this long after it (wall, s).
pub const MARGIN: f64 = 3.0;
/// Earliest action, s of wall time after the process set is up.
const FIRST_ACTION: f64 = 0.5;
/// Shortest SIGSTOP pause, s.
const MIN_STOP: f64 = 0.2;
/// How often the campaign looks at the process set.
const POLL: Duration = Duration::from_millis(2);
/// Longest wait for the process set to come up.
const UP_TIMEOUT: Duration = Duration::from_secs(120);
/// Ticks of the calibration run.
const CALIBRATION_TICKS: u64 = 4000;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct ChaosArgs {
    /// The mission file.
    pub mission: PathBuf,
    /// SIGKILLs per run.
    #[arg(long, default_value_t = 3)]
    pub kills: usize,
    /// SIGSTOPs per run (each followed by SIGCONT after a seeded pause).
    #[arg(long, default_value_t = 1)]
    pub stops: usize,
    /// Campaign seed: runs of one (pace, policy) use seeds S, S + 1, ...
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Runs per (pace, policy) combination.
    #[arg(long, default_value_t = 1)]
    pub runs: usize,
    /// Paces, comma-separated: "lockstep" or real-time factors.
    #[arg(long, value_delimiter = ',', default_value = "lockstep,10")]
    pub paces: Vec<Pace>,
    /// Restart policies of the vehicle agents, comma-separated: never, on-failure, always.
    #[arg(long, default_value = "never,on-failure,always")]
    pub policies: String,
    /// What may be hit, comma-separated: agents, coordinator, field_server.
    #[arg(long, default_value = "agents")]
    pub targets: String,
    /// Wall time window of the actions after the process set is up, s.
    #[arg(long, default_value_t = 4.0)]
    pub window: f64,
    /// Longest SIGSTOP pause, s.
    #[arg(long, default_value_t = 2.0)]
    pub max_stop: f64,
    /// Override vehicles.count.
    #[arg(long)]
    pub vehicles: Option<usize>,
    /// Also fail a kill detected later than this, ms (default: any detection counts).
    #[arg(long)]
    pub max_detection_ms: Option<f64>,
    /// Output directory (default: runs/<mission>-chaos-<UTC timestamp>/).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print no line per finished run.
    #[arg(long)]
    pub quiet: bool,
}

/// A process slot of the set.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Slot {
    FieldServer,
    Coordinator,
    Agent(u32),
}

impl Slot {
    /// "vehicle_agent 3", "coordinator", "field_server".
    pub fn label(self) -> String {
        match self {
            Slot::FieldServer => "field_server".into(),
            Slot::Coordinator => "coordinator".into(),
            Slot::Agent(i) => format!("vehicle_agent {i}"),
        }
    }
    fn kind(self) -> Target {
        match self {
            Slot::FieldServer => Target::FieldServer,
            Slot::Coordinator => Target::Coordinator,
            Slot::Agent(_) => Target::Agents,
        }
    }
}

/// A target kind of `--targets`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Target {
    Agents,
    Coordinator,
    FieldServer,
}

/// The slot of a process from its command line (`argv[0]` and `--id`); None for others.
pub fn slot_of(cmdline: &[String]) -> Option<Slot> {
    let exe = Path::new(cmdline.first()?).file_name()?.to_str()?;
    match exe {
        "field_server" => Some(Slot::FieldServer),
        "coordinator" => Some(Slot::Coordinator),
        "vehicle_agent" => {
            let i = cmdline.iter().position(|a| a == "--id")?;
            Some(Slot::Agent(cmdline.get(i + 1)?.parse().ok()?))
        }
        _ => None,
    }
}

fn cmdline(pid: u32) -> Option<Vec<String>> {
    let raw = std::fs::read(format!("/proc/{pid}/cmdline")).ok()?;
    Some(
        raw.split(|b| *b == 0)
            .filter(|s| !s.is_empty())
            .map(|s| String::from_utf8_lossy(s).into_owned())
            .collect(),
    )
}

/// True when `pid` exists and is not a zombie.
fn alive(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Ok(stat) => stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_some_and(|state| state != "Z" && state != "X"),
        Err(_) => false,
    }
}

/// The children of `pid` (of every thread of it).
fn children(pid: u32) -> Vec<u32> {
    let mut out = Vec::new();
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return out;
    };
    for t in tasks.flatten() {
        if let Ok(text) = std::fs::read_to_string(t.path().join("children")) {
            out.extend(
                text.split_whitespace()
                    .filter_map(|p| p.parse::<u32>().ok()),
            );
        }
    }
    out.sort_unstable();
    out.dedup();
    out
}

/// Sends `sig` to `pid`; false when there is no such process (any more). The pid was just
/// checked to be the process of the run we mean (its command line).
fn send(pid: u32, sig: Signal) -> bool {
    match i32::try_from(pid) {
        Ok(pid) if pid > 0 => nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), sig).is_ok(),
        _ => false,
    }
}

fn epoch_s(t: SystemTime) -> f64 {
    t.duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// One action of the campaign and how it went.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Action {
    /// "kill" or "stop".
    pub action: String,
    /// "vehicle_agent 2", "coordinator", "field_server"; "" when not sent.
    pub target: String,
    /// The vehicle, for an agent.
    pub vehicle: Option<u32>,
    pub pid: Option<u32>,
    /// Planned wall time, s after the process set was up.
    pub planned_s: f64,
    /// Wall time it was sent, s after the process set was up.
    pub at_s: Option<f64>,
    /// Wall time it was sent, s since the Unix epoch.
    pub at_unix_s: Option<f64>,
    /// SIGSTOP: the pause before SIGCONT, s.
    pub pause_s: Option<f64>,
    pub sent: bool,
    /// Judged (see the module documentation).
    pub judged: bool,
    pub detected: Option<bool>,
    /// Mission time of the `lost` event, s.
    pub detected_t: Option<f64>,
    /// Wall time from the signal to the detection, ms.
    pub detection_ms: Option<f64>,
    /// Wall time from the signal to a new process in the slot, ms.
    pub restarted_ms: Option<f64>,
    pub rejoined: Option<bool>,
    /// Mission time of the `rejoin` event, s.
    pub rejoin_t: Option<f64>,
    pub reconfigured: Option<bool>,
    pub recovered: Option<bool>,
    /// SIGSTOP: still alive when continued.
    pub survived: Option<bool>,
    /// SIGSTOP: its vehicle was declared lost.
    pub declared_lost: Option<bool>,
    /// "ok", "not sent: …", "unjudged: …" or what failed.
    pub outcome: String,
    /// Wall time of SIGCONT, s since the Unix epoch (internal).
    #[serde(skip)]
    cont_unix_s: Option<f64>,
    #[serde(skip)]
    slot: Option<Slot>,
}

impl Action {
    fn failed(&self) -> bool {
        self.sent && self.judged && self.outcome != "ok"
    }
}

/// One run of the campaign.
#[derive(Clone, Debug, Default, Serialize)]
pub struct RunReport {
    pub index: usize,
    /// True for the lockstep calibration run (no actions).
    pub calibration: bool,
    pub pace: String,
    pub policy: String,
    pub seed: u64,
    pub mission_name: String,
    pub run_dir: PathBuf,
    pub expected_ticks: u64,
    pub exit_code: Option<i32>,
    pub wall_s: f64,
    pub ticks: Option<u64>,
    pub late_ticks: Option<u64>,
    pub vehicles_lost: Option<u64>,
    pub vehicles_rejoined: Option<u64>,
    pub reconfigurations: Option<u64>,
    /// The coordinator's own `detection_latency_ms`.
    pub coordinator_detection_ms: Vec<f64>,
    /// The coordinator's own `rejoin_latency_ms`.
    pub coordinator_rejoin_ms: Vec<f64>,
    pub verdict: String,
    pub reasons: Vec<String>,
    /// Processes the supervisor started in a slot after its first, per kind
    /// (`agents`, `coordinator`, `field_server`): every restart, asked for or not.
    pub restarts_seen: BTreeMap<String, usize>,
    pub leftover_files: Vec<PathBuf>,
    pub leftover_processes: Vec<String>,
    pub actions: Vec<Action>,
    /// Why this run fails the campaign (empty: it does not).
    pub failures: Vec<String>,
}

/// Totals over the campaign.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Totals {
    pub runs: usize,
    pub runs_failed: usize,
    pub kills_sent: usize,
    pub kills_judged: usize,
    pub kills_detected: usize,
    pub kills_undetected: usize,
    pub kills_recovered: usize,
    pub stops_sent: usize,
    pub stops_ok: usize,
    pub not_sent: usize,
    pub unjudged: usize,
    /// Judged actions whose outcome is not "ok".
    pub actions_failed: usize,
    /// Detected kills of agents with a detection latency.
    pub agent_detection_n: usize,
    /// Over the detected kills of agents, ms (the campaign's measure).
    pub agent_detection_ms: Percentiles,
    /// The coordinators' own `detection_latency_ms`, every run pooled.
    pub coordinator_detection_n: usize,
    /// Over the coordinators' own `detection_latency_ms`, ms.
    pub coordinator_detection_ms: Percentiles,
    /// Detected kills of the coordinator and field server.
    pub restart_n: usize,
    /// Over the detected kills of the coordinator and field server, ms.
    pub restart_ms: Percentiles,
    pub late_ticks: u64,
    pub leftover_files: usize,
    pub leftover_processes: usize,
}

/// `chaos.json`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Campaign {
    pub mission: String,
    pub command: String,
    pub started_utc: String,
    pub host: String,
    pub seed: u64,
    pub kills_per_run: usize,
    pub stops_per_run: usize,
    pub paces: Vec<String>,
    pub policies: Vec<String>,
    pub targets: Vec<String>,
    pub window_s: f64,
    pub tail_s: f64,
    pub margin_s: f64,
    /// `--max-detection-ms`, when given.
    pub max_detection_ms: Option<f64>,
    pub vehicles: usize,
    /// Lockstep speed measured by the calibration run, ticks per wall second.
    pub lockstep_ticks_per_s: Option<f64>,
    pub wall_s: f64,
    pub runs: Vec<RunReport>,
    pub totals: Totals,
    pub passed: bool,
    pub failures: Vec<String>,
}

fn parse_list<T>(arg: &str, text: &str, parse: impl Fn(&str) -> Option<T>) -> Result<Vec<T>> {
    let items: Vec<&str> = text
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .collect();
    if items.is_empty() {
        return Err(InvalidInput(format!("{arg} {text:?}: needs at least one value")).into());
    }
    items
        .iter()
        .map(|s| {
            parse(s).ok_or_else(|| InvalidInput(format!("{arg} {text}: {s:?} is not valid")).into())
        })
        .collect()
}

fn parse_policy(s: &str) -> Option<RestartPolicy> {
    match s {
        "never" => Some(RestartPolicy::Never),
        "on-failure" => Some(RestartPolicy::OnFailure),
        "always" => Some(RestartPolicy::Always),
        _ => None,
    }
}

fn policy_name(p: RestartPolicy) -> &'static str {
    match p {
        RestartPolicy::Never => "never",
        RestartPolicy::OnFailure => "on-failure",
        RestartPolicy::Always => "always",
    }
}

fn parse_target(s: &str) -> Option<Target> {
    match s {
        "agents" => Some(Target::Agents),
        "coordinator" => Some(Target::Coordinator),
        "field_server" => Some(Target::FieldServer),
        _ => None,
    }
}

fn target_name(t: Target) -> &'static str {
    match t {
        Target::Agents => "agents",
        Target::Coordinator => "coordinator",
        Target::FieldServer => "field_server",
    }
}

/// `<name>_c<NNN>`, the name cut to fit.
pub fn run_name(name: &str, index: usize) -> String {
    let suffix = format!("_c{index:03}");
    let keep = MAX_NAME_LEN.saturating_sub(suffix.len()).min(name.len());
    format!("{}{suffix}", &name[..keep])
}

/// The seeded plan of one run: (planned wall offset s, kill?, pause s).
pub fn plan(
    seed: u64,
    index: usize,
    kills: usize,
    stops: usize,
    window: f64,
    max_stop: f64,
) -> Vec<(f64, bool, f64)> {
    let mut rng = run_rng(seed, index, 0);
    let mut out: Vec<(f64, bool, f64)> = (0..kills + stops)
        .map(|i| {
            let at = FIRST_ACTION + rng.random::<f64>() * (window - FIRST_ACTION);
            let pause = MIN_STOP + rng.random::<f64>() * (max_stop - MIN_STOP);
            (at, i < kills, if i < kills { 0.0 } else { pause })
        })
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

fn run_rng(seed: u64, index: usize, stream: u64) -> StdRng {
    let mut z = seed ^ 0x6368_616f_7300_0000 ^ ((index as u64) << 8) ^ stream;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    StdRng::seed_from_u64(z ^ (z >> 31))
}

/// Runs the command; returns the exit code.
pub fn main(args: &ChaosArgs) -> Result<i32> {
    let paces = args.paces.clone();
    let policies = parse_list("--policies", &args.policies, parse_policy)?;
    let targets: Vec<Target> = parse_list("--targets", &args.targets, parse_target)?
        .into_iter()
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    if args.runs == 0 {
        return Err(InvalidInput("--runs 0: need at least one run".into()).into());
    }
    if !(args.window.is_finite() && args.window >= 1.0 && args.window <= 600.0) {
        return Err(InvalidInput(format!(
            "--window {}: must be within [1, 600] s",
            args.window
        ))
        .into());
    }
    if !(args.max_stop.is_finite() && args.max_stop >= MIN_STOP && args.max_stop <= 60.0) {
        return Err(InvalidInput(format!(
            "--max-stop {}: must be within [{MIN_STOP}, 60] s",
            args.max_stop
        ))
        .into());
    }
    if args
        .max_detection_ms
        .is_some_and(|ms| !(ms.is_finite() && ms > 0.0))
    {
        return Err(InvalidInput(format!(
            "--max-detection-ms {}: must be a number > 0",
            args.max_detection_ms.unwrap_or_default()
        ))
        .into());
    }
    if args.kills + args.stops > 1000 {
        return Err(InvalidInput("--kills + --stops: at most 1000 actions per run".into()).into());
    }
    let mut base = Mission::load(&args.mission)?.with_overrides(&Overrides {
        vehicles: args.vehicles,
        ..Overrides::default()
    })?;
    base.faults.retain(|f| f.kind != FaultKind::Kill);
    let out = match &args.out {
        Some(p) => p.clone(),
        None => crate::rundirs::default_run_dir(&format!("{}-chaos", base.mission.name))?,
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
    let out = std::fs::canonicalize(&out).context("resolving --out")?;
    let exe = std::env::current_exe().context("locating the vbap executable")?;
    let start = Instant::now();

    let mut campaign = Campaign {
        mission: args.mission.display().to_string(),
        command: std::env::args().collect::<Vec<_>>().join(" "),
        started_utc: utc_now(),
        host: host_description(),
        seed: args.seed,
        kills_per_run: args.kills,
        stops_per_run: args.stops,
        paces: paces.iter().map(|p| p.to_string()).collect(),
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
    };

    let mut index = 0usize;
    if paces.contains(&Pace::Lockstep) {
        // Calibration: how many lockstep ticks a wall second holds on this machine now.
        let mut m = base.clone();
        m.mission.duration = CALIBRATION_TICKS as f64 * m.mission.dt;
        m.faults.retain(|f| f.at <= m.mission.duration);
        let report = run_one(
            &exe,
            &out,
            index,
            m,
            Pace::Lockstep,
            base.restart.vehicles,
            args.seed,
            &[],
            true,
            &targets,
        )?;
        campaign.lockstep_ticks_per_s = lockstep_rate(&report);
        if !args.quiet {
            eprintln!("{}", describe(&report));
        }
        campaign.runs.push(report);
        index += 1;
    }
    for pace in &paces {
        for policy in &policies {
            for r in 0..args.runs {
                let seed = args.seed + r as u64;
                let wall = args.window + TAIL;
                let mut m = base.clone();
                m.mission.duration = match pace {
                    Pace::Factor(f) => f * wall,
                    Pace::Lockstep => {
                        let rate = campaign.lockstep_ticks_per_s.unwrap_or(1000.0);
                        rate * wall * 1.5 * m.mission.dt
                    }
                };
                let max = MAX_TICKS * m.mission.dt;
                m.mission.duration = m.mission.duration.clamp(20.0 * m.mission.dt, max);
                m.faults.retain(|f| f.at <= m.mission.duration);
                for f in &mut m.faults {
                    if let Some(u) = f.until.as_mut() {
                        *u = u.min(m.mission.duration);
                    }
                }
                m.faults.retain(|f| f.until.is_none_or(|u| u > f.at));
                let plan = plan(
                    seed,
                    index,
                    args.kills,
                    args.stops,
                    args.window,
                    args.max_stop,
                );
                let report = run_one(
                    &exe, &out, index, m, *pace, *policy, seed, &plan, false, &targets,
                )?;
                if !args.quiet {
                    eprintln!("{}", describe(&report));
                }
                campaign.runs.push(report);
                index += 1;
            }
        }
    }
    campaign.wall_s = start.elapsed().as_secs_f64();
    if let Some(limit) = args.max_detection_ms {
        for r in &mut campaign.runs {
            apply_detection_limit(r, limit);
        }
    }
    campaign.max_detection_ms = args.max_detection_ms;
    judge(&mut campaign);

    let json = serde_json::to_string_pretty(&campaign)? + "\n";
    std::fs::write(out.join("chaos.json"), &json).context("writing chaos.json")?;
    std::fs::write(out.join("chaos.csv"), csv(&campaign)).context("writing chaos.csv")?;
    let mut stdout = std::io::stdout();
    let _ = write!(stdout, "{}", table(&campaign));
    let _ = stdout.flush();
    eprintln!(
        "campaign: table {}, details {}",
        out.join("chaos.csv").display(),
        out.join("chaos.json").display()
    );
    if campaign.passed {
        eprintln!("PASS");
        Ok(EXIT_OK)
    } else {
        for f in &campaign.failures {
            eprintln!("FAIL: {f}");
        }
        Ok(EXIT_FAILURE)
    }
}

/// Ticks per wall second of a run, between the coordinator's `coordinator up` and
/// `coordinator done` lines (start-up excluded), else over the whole run.
fn lockstep_rate(r: &RunReport) -> Option<f64> {
    let ticks = r.ticks? as f64;
    let log = json_lines(&r.run_dir.join("logs").join("coordinator.jsonl"));
    let at = |msg: &str| {
        log.iter()
            .find(|l| l.pointer("/fields/message").and_then(Value::as_str) == Some(msg))
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

/// What the campaign saw of one process of the set.
struct Seen {
    slot: Slot,
    cmd: Vec<String>,
    first_unix_s: f64,
}

/// Starts `vbap run` on the mission variant, acts on its processes, judges the run.
#[allow(clippy::too_many_arguments)]
fn run_one(
    exe: &Path,
    out: &Path,
    index: usize,
    mut m: Mission,
    pace: Pace,
    policy: RestartPolicy,
    seed: u64,
    plan: &[(f64, bool, f64)],
    calibration: bool,
    targets: &[Target],
) -> Result<RunReport> {
    m.mission.name = run_name(&m.mission.name, index);
    m.mission.seed = seed;
    m.mission.pace = pace;
    m.restart.vehicles = policy;
    m.validate().with_context(|| {
        format!(
            "the mission of run {index} ({pace}, {})",
            policy_name(policy)
        )
    })?;
    let file = out.join("missions").join(format!("{index:03}.toml"));
    std::fs::write(&file, m.to_toml_string())
        .with_context(|| format!("writing {}", file.display()))?;
    let run_dir = out.join("runs").join(format!("{index:03}"));
    std::fs::create_dir_all(&run_dir).with_context(|| format!("creating {}", run_dir.display()))?;
    let mut report = RunReport {
        index,
        calibration,
        pace: pace.to_string(),
        policy: policy_name(policy).into(),
        seed,
        mission_name: m.mission.name.clone(),
        run_dir: run_dir.clone(),
        expected_ticks: m.ticks(),
        ..RunReport::default()
    };
    let log_path = run_dir.join("vbap.log");
    let log = std::fs::File::create(&log_path)
        .with_context(|| format!("creating {}", log_path.display()))?;
    let mut cmd = std::process::Command::new(exe);
    cmd.arg("run")
        .arg(&file)
        .arg("--out")
        .arg(&run_dir)
        .arg("--quiet")
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log);
    vbap_ipc::process::stop_with_parent(&mut cmd);
    let wall = Instant::now();
    let mut child = cmd
        .spawn()
        .with_context(|| format!("starting {}", exe.display()))?;
    let sup = child.id();
    let mission_arg = run_dir.join("mission.toml").to_string_lossy().into_owned();

    let mut seen: BTreeMap<u32, Seen> = BTreeMap::new();
    let mut actions: Vec<Action> = plan
        .iter()
        .map(|&(at, kill, pause)| Action {
            action: if kill { "kill" } else { "stop" }.into(),
            planned_s: at,
            pause_s: (!kill).then_some(pause),
            ..Action::default()
        })
        .collect();
    let mut rng = run_rng(seed, index, 1);
    let n = m.vehicles.count as u32;
    let floor = m.mission.dim + 1;
    let mut up: Option<Instant> = None;
    let mut next = 0usize;
    let mut stopped: Vec<(u32, Instant, usize)> = Vec::new(); // pid, SIGCONT due, action
    let mut killed_slots: BTreeSet<Slot> = BTreeSet::new();
    let mut stopped_slots: BTreeSet<Slot> = BTreeSet::new();
    let status = loop {
        // The process set now.
        let live: Vec<u32> = children(sup);
        for &pid in &live {
            if let std::collections::btree_map::Entry::Vacant(e) = seen.entry(pid) {
                if let Some(c) = cmdline(pid) {
                    if let Some(slot) = slot_of(&c) {
                        e.insert(Seen {
                            slot,
                            cmd: c,
                            first_unix_s: epoch_s(SystemTime::now()),
                        });
                    }
                }
            }
        }
        let current: Vec<(u32, Slot)> = live
            .iter()
            .filter(|p| alive(**p))
            .filter_map(|p| seen.get(p).map(|s| (*p, s.slot)))
            .collect();
        // Continue the stopped processes that are due (always, even late).
        let now = Instant::now();
        stopped.retain(|&(pid, due, a)| {
            if now < due {
                return true;
            }
            let same = seen
                .get(&pid)
                .is_some_and(|s| cmdline(pid).as_ref() == Some(&s.cmd));
            actions[a].survived = Some(same && alive(pid));
            if same {
                send(pid, Signal::SIGCONT);
            }
            actions[a].cont_unix_s = Some(epoch_s(SystemTime::now()));
            false
        });
        match child.try_wait() {
            Ok(Some(st)) => break Ok(st),
            Err(e) => break Err(e),
            Ok(None) => {}
        }
        if up.is_none() {
            let slots: BTreeSet<Slot> = current.iter().map(|(_, s)| *s).collect();
            let all = slots.contains(&Slot::Coordinator)
                && slots.contains(&Slot::FieldServer)
                && (0..n).all(|i| slots.contains(&Slot::Agent(i)));
            let agents_up = all
                && (0..n).all(|i| {
                    std::fs::read_to_string(
                        run_dir
                            .join("logs")
                            .join(format!("vehicle_agent_{i}.jsonl")),
                    )
                    .is_ok_and(|t| t.contains("agent up"))
                });
            if agents_up || (wall.elapsed() > UP_TIMEOUT && all) {
                up = Some(Instant::now());
            }
        }
        if let Some(t0) = up {
            while next < actions.len() && t0.elapsed().as_secs_f64() >= actions[next].planned_s {
                let a = next;
                next += 1;
                let over = std::fs::read_to_string(run_dir.join("logs").join("coordinator.jsonl"))
                    .is_ok_and(|t| t.contains("coordinator done"));
                if over {
                    actions[a].outcome = "not sent: the mission was over".into();
                    continue;
                }
                let kill = actions[a].action == "kill";
                let paused: BTreeSet<u32> = stopped.iter().map(|s| s.0).collect();
                let agents_alive = current
                    .iter()
                    .filter(|(_, s)| matches!(s, Slot::Agent(_)))
                    .count();
                let candidates: Vec<(u32, Slot)> = current
                    .iter()
                    .copied()
                    .filter(|(p, s)| {
                        targets.contains(&s.kind())
                            && !paused.contains(p)
                            && is_up(&run_dir, *p, *s)
                            && match (kill, s) {
                                (true, Slot::Agent(_)) => {
                                    !stopped_slots.contains(s) && agents_alive > floor
                                }
                                (false, Slot::Agent(_)) => {
                                    !killed_slots.contains(s) && !stopped_slots.contains(s)
                                }
                                _ => true,
                            }
                    })
                    .collect();
                let kinds: Vec<Target> = targets
                    .iter()
                    .copied()
                    .filter(|t| candidates.iter().any(|(_, s)| s.kind() == *t))
                    .collect();
                if kinds.is_empty() {
                    actions[a].outcome = if kill {
                        format!("not sent: no live target (agents are spared at {floor} = dim + 1 alive)")
                    } else {
                        "not sent: no live target".into()
                    };
                    continue;
                }
                let kind = kinds[rng.random_range(0..kinds.len())];
                let of_kind: Vec<(u32, Slot)> = candidates
                    .into_iter()
                    .filter(|(_, s)| s.kind() == kind)
                    .collect();
                let (pid, slot) = of_kind[rng.random_range(0..of_kind.len())];
                // The pid is still the process we saw (no reuse since).
                if cmdline(pid).as_ref() != seen.get(&pid).map(|s| &s.cmd) {
                    actions[a].outcome = "not sent: the target ended just before".into();
                    continue;
                }
                let sig = if kill {
                    Signal::SIGKILL
                } else {
                    Signal::SIGSTOP
                };
                let sent_at = SystemTime::now();
                if !send(pid, sig) {
                    actions[a].outcome = "not sent: the target ended just before".into();
                    continue;
                }
                let act = &mut actions[a];
                act.sent = true;
                act.target = slot.label();
                act.slot = Some(slot);
                act.vehicle = match slot {
                    Slot::Agent(i) => Some(i),
                    _ => None,
                };
                act.pid = Some(pid);
                act.at_unix_s = Some(epoch_s(sent_at));
                act.at_s = Some(t0.elapsed().as_secs_f64());
                if kill {
                    killed_slots.insert(slot);
                } else {
                    stopped_slots.insert(slot);
                    let pause = Duration::from_secs_f64(act.pause_s.unwrap_or(MIN_STOP));
                    stopped.push((pid, Instant::now() + pause, a));
                }
            }
        }
        std::thread::sleep(POLL);
    };
    // The run is over: continue anything still stopped (it may have outlived the run).
    for (pid, _, a) in stopped.drain(..) {
        let same = seen
            .get(&pid)
            .is_some_and(|s| cmdline(pid).as_ref() == Some(&s.cmd));
        actions[a].survived = Some(same && alive(pid));
        if same {
            send(pid, Signal::SIGCONT);
        }
        actions[a].cont_unix_s = Some(epoch_s(SystemTime::now()));
    }
    for a in actions.iter_mut().skip(next) {
        a.outcome = "not sent: the mission was over".into();
    }
    let end_unix = epoch_s(SystemTime::now());
    report.wall_s = wall.elapsed().as_secs_f64();
    match status {
        Ok(st) => {
            report.exit_code = st.code();
            if st.code().is_none() {
                report
                    .failures
                    .push(format!("vbap run ended by a signal ({st})"));
            }
        }
        Err(e) => report.failures.push(format!("waiting for vbap run: {e}")),
    }

    // Leftovers: files of the run's domain, live processes of the run; then clean them.
    let domain = Domain::new(&m.mission.name)?;
    report.leftover_processes = leftover_processes(&mission_arg, &seen);
    for entry in &report.leftover_processes {
        if let Some(pid) = entry
            .split_whitespace()
            .next()
            .and_then(|p| p.parse::<u32>().ok())
        {
            send(pid, Signal::SIGCONT);
            send(pid, Signal::SIGKILL);
        }
    }
    report.leftover_files = crate::domain::leftover_files(&domain);
    for f in &report.leftover_files {
        let _ = std::fs::remove_file(f);
    }

    let mut per_slot: BTreeMap<Slot, usize> = BTreeMap::new();
    for p in seen.values() {
        *per_slot.entry(p.slot).or_default() += 1;
    }
    for (slot, n) in per_slot {
        *report
            .restarts_seen
            .entry(target_name(slot.kind()).to_string())
            .or_default() += n - 1;
    }
    evaluate(&mut report, &mut actions, &run_dir, &seen, end_unix, policy);
    report.actions = actions;
    Ok(report)
}

/// True when process `pid` of `slot` is up by its own log (`logs/<process>.jsonl`, the
/// lines after its `started` line): the coordinator and the field server once they say
/// `… up`, an agent once it says `agent up` — and, when it is a restarted agent joining,
/// once it says it was admitted back. A process still starting is no target: the
/// coordinator cannot lose what it has not admitted.
fn is_up(run_dir: &Path, pid: u32, slot: Slot) -> bool {
    let name = match slot {
        Slot::FieldServer => "field_server".to_string(),
        Slot::Coordinator => "coordinator".to_string(),
        Slot::Agent(i) => format!("vehicle_agent_{i}"),
    };
    let lines = json_lines(&run_dir.join("logs").join(format!("{name}.jsonl")));
    let message = |l: &Value| {
        l.pointer("/fields/message")
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_string()
    };
    let Some(start) = lines.iter().rposition(|l| {
        message(l) == "started"
            && l.pointer("/fields/pid").and_then(Value::as_u64) == Some(u64::from(pid))
    }) else {
        return false;
    };
    let mut joining = None;
    for l in &lines[start + 1..] {
        let msg = message(l);
        if msg == "started" {
            break;
        }
        match slot {
            Slot::Agent(_) if msg == "agent up" => {
                joining = Some(l.pointer("/fields/joining").and_then(Value::as_bool) == Some(true));
                if joining == Some(false) {
                    return true;
                }
            }
            Slot::Agent(_) if joining == Some(true) && msg.contains("admitted") => return true,
            Slot::Agent(_) => {}
            _ if msg.ends_with(" up") => return true,
            _ => {}
        }
    }
    false
}

/// Live processes started with the run's mission file, as "pid command line".
fn leftover_processes(mission_arg: &str, seen: &BTreeMap<u32, Seen>) -> Vec<String> {
    let mut out = BTreeMap::new();
    if let Ok(entries) = std::fs::read_dir("/proc") {
        for e in entries.flatten() {
            let Some(pid) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
                continue;
            };
            if let Some(c) = cmdline(pid) {
                if c.iter().any(|a| a == mission_arg) && alive(pid) {
                    out.insert(pid, c.join(" "));
                }
            }
        }
    }
    for (pid, s) in seen {
        if alive(*pid) && cmdline(*pid).as_ref() == Some(&s.cmd) {
            out.insert(*pid, s.cmd.join(" "));
        }
    }
    out.into_iter().map(|(p, c)| format!("{p} {c}")).collect()
}

/// A line of a JSON-lines file, parsed; None for a line that is not JSON.
fn json_lines(path: &Path) -> Vec<Value> {
    std::fs::read_to_string(path)
        .map(|t| {
            t.lines()
                .filter_map(|l| serde_json::from_str(l).ok())
                .collect()
        })
        .unwrap_or_default()
}

fn num_list(v: Option<&Value>) -> Vec<f64> {
    v.and_then(Value::as_array)
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default()
}

/// Wall time (s since the Unix epoch) at which the coordinator published the command of
/// each tick of `ticks`, from the agents' message records (`logs/vehicle_agent_*.msgs.csv`,
/// hop `body`: `sent_ns` is the coordinator's clock when it published): the earliest over
/// every record of that tick. A `lost` event of tick k is written before the command of
/// tick k is published, so this is the first publication after the verdict (at most one
/// tick period after it in a paced run).
fn command_times(logs: &Path, ticks: &BTreeSet<u64>) -> BTreeMap<u64, f64> {
    use std::io::BufRead as _;
    let mut out: BTreeMap<u64, u64> = BTreeMap::new();
    if ticks.is_empty() {
        return BTreeMap::new();
    }
    let Ok(entries) = std::fs::read_dir(logs) else {
        return BTreeMap::new();
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !(name.starts_with("vehicle_agent") && name.ends_with(vbap_ipc::msglog::MSG_SUFFIX)) {
            continue;
        }
        let Ok(file) = std::fs::File::open(e.path()) else {
            continue;
        };
        for line in std::io::BufReader::new(file).lines().map_while(Result::ok) {
            let mut f = line.split(',');
            let (Some(_), Some("body"), Some(_), Some(_), Some(tick), Some(_), Some(sent)) = (
                f.next(),
                f.next(),
                f.next(),
                f.next(),
                f.next(),
                f.next(),
                f.next(),
            ) else {
                continue;
            };
            let (Ok(tick), Ok(sent)) = (tick.parse::<u64>(), sent.parse::<u64>()) else {
                continue;
            };
            if ticks.contains(&tick) {
                let t = out.entry(tick).or_insert(sent);
                *t = (*t).min(sent);
            }
        }
    }
    out.into_iter()
        .map(|(k, ns)| (k, ns as f64 * 1e-9))
        .collect()
}

/// Reads the run directory and judges every action of the run.
fn evaluate(
    report: &mut RunReport,
    actions: &mut [Action],
    run_dir: &Path,
    seen: &BTreeMap<u32, Seen>,
    end_unix: f64,
    policy: RestartPolicy,
) {
    let summary: Option<Value> = std::fs::read_to_string(run_dir.join("summary.json"))
        .ok()
        .and_then(|t| serde_json::from_str(&t).ok());
    if let Some(s) = &summary {
        let u = |k: &str| s.get(k).and_then(Value::as_u64);
        report.ticks = u("ticks");
        report.late_ticks = u("late_ticks");
        report.vehicles_lost = u("vehicles_lost");
        report.vehicles_rejoined = u("vehicles_rejoined");
        report.reconfigurations = u("reconfigurations");
        report.coordinator_detection_ms = num_list(s.get("detection_latency_ms"));
        report.coordinator_rejoin_ms = num_list(s.get("rejoin_latency_ms"));
        report.verdict = match s.get("verdict") {
            Some(Value::String(v)) => v.clone(),
            Some(other) if !other.is_null() => other.to_string(),
            _ => match s.get("converged").and_then(Value::as_bool) {
                Some(true) => "converged".into(),
                Some(false) => "not converged".into(),
                None => "unknown".into(),
            },
        };
        report.reasons = s
            .get("reasons")
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .map(|r| r.as_str().map_or_else(|| r.to_string(), str::to_string))
                    .collect()
            })
            .unwrap_or_default();
    } else {
        report.verdict = "no summary".into();
    }
    let completed = summary.is_some() && report.exit_code == Some(0);
    if !completed {
        report.failures.push(format!(
            "the run failed (vbap run exit {:?}, summary.json {}); see {}",
            report.exit_code,
            if summary.is_some() {
                "written"
            } else {
                "missing"
            },
            run_dir.join("vbap.log").display()
        ));
    }
    let went_on = completed && report.ticks == Some(report.expected_ticks);
    if !report.leftover_files.is_empty() {
        report.failures.push(format!(
            "{} file(s) of the run's iceoryx2 domain left behind",
            report.leftover_files.len()
        ));
    }
    if !report.leftover_processes.is_empty() {
        report.failures.push(format!(
            "{} process(es) left running",
            report.leftover_processes.len()
        ));
    }

    let events = json_lines(&run_dir.join("events.jsonl"));
    let of = |kind: &str, v: u32| -> Vec<&Value> {
        events
            .iter()
            .filter(|e| e.get("kind").and_then(Value::as_str) == Some(kind))
            .filter(|e| e.get("vehicle").and_then(Value::as_u64) == Some(u64::from(v)))
            .filter(|e| {
                e.pointer("/detail/cause").and_then(Value::as_str) != Some("scheduled kill")
            })
            .collect()
    };
    let reconfigs: Vec<&Value> = events
        .iter()
        .filter(|e| e.get("kind").and_then(Value::as_str) == Some("reconfigured"))
        .collect();
    let log: Vec<(f64, Value)> = json_lines(&run_dir.join("logs").join("coordinator.jsonl"))
        .into_iter()
        .filter_map(|l| {
            Some((
                vbap_report::analyze::parse_utc(l.get("timestamp")?.as_str()?)?,
                l,
            ))
        })
        .collect();
    let lost_ticks: BTreeSet<u64> = events
        .iter()
        .filter(|e| e.get("kind").and_then(Value::as_str) == Some("lost"))
        .filter_map(|e| e.get("k").and_then(Value::as_u64))
        .collect();
    let published = command_times(&run_dir.join("logs"), &lost_ticks);
    let mission_end = log
        .iter()
        .rev()
        .find(|(_, l)| {
            l.pointer("/fields/message").and_then(Value::as_str) == Some("coordinator done")
        })
        .map_or(end_unix, |(t, _)| *t);
    let restarts_vehicles = policy != RestartPolicy::Never;
    let restarts_of = |slot: Slot, after: f64| -> Option<f64> {
        seen.values()
            .filter(|s| s.slot == slot && s.first_unix_s > after)
            .map(|s| s.first_unix_s)
            .fold(None, |a: Option<f64>, t| Some(a.map_or(t, |a| a.min(t))))
    };
    let mut kill_count: BTreeMap<Slot, usize> = BTreeMap::new();
    let kill_times: BTreeMap<Slot, Vec<f64>> = actions
        .iter()
        .filter(|a| a.sent && a.action == "kill")
        .filter_map(|a| Some((a.slot?, a.at_unix_s?)))
        .fold(BTreeMap::new(), |mut acc, (s, t)| {
            acc.entry(s).or_insert_with(Vec::new).push(t);
            acc
        });
    for a in actions.iter_mut().filter(|a| a.sent) {
        let (Some(slot), Some(at)) = (a.slot, a.at_unix_s) else {
            continue;
        };
        let mut problems: Vec<String> = Vec::new();
        if a.action == "kill" {
            let i = *kill_count.entry(slot).and_modify(|c| *c += 1).or_insert(0);
            let next_kill = kill_times
                .get(&slot)
                .and_then(|t| t.get(i + 1))
                .copied()
                .unwrap_or(f64::INFINITY);
            a.restarted_ms = restarts_of(slot, at)
                .filter(|t| *t < next_kill)
                .map(|t| (t - at) * 1e3);
            match slot {
                Slot::Agent(v) => {
                    let lost = of("lost", v);
                    let found = lost.get(i);
                    a.detected = Some(found.is_some());
                    a.detected_t = found.and_then(|e| e.get("t")).and_then(Value::as_f64);
                    if found.is_some() {
                        let k = found.and_then(|e| e.get("k")).and_then(Value::as_u64);
                        a.detection_ms = k
                            .and_then(|k| published.get(&k))
                            .map(|t| (t - at) * 1e3)
                            .or_else(|| {
                                // No message records: the coordinator's warning about the
                                // vehicle (its verdict "dead"), if it wrote one.
                                log.iter()
                                    .find(|(t, l)| {
                                        *t > at
                                            && *t < next_kill
                                            && l.get("level").and_then(Value::as_str)
                                                == Some("WARN")
                                            && l.pointer("/fields/vehicle").and_then(Value::as_u64)
                                                == Some(u64::from(v))
                                    })
                                    .map(|(t, _)| (t - at) * 1e3)
                            });
                    } else {
                        problems.push("not detected".into());
                    }
                    let lost_k = found.and_then(|e| e.get("k")).and_then(Value::as_u64);
                    if restarts_vehicles {
                        let rejoin = of("rejoin", v);
                        let r = rejoin.get(i);
                        a.rejoined = Some(r.is_some());
                        a.rejoin_t = r.and_then(|e| e.get("t")).and_then(Value::as_f64);
                        if r.is_none() {
                            problems.push("not readmitted".into());
                        }
                    } else {
                        let re = lost_k.is_some_and(|k| {
                            reconfigs.iter().any(|e| {
                                e.get("k").and_then(Value::as_u64).is_some_and(|ek| ek >= k)
                                    && e.pointer("/detail/vehicles")
                                        .and_then(Value::as_array)
                                        .is_some_and(|vs| {
                                            !vs.iter().any(|x| x.as_u64() == Some(u64::from(v)))
                                        })
                            })
                        });
                        a.reconfigured = Some(re);
                        if !re {
                            problems.push("no formation redesigned without it".into());
                        }
                    }
                    if !completed {
                        problems.push("the run failed".into());
                    }
                }
                Slot::Coordinator | Slot::FieldServer => {
                    a.detected = Some(a.restarted_ms.is_some());
                    a.detection_ms = a.restarted_ms;
                    if a.restarted_ms.is_none() {
                        problems.push("not restarted".into());
                    }
                    if !went_on {
                        problems.push("the mission did not go on to its last tick".into());
                    }
                }
            }
            a.recovered = Some(problems.is_empty());
        } else {
            if a.survived != Some(true) {
                problems.push("the stopped process did not survive".into());
            }
            if let Slot::Agent(v) = slot {
                let lost = !of("lost", v).is_empty();
                a.declared_lost = Some(lost);
                if lost && of("rejoin", v).is_empty() {
                    problems.push("declared lost and never readmitted".into());
                }
            }
            if !completed {
                problems.push("the run failed".into());
            }
        }
        let last = a.cont_unix_s.unwrap_or(at).max(at);
        a.judged = mission_end - last >= MARGIN || problems.is_empty();
        a.outcome = if problems.is_empty() {
            "ok".into()
        } else if a.judged {
            problems.join("; ")
        } else {
            format!(
                "unjudged: the mission ended {:.2} s after ({})",
                mission_end - last,
                problems.join("; ")
            )
        };
        if a.failed() {
            report.failures.push(format!(
                "{} of {} at {:.2} s: {}",
                a.action,
                a.target,
                a.at_s.unwrap_or(0.0),
                a.outcome
            ));
        }
    }
}

/// Fails every judged kill of `r` detected later than `limit` ms (`--max-detection-ms`).
fn apply_detection_limit(r: &mut RunReport, limit: f64) {
    for a in r
        .actions
        .iter_mut()
        .filter(|a| a.sent && a.judged && a.action == "kill")
    {
        let Some(ms) = a.detection_ms.filter(|ms| *ms > limit) else {
            continue;
        };
        let slow = format!("detected after {ms:.0} ms > --max-detection-ms {limit}");
        a.outcome = if a.outcome == "ok" {
            slow
        } else {
            format!("{}; {slow}", a.outcome)
        };
        r.failures.push(format!(
            "{} of {} at {:.2} s: {}",
            a.action,
            a.target,
            a.at_s.unwrap_or(0.0),
            a.outcome
        ));
    }
}

/// Totals, pass/fail.
fn judge(c: &mut Campaign) {
    let mut t = Totals {
        runs: c.runs.len(),
        ..Totals::default()
    };
    let mut agent_ms = Vec::new();
    let mut restart_ms = Vec::new();
    let mut failures = Vec::new();
    for r in &c.runs {
        if !r.failures.is_empty() {
            t.runs_failed += 1;
            for f in &r.failures {
                failures.push(format!(
                    "run {:03} ({}, {}): {f}",
                    r.index, r.pace, r.policy
                ));
            }
        }
        t.late_ticks += r.late_ticks.unwrap_or(0);
        t.leftover_files += r.leftover_files.len();
        t.leftover_processes += r.leftover_processes.len();
        for a in &r.actions {
            if !a.sent {
                t.not_sent += 1;
                continue;
            }
            if !a.judged {
                t.unjudged += 1;
            }
            if a.failed() {
                t.actions_failed += 1;
            }
            if a.action == "kill" {
                t.kills_sent += 1;
                if a.judged {
                    t.kills_judged += 1;
                    if a.detected == Some(true) {
                        t.kills_detected += 1;
                    } else {
                        t.kills_undetected += 1;
                    }
                    if a.recovered == Some(true) {
                        t.kills_recovered += 1;
                    }
                }
                if let Some(ms) = a.detection_ms {
                    if a.vehicle.is_some() {
                        agent_ms.push(ms);
                    } else {
                        restart_ms.push(ms);
                    }
                }
            } else {
                t.stops_sent += 1;
                if a.outcome == "ok" {
                    t.stops_ok += 1;
                }
            }
        }
    }
    let mut own: Vec<f64> = c
        .runs
        .iter()
        .flat_map(|r| r.coordinator_detection_ms.iter().copied())
        .collect();
    t.agent_detection_n = agent_ms.len();
    t.agent_detection_ms = Percentiles::of(&mut agent_ms);
    t.coordinator_detection_n = own.len();
    t.coordinator_detection_ms = Percentiles::of(&mut own);
    t.restart_n = restart_ms.len();
    t.restart_ms = Percentiles::of(&mut restart_ms);
    c.totals = t;
    c.passed = failures.is_empty();
    c.failures = failures;
}

/// Header of `chaos.csv`.
pub const CSV_HEADER: &str = "run,pace,policy,seed,action,target,pid,at_s,pause_s,sent,judged,detected,detected_t,detection_ms,restarted_ms,rejoined,rejoin_t,reconfigured,survived,declared_lost,recovered,verdict,outcome";

fn csv(c: &Campaign) -> String {
    fn o<T: std::fmt::Display>(v: Option<T>) -> String {
        v.map(|v| v.to_string()).unwrap_or_default()
    }
    fn quote(s: &str) -> String {
        if s.contains([',', '"', '\n']) {
            format!("\"{}\"", s.replace('"', "\"\"").replace('\n', " "))
        } else {
            s.to_string()
        }
    }
    let mut out = String::from(CSV_HEADER);
    out.push('\n');
    for r in &c.runs {
        for a in &r.actions {
            out.push_str(&format!(
                "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                r.index,
                r.pace,
                r.policy,
                r.seed,
                a.action,
                quote(&a.target),
                o(a.pid),
                o(a.at_s),
                o(a.pause_s),
                a.sent,
                a.judged,
                o(a.detected),
                o(a.detected_t),
                o(a.detection_ms),
                o(a.restarted_ms),
                o(a.rejoined),
                o(a.rejoin_t),
                o(a.reconfigured),
                o(a.survived),
                o(a.declared_lost),
                o(a.recovered),
                quote(&r.verdict),
                quote(&a.outcome)
            ));
        }
    }
    out
}

fn describe(r: &RunReport) -> String {
    let sent = r.actions.iter().filter(|a| a.sent).count();
    let bad = r.actions.iter().filter(|a| a.failed()).count();
    format!(
        "run {:03} ({}pace {}, policy {}): exit {}, {:.1} s, ticks {}/{}, {} action(s) sent, {} failed, {} leftover(s){}",
        r.index,
        if r.calibration { "calibration, " } else { "" },
        r.pace,
        r.policy,
        r.exit_code.map_or("-".into(), |c| c.to_string()),
        r.wall_s,
        r.ticks.map_or("-".into(), |t| t.to_string()),
        r.expected_ticks,
        sent,
        bad,
        r.leftover_files.len() + r.leftover_processes.len(),
        if r.failures.is_empty() { "" } else { ": FAILED" }
    )
}

/// The table printed on the terminal: one line per action, one per run, totals.
pub fn table(c: &Campaign) -> String {
    fn o(v: Option<f64>, d: usize) -> String {
        v.map_or("-".into(), |v| format!("{v:.d$}"))
    }
    fn b(v: Option<bool>) -> &'static str {
        match v {
            Some(true) => "yes",
            Some(false) => "NO",
            None => "-",
        }
    }
    let mut s = String::new();
    s.push_str(&format!(
        "{:>3} {:>8} {:>10} {:>4} {:<16} {:>7} {:>6} {:>8} {:>9} {:>9} {:>8} {:>8}  {}\n",
        "run",
        "pace",
        "policy",
        "act",
        "target",
        "at s",
        "det",
        "det t",
        "det ms",
        "restart",
        "rejoin",
        "reconf",
        "outcome"
    ));
    for r in &c.runs {
        for a in &r.actions {
            s.push_str(&format!(
                "{:>3} {:>8} {:>10} {:>4} {:<16} {:>7} {:>6} {:>8} {:>9} {:>9} {:>8} {:>8}  {}\n",
                r.index,
                r.pace,
                r.policy,
                a.action,
                if a.target.is_empty() { "-" } else { &a.target },
                o(a.at_s, 2),
                if a.action == "stop" {
                    b(a.survived)
                } else {
                    b(a.detected)
                },
                o(a.detected_t, 2),
                o(a.detection_ms, 0),
                o(a.restarted_ms, 0),
                b(a.rejoined),
                b(a.reconfigured),
                a.outcome
            ));
        }
    }
    s.push_str(
        "(det: kill detected, or stopped process survived; det t: mission time of the `lost` \
         event; det ms: SIGKILL to the coordinator's first command after its verdict, or to \
         the new process of a coordinator or field server; restart: SIGKILL to a new process \
         in the slot)\n\n",
    );
    s.push_str(&format!(
        "{:>3} {:>8} {:>10} {:>5} {:>9} {:>6} {:>5} {:>8} {:>8} {:>9} {:>6} {:>9}  {}\n",
        "run",
        "pace",
        "policy",
        "exit",
        "ticks",
        "late",
        "lost",
        "rejoined",
        "reconfig",
        "rst a/c/f",
        "left",
        "wall s",
        "verdict"
    ));
    for r in &c.runs {
        s.push_str(&format!(
            "{:>3} {:>8} {:>10} {:>5} {:>9} {:>6} {:>5} {:>8} {:>8} {:>9} {:>6} {:>9.1}  {}{}\n",
            r.index,
            r.pace,
            if r.calibration { "(calib.)" } else { &r.policy },
            r.exit_code.map_or("-".into(), |c| c.to_string()),
            r.ticks.map_or("-".into(), |t| t.to_string()),
            r.late_ticks.map_or("-".into(), |t| t.to_string()),
            r.vehicles_lost.map_or("-".into(), |t| t.to_string()),
            r.vehicles_rejoined.map_or("-".into(), |t| t.to_string()),
            r.reconfigurations.map_or("-".into(), |t| t.to_string()),
            format!(
                "{}/{}/{}",
                r.restarts_seen.get("agents").copied().unwrap_or(0),
                r.restarts_seen.get("coordinator").copied().unwrap_or(0),
                r.restarts_seen.get("field_server").copied().unwrap_or(0)
            ),
            r.leftover_files.len() + r.leftover_processes.len(),
            r.wall_s,
            r.verdict,
            if r.reasons.is_empty() {
                String::new()
            } else {
                format!(" ({})", r.reasons.join("; "))
            }
        ));
    }
    s.push_str(
        "(late: ticks whose states were not all in at the deadline; rst a/c/f: processes \
         the supervisor started again, agents/coordinator/field server; left: leftover files \
         and processes)\n",
    );
    let t = &c.totals;
    s.push_str(&format!(
        "\n{} runs ({} failed); kills: {} sent, {} judged, {} detected, {} undetected, {} recovered; stops: {} sent, {} ok; {} not sent, {} unjudged; {} judged action(s) failed\n",
        t.runs, t.runs_failed, t.kills_sent, t.kills_judged, t.kills_detected, t.kills_undetected, t.kills_recovered, t.stops_sent, t.stops_ok, t.not_sent, t.unjudged, t.actions_failed
    ));
    let dist = |n: usize, p: &Percentiles| {
        if n == 0 {
            "none".to_string()
        } else {
            format!(
                "n {n}, p50 {:.0}, p90 {:.0}, p99 {:.0}, max {:.0}",
                p.p50, p.p90, p.p99, p.max
            )
        }
    };
    s.push_str(&format!(
        "agent detection ms: {}; the coordinators' own detection_latency_ms: {}; restart ms (coordinator, field server): {}\nlate ticks {}; leftovers: {} files, {} processes\n",
        dist(t.agent_detection_n, &t.agent_detection_ms),
        dist(t.coordinator_detection_n, &t.coordinator_detection_ms),
        dist(t.restart_n, &t.restart_ms),
        t.late_ticks,
        t.leftover_files,
        t.leftover_processes
    ));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slots_from_command_lines() {
        let v = |s: &str| s.split(' ').map(String::from).collect::<Vec<_>>();
        assert_eq!(
            slot_of(&v("/x/vehicle_agent --mission m --id 3 --log l")),
            Some(Slot::Agent(3))
        );
        assert_eq!(
            slot_of(&v("/x/coordinator --mission m")),
            Some(Slot::Coordinator)
        );
        assert_eq!(
            slot_of(&v("field_server --mission m")),
            Some(Slot::FieldServer)
        );
        assert_eq!(slot_of(&v("/x/vbap run m")), None);
        assert_eq!(slot_of(&v("/x/vehicle_agent --mission m")), None);
    }

    #[test]
    fn plans_are_seeded_sorted_and_inside_the_window() {
        let a = plan(7, 3, 5, 2, 4.0, 2.0);
        assert_eq!(a, plan(7, 3, 5, 2, 4.0, 2.0));
        assert_ne!(a, plan(8, 3, 5, 2, 4.0, 2.0));
        assert_eq!(a.iter().filter(|x| x.1).count(), 5);
        assert!(a.windows(2).all(|w| w[0].0 <= w[1].0));
        for (at, kill, pause) in a {
            assert!((FIRST_ACTION..=4.0).contains(&at));
            if kill {
                assert_eq!(pause, 0.0);
            } else {
                assert!((MIN_STOP..=2.0).contains(&pause));
            }
        }
    }

    #[test]
    fn a_detection_limit_fails_slow_judged_kills_only() {
        let kill = |ms: f64, judged: bool| Action {
            action: "kill".into(),
            target: "vehicle_agent 1".into(),
            sent: true,
            judged,
            detected: Some(true),
            detection_ms: Some(ms),
            outcome: "ok".into(),
            ..Action::default()
        };
        let mut r = RunReport {
            actions: vec![kill(200.0, true), kill(900.0, true), kill(900.0, false)],
            ..RunReport::default()
        };
        apply_detection_limit(&mut r, 500.0);
        assert_eq!(r.actions[0].outcome, "ok");
        assert!(r.actions[1].outcome.contains("detected after 900 ms"));
        assert!(r.actions[1].failed() && !r.actions[2].failed());
        assert_eq!(r.failures.len(), 1);
    }

    #[test]
    fn run_names_fit() {
        assert_eq!(run_name("paper", 3), "paper_c003");
        let long = run_name(&"a".repeat(40), 12);
        assert_eq!(long.len(), MAX_NAME_LEN);
        assert!(long.ends_with("_c012"));
    }
}
