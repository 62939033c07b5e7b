//! What `vbap bench` records: the plan of a run, the machine, every table's rows, the
//! goals and their ratios (`--out` JSON).

use std::path::PathBuf;

use serde::Serialize;
use vbap_mission::rundir::Percentiles;

use super::floors::HopFloor;
use super::overhead::Overhead;
use super::plan::{Goal, Plan};
use super::system::Footprint;

/// The machine the figures come from.
#[derive(Clone, Debug, Default, Serialize)]
pub(super) struct Machine {
    pub(super) cpus: usize,
    pub(super) cpu_model: String,
    pub(super) kernel: String,
    /// UTC date and time of the run.
    pub(super) date: String,
    /// Share of all CPU time during the bench used by processes other than the bench and
    /// its children (a build, another test): figures taken with a busy machine are low.
    pub(super) other_load: Option<f64>,
}

/// CPU time counters (clock ticks): the machine's (/proc/stat) and the bench's own with
/// its reaped children (/proc/self/stat).
#[derive(Clone, Copy, Debug)]
pub(super) struct CpuMark {
    pub(super) busy: u64,
    pub(super) total: u64,
    pub(super) ours: u64,
}

impl CpuMark {
    pub(super) fn read() -> Option<Self> {
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
    pub(super) fn other_share(&self, later: &Self) -> Option<f64> {
        let total = later.total.checked_sub(self.total)?;
        let busy = later.busy.checked_sub(self.busy)?;
        let ours = later.ours.checked_sub(self.ours)?;
        (total > 0).then(|| busy.saturating_sub(ours) as f64 / total as f64)
    }
}

impl Machine {
    pub(super) fn probe() -> Self {
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
pub(super) struct SystemHop {
    pub(super) vehicles: usize,
    pub(super) transport_us: Percentiles,
    pub(super) samples: u64,
}

/// One row of the lockstep scaling table.
#[derive(Clone, Debug, Serialize)]
pub(super) struct LockstepRow {
    pub(super) vehicles: usize,
    pub(super) ticks: u64,
    /// `vbap run`, ticks/s of the mission itself (start-up excluded).
    pub(super) run_ticks_per_s: Option<f64>,
    /// `vbap sim` on the same mission, ticks/s.
    pub(super) in_process_ticks_per_s: f64,
    /// One blocking iceoryx2 event round through N + 1 processes, rounds/s.
    pub(super) wake_floor_ticks_per_s: f64,
    /// Wall time per tick and vehicle, µs: run, in-process, floor.
    pub(super) run_us_per_tick_vehicle: Option<f64>,
    pub(super) in_process_us_per_tick_vehicle: f64,
    pub(super) floor_us_per_tick_vehicle: f64,
    /// Why the run failed (no figures), if it did.
    pub(super) error: Option<String>,
    /// What makes the figures suspect (rejected states, lost vehicles), if anything.
    pub(super) note: Option<String>,
    /// Mean and largest command one vehicle is told, in the compact link encoding, bytes
    /// (`summary.json` `link_bytes`).
    pub(super) command_mean_b: Option<f64>,
    pub(super) command_max_b: Option<u64>,
    /// The shared command's swarm snapshot in use, bytes: what every vehicle read before
    /// the neighbour lists (the fixed part and N snapshot entries).
    pub(super) shared_snapshot_b: u64,
}

/// One row of the real-time sweep.
#[derive(Clone, Debug, Serialize)]
pub(super) struct RealtimeRow {
    pub(super) vehicles: usize,
    pub(super) ticks: u64,
    pub(super) late_ticks: u64,
    /// States the coordinator rejected, and how many of them were from the future (an
    /// agent stepped on its own: it held station while the coordinator was silent).
    pub(super) rejected: u64,
    pub(super) rejected_future: u64,
    pub(super) vehicles_lost: usize,
    /// Every tick run, none late, no vehicle lost.
    pub(super) holds: bool,
    pub(super) startup_s: Option<f64>,
    pub(super) error: Option<String>,
}

/// The real-time capacity.
#[derive(Clone, Debug, Serialize)]
pub(super) struct Realtime {
    pub(super) dt_s: f64,
    pub(super) duration_s: f64,
    pub(super) rows: Vec<RealtimeRow>,
    /// Largest N of the sweep such that it and every smaller N held pace.
    pub(super) largest_vehicles: Option<usize>,
}

/// Glider-days per wall minute of one mode.
#[derive(Clone, Debug, Serialize)]
pub(super) struct GliderRate {
    /// Wall time of the whole command (start-up, mission, files), s.
    pub(super) wall_s: f64,
    /// Simulated days per wall minute, end to end.
    pub(super) days_per_wall_min: f64,
    /// Simulated days per wall minute of the mission loop alone (start-up excluded).
    pub(super) mission_days_per_wall_min: Option<f64>,
    pub(super) error: Option<String>,
}

/// The glider figures.
#[derive(Clone, Debug, Serialize)]
pub(super) struct Glider {
    pub(super) vehicles: usize,
    pub(super) simulated_days: f64,
    pub(super) surfacing_period_s: f64,
    pub(super) surfacing_window_s: f64,
    pub(super) sim: GliderRate,
    pub(super) run: GliderRate,
    /// What makes the run's figures suspect, if anything.
    pub(super) note: Option<String>,
}

/// Everything `vbap bench` measured.
#[derive(Clone, Debug, Serialize)]
pub(super) struct Report {
    pub(super) command: String,
    pub(super) quick: bool,
    pub(super) machine: Machine,
    pub(super) plan: Plan,
    /// The floors with idle CPUs (nothing else running).
    pub(super) hop_iceoryx2: HopFloor,
    pub(super) hop_udp: HopFloor,
    /// The floors with every CPU kept out of idle by a lowest-priority spinner, as in a
    /// loaded `vbap run` (the reference of the hop goal when measured).
    pub(super) hop_iceoryx2_warm: Option<HopFloor>,
    pub(super) hop_udp_warm: Option<HopFloor>,
    /// The floors with both sides busy polling (no event, no sleep): the payload path
    /// alone, which a blocking system never sees (a rule of this system: nothing busy-polls, docs/ARCHITECTURE.md §3).
    pub(super) hop_iceoryx2_poll: HopFloor,
    pub(super) hop_udp_poll: HopFloor,
    pub(super) hop_system: Vec<SystemHop>,
    pub(super) lockstep: Vec<LockstepRow>,
    pub(super) realtime: Realtime,
    pub(super) glider: Glider,
    pub(super) footprint: Vec<Footprint>,
    /// Issue 17: the skeleton floor, the hop as a median of repetitions, the fan-out.
    pub(super) overhead: Overhead,
    pub(super) goals: Vec<Goal>,
    /// Where the run directories are (kept), if they are.
    pub(super) work_dir: Option<PathBuf>,
    /// Runs that failed, lost vehicles, rejected states or ran late: their directories are
    /// kept even without `--work-dir`.
    pub(super) suspect_runs: Vec<PathBuf>,
    pub(super) total_wall_s: f64,
}

/// The goals of issue 17 (performance, restated), each as the ratio or figure measured in
/// this run. The first-round goals it replaced (UDP / hop ≥ 10, tick / wake-up floor ≤ 2,
/// glider-days per minute ≥ 30) are gone: their figures stay in the tables above.
pub(super) fn goals(r: &Report) -> Vec<Goal> {
    let mut out = Vec::new();
    let mut goal = |g: String, value: Option<f64>, target: &str, met: Option<bool>| {
        out.push(Goal::new(g, value, target, met))
    };
    // 1 and 6 (skeleton, hop median) and 3 (fan-out) come from the overhead sections.
    // 2: cost per tick·vehicle that grows linearly.
    let per_vehicle = |n: usize| {
        r.lockstep
            .iter()
            .find(|l| l.vehicles == n)
            .and_then(|l| l.run_us_per_tick_vehicle)
    };
    // N = 256 is always listed (not measured under --quick), N = 1024 under --large.
    let listed = |n: usize| n == 256 || r.lockstep.iter().any(|l| l.vehicles == n);
    for n in [256, 1024] {
        if !listed(n) {
            continue;
        }
        let v = per_vehicle(n).zip(per_vehicle(16)).map(|(a, b)| a / b);
        goal(
            format!("µs per tick·vehicle, N = {n} / N = 16 (lockstep)"),
            v,
            "≤ 1.2",
            v.map(|v| v <= 1.2),
        );
    }
    // Issue 31: what a vehicle is told does not grow with N.
    let bytes = |n: usize| {
        r.lockstep
            .iter()
            .find(|l| l.vehicles == n)
            .and_then(|l| l.command_mean_b)
    };
    for n in [256, 1024] {
        if listed(n) {
            let v = bytes(n).zip(bytes(16)).map(|(a, b)| a / b);
            goal(
                format!("command bytes per vehicle, N = {n} / N = 16"),
                v,
                "≤ 2",
                v.map(|v| v <= 2.0),
            );
        }
    }
    // 4: scale.
    let largest = r.realtime.largest_vehicles.unwrap_or(0);
    for n in [256, 1024] {
        if listed(n) {
            let measured = r.plan.realtime.contains(&n);
            goal(
                format!("N = {n} at real time (dt = 0.1 s, none late or lost)"),
                r.realtime
                    .largest_vehicles
                    .map(|n| n as f64)
                    .filter(|_| measured),
                &format!("largest N ≥ {n}"),
                measured.then_some(largest >= n),
            );
        }
    }
    let footprint = |n: usize| r.footprint.iter().find(|f| f.vehicles == n);
    for (n, limit) in [(256, 5.0), (1024, 20.0)] {
        if listed(n) {
            let s = footprint(n).and_then(|f| f.startup_s);
            goal(
                format!("start-up s, N = {n}"),
                s,
                &format!("≤ {limit}"),
                s.map(|s| s <= limit),
            );
        }
    }
    let coordinator = footprint(256).and_then(|f| f.pss_coordinator_mib);
    goal(
        "coordinator PSS MiB, N = 256".into(),
        coordinator,
        "≤ 40",
        coordinator.map(|m| m <= 40.0),
    );
    let set_per_vehicle = footprint(256).and_then(|f| f.pss_total_per_vehicle_mib);
    goal(
        "PSS of the whole set per vehicle MiB, N = 256".into(),
        set_per_vehicle,
        "≤ 2",
        set_per_vehicle.map(|m| m <= 2.0),
    );
    // 5: long missions.
    let glider = (r.glider.run.days_per_wall_min > 0.0 && r.glider.sim.days_per_wall_min > 0.0)
        .then(|| r.glider.run.days_per_wall_min / r.glider.sim.days_per_wall_min);
    goal(
        "glider mission, vbap run / vbap sim days per minute".into(),
        glider,
        "≥ 0.7",
        glider.map(|v| v >= 0.7),
    );
    out.extend(super::overhead::goals(&r.overhead));
    out
}

/// The p50s the hop is compared with: the warm floors when measured (a loaded `vbap run`
/// keeps the CPUs awake too), else the idle ones.
pub(super) fn reference_floors(r: &Report) -> (f64, f64) {
    match (&r.hop_iceoryx2_warm, &r.hop_udp_warm) {
        (Some(i), Some(u)) => (i.one_way_us.p50, u.one_way_us.p50),
        _ => (r.hop_iceoryx2.one_way_us.p50, r.hop_udp.one_way_us.p50),
    }
}
