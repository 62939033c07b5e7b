//! `vbap bench`: the cost of IPC against its floor, and scaling to 256 vehicles.
//!
//! One run measures, on this machine and in this run, every figure and the baselines it is
//! compared with, then prints ratios (never asserts a time):
//!
//! 1. **Hop latency**: the state → coordinator hop of `vbap run` (one-way, from the message
//!    records of the logs, as `vbap analyze` reports it) against a raw iceoryx2 ping-pong of
//!    the same payload in the same wake-up mode (pub-sub + event, blocking WaitSet on both
//!    sides: the floor) and against the same ping-pong over UDP loopback with a blocking
//!    `recv` (what a user might pick instead). Floors are real two-process measurements: the
//!    peer is this executable in a hidden helper role ([`floors`]); each is taken with idle
//!    CPUs and with the CPUs kept awake by lowest-priority spinners, as a loaded run keeps
//!    them (an idle vCPU of a KVM guest takes ~20 µs longer to wake).
//! 2. **Lockstep scaling**: ticks per second of `vbap run` at N = 4, 16, 64, 256 against the
//!    in-process simulator on the same mission and against the wake-up floor: one blocking
//!    iceoryx2 event round through N + 1 processes per tick, no payload work ([`floors`]).
//! 3. **Real-time capacity**: the largest N that runs at pace 1.0, dt = 0.1 s with no late
//!    tick.
//! 4. **Glider-days per wall minute**: 6 gliders (deploy/missions/glider.toml, dt = 10 s,
//!    surfacing every 2 h for 10 min), `vbap sim` and `vbap run`.
//! 5. **Footprint**: start-up time of the process set and memory (PSS) per vehicle.
//!
//! How each figure is derived from the runs is in [`system`] and in BENCHMARKS.md.

mod floors;
mod system;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use iceoryx2::node::{Node, NodeWaitFailure};
use iceoryx2::prelude::ipc;
use serde::Serialize;
use vbap_ipc::topics::Domain;
use vbap_mission::config::{Mission, Pace};
use vbap_mission::rundir::Percentiles;

use crate::domain::clean_domain;
use crate::errors::InvalidInput;

use floors::HopFloor;
use system::{Footprint, SystemRun};

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Quick run: fewer samples, shorter missions, no N = 256 (a smoke run, < 1 min).
    #[arg(long)]
    pub quick: bool,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Keep the run directories (missions, logs, summaries) in this directory (must be
    /// empty or absent). Default: a temporary directory, removed at the end except for
    /// the runs that failed, ran late, rejected states or lost vehicles.
    #[arg(long)]
    pub work_dir: Option<PathBuf>,
    /// Helper role of a peer process (internal).
    #[arg(long, hide = true, value_enum)]
    pub role: Option<floors::Role>,
    /// Helper: the private iceoryx2 domain (mission name) of the floor (internal).
    #[arg(long, hide = true)]
    pub domain: Option<String>,
    /// Helper: the agent id (internal).
    #[arg(long, hide = true)]
    pub id: Option<usize>,
    /// Helper: the number of agents of the wake-up floor (internal).
    #[arg(long, hide = true)]
    pub agents: Option<usize>,
    /// Helper: exit when this process is no longer our parent (internal).
    #[arg(long, hide = true)]
    pub parent: Option<u32>,
}

/// Exit code of a bench stopped by SIGINT/SIGTERM.
const EXIT_INTERRUPTED: i32 = 130;

/// The bench was stopped by a signal.
#[derive(Debug, thiserror::Error)]
#[error("interrupted")]
pub(crate) struct Interrupted;

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Catches SIGINT/SIGTERM for the whole bench: an iceoryx2 node with
/// `HandleTerminationRequests` turns them into a flag that [`StopFlag::check`] reads between
/// and inside the phases, so an interrupted bench still reaps its children and removes its
/// shared-memory files.
pub(crate) struct StopFlag {
    node: Node<ipc::Service>,
    domain: Domain,
}

impl StopFlag {
    fn new(domain: Domain) -> Result<Self> {
        let node = domain.node("bench_signals")?;
        let flag = Self { node, domain };
        let _ = flag.requested(); // installs iceoryx2's signal capture now
        Ok(flag)
    }

    /// True once SIGINT or SIGTERM has arrived (sticky).
    pub(crate) fn requested(&self) -> bool {
        if !INTERRUPTED.load(Ordering::SeqCst) {
            if let Err(NodeWaitFailure::Interrupt | NodeWaitFailure::TerminationRequest) =
                self.node.wait(Duration::ZERO)
            {
                INTERRUPTED.store(true, Ordering::SeqCst);
            }
        }
        INTERRUPTED.load(Ordering::SeqCst)
    }

    /// Records a signal seen by some other iceoryx2 wait.
    pub(crate) fn set() {
        INTERRUPTED.store(true, Ordering::SeqCst);
    }

