//! The campaign's arguments and plan: `vbap chaos` options, their checks, the mission of
//! each run, and the seeded actions of a run.

use std::path::PathBuf;

use anyhow::Result;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use vbap_mission::config::{Mission, Pace, RestartPolicy, MAX_TICKS};

use super::procs::Target;
use super::timing::{FIRST_ACTION, MIN_STOP, TAIL};
use vbap_ipc::process::InvalidInput;

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
    /// What may be hit, comma-separated: agents, coordinator, field_server; or all.
    #[arg(long, default_value = "agents")]
    pub targets: String,
    /// Compound faults per run: a death during another recovery, each of a seeded case:
    /// an agent killed during a coordinator restart, during a field-server restart, or
    /// while it is stopped (SIGSTOP then SIGKILL of the same process). Whatever
    /// `--targets` says.
    #[arg(long, default_value_t = 0)]
    pub compound: usize,
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

pub(super) fn parse_list<T>(
    arg: &str,
    text: &str,
    parse: impl Fn(&str) -> Option<T>,
) -> Result<Vec<T>> {
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

pub(super) fn parse_policy(s: &str) -> Option<RestartPolicy> {
    match s {
        "never" => Some(RestartPolicy::Never),
        "on-failure" => Some(RestartPolicy::OnFailure),
        "always" => Some(RestartPolicy::Always),
        _ => None,
    }
}

pub(super) fn policy_name(p: RestartPolicy) -> &'static str {
    match p {
        RestartPolicy::Never => "never",
        RestartPolicy::OnFailure => "on-failure",
        RestartPolicy::Always => "always",
    }
}

pub(super) fn parse_target(s: &str) -> Option<Target> {
    match s {
        "agents" => Some(Target::Agents),
        "coordinator" => Some(Target::Coordinator),
        "field_server" => Some(Target::FieldServer),
        _ => None,
    }
}

/// `--targets`: a list of targets, or `all`.
pub(super) fn parse_targets(text: &str) -> Result<Vec<Target>> {
    let all = [Target::Agents, Target::Coordinator, Target::FieldServer];
    let items = parse_list("--targets", text, |s| match s {
        "all" => Some(all.to_vec()),
        _ => parse_target(s).map(|t| vec![t]),
    })?;
    let set: std::collections::BTreeSet<Target> = items.into_iter().flatten().collect();
    Ok(set.into_iter().collect())
}

/// A compound fault: a death during another recovery.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compound {
    /// SIGKILL of the coordinator, then of an agent while the coordinator restarts.
    DuringCoordinatorRestart,
    /// SIGKILL of the field server, then of an agent while the field server restarts.
    DuringFieldServerRestart,
    /// SIGSTOP of an agent, then SIGKILL of that same stopped process.
    WhileStopped,
}

impl Compound {
    /// Its name in `chaos.json` and the tables.
    pub fn name(self) -> &'static str {
        match self {
            Compound::DuringCoordinatorRestart => "kill during coordinator restart",
            Compound::DuringFieldServerRestart => "kill during field-server restart",
            Compound::WhileStopped => "kill while stopped",
        }
    }
}

/// The seeded compound faults of one run: (planned wall offset s, case), sorted; drawn
/// from a stream of their own, so the single actions of a seed do not change.
pub fn compound_plan(seed: u64, index: usize, n: usize, window: f64) -> Vec<(f64, Compound)> {
    let mut rng = run_rng(seed, index, 2);
    let cases = [
        Compound::DuringCoordinatorRestart,
        Compound::DuringFieldServerRestart,
        Compound::WhileStopped,
    ];
    let mut out: Vec<(f64, Compound)> = (0..n)
        .map(|_| {
            let at = FIRST_ACTION + rng.random::<f64>() * (window - FIRST_ACTION);
            (at, cases[rng.random_range(0..cases.len())])
        })
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

pub(super) fn target_name(t: Target) -> &'static str {
    match t {
        Target::Agents => "agents",
        Target::Coordinator => "coordinator",
        Target::FieldServer => "field_server",
    }
}

/// `<name>_c<NNN>`, the name cut to fit.
pub fn run_name(name: &str, index: usize) -> String {
    vbap_mission::config::suffixed_name(name, &format!("_c{index:03}"))
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

pub(super) fn run_rng(seed: u64, index: usize, stream: u64) -> StdRng {
    let mut z = seed ^ 0x6368_616f_7300_0000 ^ ((index as u64) << 8) ^ stream;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    StdRng::seed_from_u64(z ^ (z >> 31))
}

/// `--policies` and `--targets` (sorted, each once), after checking every other argument.
pub(super) fn check(args: &ChaosArgs) -> Result<(Vec<RestartPolicy>, Vec<Target>)> {
    let policies = parse_list("--policies", &args.policies, parse_policy)?;
    let targets = parse_targets(&args.targets)?;
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
    if args.kills + args.stops + 2 * args.compound > 1000 {
        return Err(InvalidInput(
            "--kills + --stops + 2 × --compound: at most 1000 actions per run".into(),
        )
        .into());
    }
    Ok((policies, targets))
}

/// The mission of a run at `pace`: paced, `pace × (window + TAIL)` mission seconds; lockstep,
/// the ticks of 1.5 × (window + TAIL) wall seconds at `lockstep_rate` ticks/s (1000 when
/// not measured); within [20 ticks, MAX_TICKS]. Faults that no longer fit are dropped or
/// cut at the end.
pub(super) fn run_mission(
    base: &Mission,
    pace: Pace,
    window: f64,
    lockstep_rate: Option<f64>,
) -> Mission {
    let wall = window + TAIL;
    let mut m = base.clone();
    m.mission.duration = match pace {
        Pace::Factor(f) => f * wall,
        Pace::Lockstep => {
            let rate = lockstep_rate.unwrap_or(1000.0);
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
    m
}