    /// `Err(Interrupted)` once a signal has arrived.
    pub(crate) fn check(&self) -> Result<()> {
        if self.requested() {
            Err(Interrupted.into())
        } else {
            Ok(())
        }
    }

    fn close(self) {
        let Self { node, domain } = self;
        drop(node);
        let _ = clean_domain(&domain);
    }
}

/// This executable, as it was when the bench started (a rebuild during the bench replaces
/// the file, and `/proc/self/exe` then names a deleted file).
pub(crate) fn exe() -> Result<PathBuf> {
    static EXE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    if let Some(p) = EXE.get() {
        return Ok(p.clone());
    }
    let p = std::env::current_exe().context("locating the vbap executable")?;
    Ok(EXE.get_or_init(|| p).clone())
}

/// A fresh mission / domain name of this bench: `bench<pid>x<counter>` (letters, digits,
/// ≤ 32 characters).
pub(crate) fn unique_name(tag: &str) -> String {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    format!(
        "bench{}{tag}{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::SeqCst)
    )
}

/// Sample counts and mission lengths of one bench run.
#[derive(Clone, Debug, Serialize)]
struct Plan {
    /// Round trips of each ping-pong (after the warm-up).
    pingpong_samples: usize,
    /// Warm-up round trips, not recorded.
    pingpong_warmup: usize,
    /// The lockstep scaling runs.
    lockstep: Vec<LockstepPlan>,
    /// N of the real-time sweep (stops at the first N with a late tick).
    realtime: Vec<usize>,
    /// Mission time of each real-time run, s.
    realtime_duration_s: f64,
    /// N of the footprint runs (start-up, PSS).
    footprint: Vec<usize>,
    /// Mission time of each footprint run, s.
    footprint_duration_s: f64,
    /// Mission time of the glider runs, s.
    glider_duration_s: f64,
}

impl Plan {
    fn new(quick: bool) -> Self {
        if quick {
            Self {
                pingpong_samples: 3000,
                pingpong_warmup: 300,
                lockstep: vec![lp(4, 1000, 1000), lp(16, 500, 500), lp(64, 150, 200)],
                realtime: vec![16, 32],
                realtime_duration_s: 3.0,
                footprint: vec![16],
                footprint_duration_s: 4.0,
                glider_duration_s: 21_600.0,
            }
        } else {
            Self {
                pingpong_samples: 20_000,
                pingpong_warmup: 2000,
                lockstep: vec![
                    lp(4, 4000, 5000),
                    lp(16, 2000, 3000),
                    lp(64, 600, 1000),
                    lp(256, 200, 300),
                ],
                realtime: vec![16, 32, 64, 128, 256],
                realtime_duration_s: 10.0,
                footprint: vec![16, 256],
                footprint_duration_s: 8.0,
                glider_duration_s: 129_600.0,
            }
        }
    }
}

/// One N of the lockstep scaling.
#[derive(Clone, Copy, Debug, Serialize)]
struct LockstepPlan {
    vehicles: usize,
    /// Ticks of `vbap run` and `vbap sim`.
    ticks: u64,
    /// Rounds of the wake-up floor.
    floor_rounds: usize,
}

const fn lp(vehicles: usize, ticks: u64, floor_rounds: usize) -> LockstepPlan {
    LockstepPlan {
        vehicles,
        ticks,
        floor_rounds,
    }
}

/// The machine the figures come from.
#[derive(Clone, Debug, Default, Serialize)]
struct Machine {
    cpus: usize,
    cpu_model: String,
    kernel: String,
    /// UTC date and time of the run.
    date: String,
    /// Share of all CPU time during the bench used by processes other than the bench and
    /// its children (a build, another test): figures taken with a busy machine are low.
    other_load: Option<f64>,
}

/// CPU time counters (clock ticks): the machine's (/proc/stat) and the bench's own with
/// its reaped children (/proc/self/stat).
#[derive(Clone, Copy, Debug)]
struct CpuMark {
    busy: u64,
    total: u64,
    ours: u64,
}

impl CpuMark {
    fn read() -> Option<Self> {
        let stat = std::fs::read_to_string("/proc/stat").ok()?;
        let cpu: Vec<u64> = stat
            .lines()
            .next()?
            .split_whitespace()
            .skip(1)
            .filter_map(|v| v.parse().ok())
            .collect();
        // user nice system idle iowait irq softirq steal ...
        let busy = cpu.iter().take(3).sum::<u64>();
        let total = cpu.iter().take(8).sum::<u64>();
        let own = std::fs::read_to_string("/proc/self/stat").ok()?;
        // Fields after the command name (which may hold spaces): state is field 3; utime,
        // stime, cutime, cstime are fields 14 to 17.
        let rest = own.rsplit_once(')')?.1;
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let ours = fields
            .get(11..15)?
            .iter()
            .filter_map(|v| v.parse::<i64>().ok())
            .sum::<i64>()
            .max(0) as u64;
        Some(Self { busy, total, ours })
    }

    /// Share of all CPU time between `self` and `later` used by other processes.
    fn other_share(&self, later: &Self) -> Option<f64> {
        let total = later.total.checked_sub(self.total)?;
        let busy = later.busy.checked_sub(self.busy)?;
        let ours = later.ours.checked_sub(self.ours)?;
        (total > 0).then(|| busy.saturating_sub(ours) as f64 / total as f64)
    }
}

impl Machine {
    fn probe() -> Self {
        let cpu_model = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into());
        let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease")
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|_| "unknown".into());
        let date = time::OffsetDateTime::now_utc()
            .format(&time::format_description::well_known::Rfc3339)
            .unwrap_or_default();
        Self {
            cpus: std::thread::available_parallelism().map_or(0, |n| n.get()),
            cpu_model,
            kernel,
            date,
            other_load: None,
        }
    }
}

/// The state hop of one `vbap run`.
#[derive(Clone, Debug, Serialize)]
struct SystemHop {
    vehicles: usize,
    transport_us: Percentiles,
    samples: u64,
}

/// One row of the lockstep scaling table.
#[derive(Clone, Debug, Serialize)]
struct LockstepRow {
    vehicles: usize,
    ticks: u64,
    /// `vbap run`, ticks/s of the mission itself (start-up excluded).
    run_ticks_per_s: Option<f64>,
    /// `vbap sim` on the same mission, ticks/s.
    in_process_ticks_per_s: f64,
    /// One blocking iceoryx2 event round through N + 1 processes, rounds/s.
    wake_floor_ticks_per_s: f64,
    /// Wall time per tick and vehicle, µs: run, in-process, floor.
    run_us_per_tick_vehicle: Option<f64>,
    in_process_us_per_tick_vehicle: f64,
    floor_us_per_tick_vehicle: f64,
    /// Why the run failed (no figures), if it did.
    error: Option<String>,
    /// What makes the figures suspect (rejected states, lost vehicles), if anything.
    note: Option<String>,
}

/// One row of the real-time sweep.
#[derive(Clone, Debug, Serialize)]
struct RealtimeRow {
    vehicles: usize,
    ticks: u64,
    late_ticks: u64,
    /// States the coordinator rejected, and how many of them were from the future (an
    /// agent stepped on its own: it held station while the coordinator was silent).
    rejected: u64,
    rejected_future: u64,
    vehicles_lost: usize,
    /// Every tick run, none late, no vehicle lost.
    holds: bool,
    startup_s: Option<f64>,
    error: Option<String>,
}

/// The real-time capacity.
#[derive(Clone, Debug, Serialize)]
struct Realtime {
    dt_s: f64,
    duration_s: f64,
    rows: Vec<RealtimeRow>,
    /// Largest N of the sweep such that it and every smaller N held pace.
    largest_vehicles: Option<usize>,
}

/// Glider-days per wall minute of one mode.
#[derive(Clone, Debug, Serialize)]
struct GliderRate {
    /// Wall time of the whole command (start-up, mission, files), s.
    wall_s: f64,
    /// Simulated days per wall minute, end to end.
    days_per_wall_min: f64,
    /// Simulated days per wall minute of the mission loop alone (start-up excluded).
    mission_days_per_wall_min: Option<f64>,
    error: Option<String>,
}

/// The glider figures.
#[derive(Clone, Debug, Serialize)]
struct Glider {
    vehicles: usize,
    simulated_days: f64,
    surfacing_period_s: f64,
    surfacing_window_s: f64,
    sim: GliderRate,
    run: GliderRate,
    /// What makes the run's figures suspect, if anything.
    note: Option<String>,
}

/// A goal of the issue and the ratio that checks it.
#[derive(Clone, Debug, Serialize)]
struct Goal {
    goal: String,
    value: Option<f64>,
    target: String,
    met: Option<bool>,
}

/// Everything `vbap bench` measured.
#[derive(Clone, Debug, Serialize)]
struct Report {
    command: String,
    quick: bool,
    machine: Machine,
    plan: Plan,
    /// The floors with idle CPUs (nothing else running).
    hop_iceoryx2: HopFloor,
    hop_udp: HopFloor,
    /// The floors with every CPU kept out of idle by a lowest-priority spinner, as in a
    /// loaded `vbap run` (the reference of the hop goal when measured).
    hop_iceoryx2_warm: Option<HopFloor>,
    hop_udp_warm: Option<HopFloor>,
    /// The floors with both sides busy polling (no event, no sleep): the payload path
    /// alone, which a blocking system never sees (a rule of this system: nothing busy-polls, docs/ARCHITECTURE.md §2).
    hop_iceoryx2_poll: HopFloor,
    hop_udp_poll: HopFloor,
    hop_system: Vec<SystemHop>,
    lockstep: Vec<LockstepRow>,
    realtime: Realtime,
    glider: Glider,
    footprint: Vec<Footprint>,
    goals: Vec<Goal>,
    /// Where the run directories are (kept), if they are.
    work_dir: Option<PathBuf>,
    /// Runs that failed, lost vehicles, rejected states or ran late: their directories are
    /// kept even without `--work-dir`.
    suspect_runs: Vec<PathBuf>,
    total_wall_s: f64,
}

/// Runs the command; returns the exit code.
pub fn main(args: &BenchArgs) -> Result<i32> {
    // iceoryx2's own warnings (no config file: defaults are what the bench wants) would
    // clutter the tables; errors still show.
    iceoryx2::prelude::set_log_level(iceoryx2::prelude::LogLevel::Error);
    exe()?;
    if let Some(role) = args.role {
        return floors::helper(role, args);
    }
    if let Some(out) = &args.out {
        let parent = out.parent().filter(|p| !p.as_os_str().is_empty());
        if parent.is_some_and(|p| !p.is_dir()) || out.is_dir() {
            return Err(InvalidInput(format!(
                "--out {}: not a file in an existing directory",
                out.display()
            ))
            .into());
        }
    }
    let (work, keep) = match &args.work_dir {
        Some(dir) => {
            let empty = !dir.exists()
                || std::fs::read_dir(dir).is_ok_and(|mut entries| entries.next().is_none());
            if !empty {
                return Err(InvalidInput(format!(
                    "--work-dir {}: must be empty or absent",
                    dir.display()
                ))
                .into());
            }
            (dir.clone(), true)
        }
        None => (
            std::env::temp_dir().join(format!("vbap-bench-{}", std::process::id())),
            false,
        ),
    };
    std::fs::create_dir_all(&work)
        .map_err(|e| InvalidInput(format!("--work-dir {}: {e}", work.display())))?;
    let stop = StopFlag::new(Domain::new(&unique_name("s"))?)?;
    let result = bench(args, &work, &stop);
    stop.close();
    match result {
        Ok(mut report) => {
            if keep {
                report.work_dir = Some(work.clone());
            } else {
                prune(&work, &report.suspect_runs);
                if !report.suspect_runs.is_empty() {
                    report.work_dir = Some(work.clone());
                }
            }
            print!("{}", render(&report));
            if let Some(out) = &args.out {
                let text = serde_json::to_string_pretty(&report)? + "\n";
                std::fs::write(out, text).with_context(|| format!("writing {}", out.display()))?;
                eprintln!("vbap bench: results written to {}", out.display());
            }
            Ok(0)
        }
        Err(e) if e.downcast_ref::<Interrupted>().is_some() => {
            eprintln!(
                "vbap bench: interrupted; run directories left in {}",
                work.display()
            );
            Ok(EXIT_INTERRUPTED)
        }
        Err(e) => {
            eprintln!(
                "vbap bench: failed; run directories left in {}",
                work.display()
            );
            Err(e)
        }
    }
}

fn phase(what: &str) {
    eprintln!("vbap bench: {what}");
}

/// The paper's mission (deploy/missions/paper.toml), with N vehicles on a polygon whose
/// edge is that of the paper's optimal square (radius 1.229 for N = 4), so neighbours
/// keep the paper's spacing at every N.
fn paper_mission(n: usize, duration: f64, dt: f64, pace: Pace) -> Result<Mission> {
    const PAPER: &str = include_str!("../../deploy/missions/paper.toml");
    let mut m = Mission::from_toml_str(PAPER, "deploy/missions/paper.toml (embedded)")?;
    let edge = 2.0 * m.formation.radius * (std::f64::consts::PI / 4.0).sin();
    m.mission.name = unique_name("p");
    m.vehicles.count = n;
    m.formation.radius = edge / (2.0 * (std::f64::consts::PI / n as f64).sin());
    m.mission.duration = duration;
    m.mission.dt = dt;
    m.mission.pace = pace;
    m.validate()?;
    Ok(m)
}

/// The glider mission (deploy/missions/glider.toml), `n` gliders, lockstep, surfacing.
fn glider_mission(n: usize, duration: f64, period: f64, window: f64) -> Result<Mission> {
    const GLIDER: &str = include_str!("../../deploy/missions/glider.toml");
    let mut m = Mission::from_toml_str(GLIDER, "deploy/missions/glider.toml (embedded)")?;
    m.mission.name = unique_name("g");
    m.vehicles.count = n;
    m.mission.duration = duration;
    m.mission.pace = Pace::Lockstep;
    m.links.surfacing_period = period;
    m.links.surfacing_window = window;
    m.validate()?;
    Ok(m)
}

fn bench(args: &BenchArgs, work: &Path, stop: &StopFlag) -> Result<Report> {
    let started = Instant::now();
    let plan = Plan::new(args.quick);
    let mut machine = Machine::probe();
    let cpu_start = CpuMark::read();

    // 1. The hop floors.
    phase("raw iceoryx2 ping-pong (VehicleState, pub-sub + event, blocking WaitSet)");
    let hop_iceoryx2 = floors::iceoryx2_ping_pong(
        work,
        plan.pingpong_warmup,
        plan.pingpong_samples,
        false,
        stop,
    )?;
    stop.check()?;
    phase("UDP loopback ping-pong (the same payload bytes, blocking recv)");
    let hop_udp = floors::udp_ping_pong(
        work,
        plan.pingpong_warmup,
        plan.pingpong_samples,
        false,
        stop,
    )?;
    stop.check()?;
    phase("the same two ping-pongs with every CPU kept awake (nice -n 19 spinners)");
    let (hop_iceoryx2_warm, hop_udp_warm) = match floors::Warm::start(work) {
        Some(_warm) => (
            Some(floors::iceoryx2_ping_pong(
                work,
                plan.pingpong_warmup,
                plan.pingpong_samples,
                false,
                stop,
            )?),
            Some(floors::udp_ping_pong(
                work,
                plan.pingpong_warmup,
                plan.pingpong_samples,
                false,
                stop,
            )?),
        ),
        None => (None, None),
    };
    stop.check()?;
    phase("the same two ping-pongs busy polling (nothing sleeps: each side burns a CPU)");
    let hop_iceoryx2_poll = floors::iceoryx2_ping_pong(
        work,
        plan.pingpong_warmup,
        plan.pingpong_samples,
        true,
        stop,
    )?;
    let hop_udp_poll = floors::udp_ping_pong(
        work,
        plan.pingpong_warmup,
        plan.pingpong_samples,
        true,
        stop,
    )?;
    stop.check()?;

    let mut suspect_runs = Vec::new();

    // 2. Lockstep scaling, with the hop of each run.
    let mut lockstep = Vec::new();
    let mut hop_system = Vec::new();
    for &LockstepPlan {
        vehicles: n,
        ticks,
        floor_rounds: rounds,
    } in &plan.lockstep
    {
        phase(&format!("wake-up floor, N = {n} ({rounds} rounds)"));
        let floor = floors::wake_floor(work, n, rounds, stop)?;
        stop.check()?;
        let dt = 0.05;
        let mission = paper_mission(n, ticks as f64 * dt, dt, Pace::Lockstep)?;
        phase(&format!("vbap sim, N = {n}, {ticks} ticks"));
        let sim = system::simulate(&mission, work)?;
        stop.check()?;
        phase(&format!("vbap run, N = {n}, {ticks} ticks, lockstep"));
        let run = system::run(&mission, work, stop, false)?;
        suspect(&run, &mut suspect_runs);
        let per = |rate: f64| 1e6 / (rate * n as f64);
        if let Some(h) = &run.state_hop {
            hop_system.push(SystemHop {
                vehicles: n,
                transport_us: h.transport_us,
                samples: h.delivered,
            });
        }
        lockstep.push(LockstepRow {
            vehicles: n,
            ticks,
            run_ticks_per_s: run.tick_rate,
            in_process_ticks_per_s: sim.tick_rate,
            wake_floor_ticks_per_s: floor,
            run_us_per_tick_vehicle: run.tick_rate.map(per),
            in_process_us_per_tick_vehicle: per(sim.tick_rate),
            floor_us_per_tick_vehicle: per(floor),
            error: run.error.clone(),
            note: run.note.clone(),
        });
    }

    // 3. Real-time capacity at dt = 0.1 s.
    let dt = 0.1;
    let mut realtime = Realtime {
        dt_s: dt,
        duration_s: plan.realtime_duration_s,
        rows: Vec::new(),
        largest_vehicles: None,
    };
    for &n in &plan.realtime {
        phase(&format!(
            "vbap run, N = {n}, pace 1.0, dt = {dt} s, {} s",
            plan.realtime_duration_s
        ));
        let mission = paper_mission(n, plan.realtime_duration_s, dt, Pace::Factor(1.0))?;
        let run = system::run(&mission, work, stop, false)?;
        suspect(&run, &mut suspect_runs);
        let holds = run.error.is_none()
            && run.late_ticks == 0
            && run.vehicles_lost == 0
            && run.ticks == mission.ticks();
        realtime.rows.push(RealtimeRow {
            vehicles: n,
            ticks: run.ticks,
            late_ticks: run.late_ticks,
            rejected: run.rejected,
            rejected_future: run.future_states,
            vehicles_lost: run.vehicles_lost,
            holds,
            startup_s: run.startup_s,
            error: run.error.clone(),
        });
        if !holds {
            break;
        }
        realtime.largest_vehicles = Some(n);
    }

    // 4. Glider-days per wall minute.
    let (period, window) = (7200.0, 600.0);
    let glider_mission = glider_mission(6, plan.glider_duration_s, period, window)?;
    let days = plan.glider_duration_s / 86_400.0;
    phase(&format!("vbap sim, 6 gliders, {days} days"));
    let sim = system::simulate(&glider_mission, work)?;
    stop.check()?;
    phase(&format!("vbap run, 6 gliders, {days} days, lockstep"));
    let run = system::run(&glider_mission, work, stop, false)?;
    suspect(&run, &mut suspect_runs);
    let glider_dt = glider_mission.mission.dt;
    let per_min = |ticks_per_s: f64| ticks_per_s * glider_dt / 86_400.0 * 60.0;
    let glider = Glider {
        vehicles: 6,
        simulated_days: days,
        surfacing_period_s: period,
        surfacing_window_s: window,
        sim: GliderRate {
            wall_s: sim.wall_s,
            days_per_wall_min: days / (sim.wall_s / 60.0),
            mission_days_per_wall_min: Some(per_min(sim.tick_rate)),
            error: None,
        },
        run: GliderRate {
            wall_s: run.wall_s,
            days_per_wall_min: if run.error.is_none() {
                days / (run.wall_s / 60.0)
            } else {
                0.0
            },
            mission_days_per_wall_min: run.tick_rate.map(per_min),
            error: run.error.clone(),
        },
        note: run.note.clone(),
    };

    // 5. Start-up and memory.
    let mut footprint = Vec::new();
    for &n in &plan.footprint {
        phase(&format!(
            "vbap run, N = {n}, pace 1.0: start-up and PSS of every process"
        ));
        let mission = paper_mission(n, plan.footprint_duration_s, dt, Pace::Factor(1.0))?;
        let run: SystemRun = system::run(&mission, work, stop, true)?;
        suspect(&run, &mut suspect_runs);
        footprint.push(run.footprint(n));
    }

    machine.other_load = cpu_start
        .zip(CpuMark::read())
        .and_then(|(a, b)| a.other_share(&b));
    let mut report = Report {
        command: std::env::args().collect::<Vec<_>>().join(" "),
        quick: args.quick,
        machine,
        plan,
        hop_iceoryx2,
        hop_udp,
        hop_iceoryx2_warm,
        hop_udp_warm,
        hop_iceoryx2_poll,
        hop_udp_poll,
        hop_system,
        lockstep,
        realtime,
        glider,
        footprint,
        goals: Vec::new(),
        work_dir: None,
        suspect_runs,
        total_wall_s: 0.0,
    };
    report.goals = goals(&report);
    report.total_wall_s = started.elapsed().as_secs_f64();
    Ok(report)
}

/// Records `run`'s directory when it is worth keeping.
fn suspect(run: &SystemRun, out: &mut Vec<PathBuf>) {
    if run.suspect() {
        out.push(run.dir.clone());
    }
}

/// Removes everything in `work` but the directories in `keep` (and their mission and
/// stderr files); removes `work` itself when nothing is kept.
fn prune(work: &Path, keep: &[PathBuf]) {
    if keep.is_empty() {
        let _ = std::fs::remove_dir_all(work);
        return;
    }
    let names: Vec<String> = keep
        .iter()
        .filter_map(|d| d.file_name().map(|f| f.to_string_lossy().to_string()))
        .collect();
    let Ok(entries) = std::fs::read_dir(work) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().to_string();
        let kept = names.iter().any(|n| {
            name == *n || name == format!("{n}.toml") || name == format!("{n}.stderr.log")
        });
        if kept {
            continue;
        }
        let path = entry.path();
        let _ = if path.is_dir() {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
    }
}

fn goals(r: &Report) -> Vec<Goal> {
    let hop4 = r.hop_system.iter().find(|h| h.vehicles == 4);
    let (floor, udp) = reference_floors(r);
    let ratio_floor = hop4.map(|h| h.transport_us.p50 / floor);
    let faster_udp = hop4.map(|h| udp / h.transport_us.p50);
    let l16 = r.lockstep.iter().find(|l| l.vehicles == 16);
    let tick16 = l16.and_then(|l| l.run_ticks_per_s.map(|run| l.wake_floor_ticks_per_s / run));
    let rt256 = if r.plan.realtime.contains(&256) {
        Some(r.realtime.largest_vehicles.unwrap_or(0) >= 256)
    } else {
        None
    };
    let days = r.glider.run.days_per_wall_min;
    vec![
        Goal {
            goal: "hop p50 / raw iceoryx2 p50 (N = 4; warm floor)".into(),
            value: ratio_floor,
            target: "≤ 1.5".into(),
            met: ratio_floor.map(|v| v <= 1.5),
        },
        Goal {
            goal: "UDP loopback p50 (warm) / hop p50 (N = 4)".into(),
            value: faster_udp,
            target: "≥ 10".into(),
            met: faster_udp.map(|v| v >= 10.0),
        },
        Goal {
            goal: "lockstep tick / wake-up floor tick (N = 16)".into(),
            value: tick16,
            target: "≤ 2".into(),
            met: tick16.map(|v| v <= 2.0),
        },
        Goal {
            goal: "N = 256 at real-time pace (dt = 0.1 s, no late tick)".into(),
            value: r.realtime.largest_vehicles.map(|n| n as f64),
            target: "largest N ≥ 256".into(),
            met: rt256,
        },
        Goal {
            goal: "glider-days per wall minute (vbap run, 6 gliders)".into(),
            value: Some(days),
            target: "≥ 30".into(),
            met: Some(days >= 30.0),
        },
    ]
}

/// The p50s the hop is compared with: the warm floors when measured (a loaded `vbap run`
/// keeps the CPUs awake too), else the idle ones.
fn reference_floors(r: &Report) -> (f64, f64) {
    match (&r.hop_iceoryx2_warm, &r.hop_udp_warm) {
        (Some(i), Some(u)) => (i.one_way_us.p50, u.one_way_us.p50),
        _ => (r.hop_iceoryx2.one_way_us.p50, r.hop_udp.one_way_us.p50),
    }
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("n/a".into(), |v| format!("{v:.prec$}"))
}

/// "   FAILED: why" or "   note: what", or nothing.
fn remark(error: &Option<String>, note: &Option<String>) -> String {
    match (error, note) {
        (Some(e), _) => format!("   FAILED: {e}"),
        (None, Some(n)) => format!("   note: {n}"),
        (None, None) => String::new(),
    }
}

/// The human-readable tables.
fn render(r: &Report) -> String {
    let mut s = String::new();
    let m = &r.machine;
    let _ = writeln!(
        s,
        "vbap bench{} — {} CPUs ({}), Linux {}, {}",
        if r.quick { " --quick" } else { "" },
        m.cpus,
        m.cpu_model,
        m.kernel,
        m.date
    );
    if let Some(other) = m.other_load {
        let _ = writeln!(
            s,
            "other processes used {:.0}% of the CPUs during the bench{}",
            other * 100.0,
            if other > 0.05 {
                " — a busy machine: the figures below are low"
            } else {
                ""
            }
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "1. state → coordinator hop, one-way latency (µs; wall clock, sender stamp to receiver read)"
    );
    let _ = writeln!(
        s,
        "   {:<52} {:>8} {:>8} {:>8}",
        "", "p50", "p99", "samples"
    );
    let (floor, udp) = reference_floors(r);
    let which = if r.hop_iceoryx2_warm.is_some() {
        "warm"
    } else {
        "idle"
    };
    let mut floors = vec![
        (
            "raw iceoryx2 ping-pong (pub-sub + event, WaitSet)",
            &r.hop_iceoryx2,
        ),
        ("UDP loopback ping-pong (blocking recv)", &r.hop_udp),
    ];
    if let (Some(i), Some(u)) = (&r.hop_iceoryx2_warm, &r.hop_udp_warm) {
        floors.push(("raw iceoryx2 ping-pong, CPUs kept awake", i));
        floors.push(("UDP loopback ping-pong, CPUs kept awake", u));
    }
    floors.push(("raw iceoryx2 ping-pong, busy polling", &r.hop_iceoryx2_poll));
    floors.push(("UDP loopback ping-pong, busy polling", &r.hop_udp_poll));
    for (name, h) in floors {
        let _ = writeln!(
            s,
            "   {:<52} {:>8.1} {:>8.1} {:>8}",
            name, h.one_way_us.p50, h.one_way_us.p99, h.samples
        );
    }
    for h in &r.hop_system {
        let _ = writeln!(
            s,
            "   {:<52} {:>8.1} {:>8.1} {:>8}   {:.2}× {which} floor, UDP/hop {:.2}×",
            format!("vbap run, lockstep, N = {}", h.vehicles),
            h.transport_us.p50,
            h.transport_us.p99,
            h.samples,
            h.transport_us.p50 / floor,
            udp / h.transport_us.p50
        );
    }
    let _ = writeln!(
        s,
        "   ({which} UDP / raw iceoryx2 p50: {:.2}× — the most any blocking hop can gain on UDP here)",
        udp / floor
    );
    let _ = writeln!(
        s,
        "   (busy polling, UDP / raw iceoryx2 p50: {:.2}× — what the zero-copy path gains when nothing sleeps)",
        r.hop_udp_poll.one_way_us.p50 / r.hop_iceoryx2_poll.one_way_us.p50
    );
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "2. lockstep ticks per second (paper mission, dt = 0.05 s; start-up excluded)"
    );
    let _ = writeln!(
        s,
        "   {:>4} {:>6} {:>10} {:>11} {:>11} {:>10} {:>10}   {:>28}",
        "N",
        "ticks",
        "vbap run",
        "in-process",
        "wake floor",
        "floor/run",
        "inproc/run",
        "µs per tick·vehicle run/inproc/floor"
    );
    for l in &r.lockstep {
        let run = l.run_ticks_per_s;
        let _ = writeln!(
            s,
            "   {:>4} {:>6} {:>10} {:>11.1} {:>11.1} {:>10} {:>10}   {:>10} {:>8.2} {:>8.2}{}",
            l.vehicles,
            l.ticks,
            opt(run, 1),
            l.in_process_ticks_per_s,
            l.wake_floor_ticks_per_s,
            opt(run.map(|v| l.wake_floor_ticks_per_s / v), 2),
            opt(run.map(|v| l.in_process_ticks_per_s / v), 1),
            opt(l.run_us_per_tick_vehicle, 1),
            l.in_process_us_per_tick_vehicle,
            l.floor_us_per_tick_vehicle,
            remark(&l.error, &l.note)
        );
    }
    let _ = writeln!(s);
    let rt = &r.realtime;
    let _ = writeln!(
        s,
        "3. real-time capacity (pace 1.0, dt = {} s, {} s of mission per N)",
        rt.dt_s, rt.duration_s
    );
    let _ = writeln!(
        s,
        "   {:>4} {:>6} {:>10} {:>17} {:>5} {:>6} {:>11}",
        "N", "ticks", "late ticks", "rejected (future)", "lost", "holds", "start-up s"
    );
    for row in &rt.rows {
        let _ = writeln!(
            s,
            "   {:>4} {:>6} {:>10} {:>17} {:>5} {:>6} {:>11}{}",
            row.vehicles,
            row.ticks,
            row.late_ticks,
            format!("{} ({})", row.rejected, row.rejected_future),
            row.vehicles_lost,
            if row.holds { "yes" } else { "NO" },
            opt(row.startup_s, 2),
            remark(&row.error, &None)
        );
    }
    let _ = writeln!(
        s,
        "   largest N at real-time pace: {}",
        rt.largest_vehicles
            .map_or("none".into(), |n| format!("{n} (of those tried)"))
    );
    let _ = writeln!(s);
    let g = &r.glider;
    let _ = writeln!(
        s,
        "4. simulated glider-days per wall minute ({} gliders, dt = 10 s, {} days, surfacing {} s every {} s)",
        g.vehicles, g.simulated_days, g.surfacing_window_s, g.surfacing_period_s
    );
    let _ = writeln!(
        s,
        "   {:<10} {:>9} {:>16} {:>22}",
        "", "wall s", "days/min (all)", "days/min (mission loop)"
    );
    for (name, rate) in [("vbap sim", &g.sim), ("vbap run", &g.run)] {
        let _ = writeln!(
            s,
            "   {:<10} {:>9.2} {:>16.1} {:>22}{}",
            name,
            rate.wall_s,
            rate.days_per_wall_min,
            opt(rate.mission_days_per_wall_min, 1),
            remark(&rate.error, &None)
        );
    }
    if let Some(note) = &g.note {
        let _ = writeln!(s, "   note: {note}");
    }
    let _ = writeln!(s);
    let _ = writeln!(
        s,
        "5. start-up and memory (pace 1.0; start-up = first process's \"started\" to last \"agent up\")"
    );
    let _ = writeln!(
        s,
        "   {:>4} {:>11} {:>14} {:>12} {:>12} {:>11} {:>11} {:>14}",
        "N",
        "start-up s",
        "incl. launch s",
        "PSS/agent",
        "coordinator",
        "field srv",
        "supervisor",
        "all / vehicle"
    );
    for f in &r.footprint {
        let mib = |v: Option<f64>| opt(v, 2) + " MiB";
        let _ = writeln!(
            s,
            "   {:>4} {:>11} {:>14} {:>12} {:>12} {:>11} {:>11} {:>14}{}",
            f.vehicles,
            opt(f.startup_s, 2),
            opt(f.launch_to_up_s, 2),
            mib(f.pss_agent_mib),
            mib(f.pss_coordinator_mib),
            mib(f.pss_field_server_mib),
            mib(f.pss_supervisor_mib),
            mib(f.pss_total_per_vehicle_mib),
            remark(&f.error, &f.note)
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "Goals (ratios measured in this run, not asserted):");
    for goal in &r.goals {
        let _ = writeln!(
            s,
            "   {:<58} {:>8}  target {:<16} {}",
            goal.goal,
            opt(goal.value, 2),
            goal.target,
            match goal.met {
                Some(true) => "met",
                Some(false) => "MISSED",
                None => "not measured (--quick)",
            }
        );
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "total wall time: {:.1} s", r.total_wall_s);
    match &r.work_dir {
        Some(dir) if r.suspect_runs.is_empty() => {
            let _ = writeln!(s, "run directories: {}", dir.display());
        }
        Some(dir) => {
            let _ = writeln!(
                s,
                "run directories: {} ({} suspect run{} to look at: late ticks, rejected states, lost vehicles or failures)",
                dir.display(),
                r.suspect_runs.len(),
                if r.suspect_runs.len() == 1 { "" } else { "s" }
            );
        }
        None => {}
    }
    s
}
