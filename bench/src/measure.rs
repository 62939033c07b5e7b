//! The measurements of `vbap bench`, in order: the hop floors, lockstep scaling, the
//! real-time capacity, glider-days per wall minute, start-up and memory.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;
use vbap_mission::config::Pace;

use super::args::BenchArgs;
use super::floors::{self, HopFloor};
use super::missions::{glider_mission, paper_mission};
use super::overhead::{self, Overhead};
use super::plan::{LockstepPlan, Plan};
use super::report::{
    goals, CpuMark, Glider, GliderRate, LockstepRow, Machine, Realtime, RealtimeRow, Report,
    SystemHop,
};
use super::stop::StopFlag;
use super::system::{self, Footprint, SystemRun};

/// Time step of the real-time and footprint runs, s.
const REALTIME_DT: f64 = 0.1;

fn phase(what: &str) {
    eprintln!("vbap bench: {what}");
}

/// Every measurement of the bench, in order; the report with its goals.
pub(super) fn bench(args: &BenchArgs, work: &Path, stop: &StopFlag) -> Result<Report> {
    let started = Instant::now();
    let plan = Plan::new(args.quick);
    let plan = if args.large { plan.with_large() } else { plan };
    let mut machine = Machine::probe();
    let cpu_start = CpuMark::read();
    let hops = hop_floors(&plan, work, stop)?;
    let mut suspect_runs = Vec::new();
    let mut overhead = Overhead::default();
    let (lockstep, hop_system) =
        lockstep_scaling(&plan, work, stop, &mut suspect_runs, &mut overhead)?;
    overhead.hop_repeats = overhead::hop_repeats(&plan, work, stop, &mut suspect_runs)?;
    overhead.fanout = Some(overhead::fanout(args.quick, work, stop)?);
    let realtime = realtime_capacity(&plan, work, stop, &mut suspect_runs)?;
    let glider = glider_rates(&plan, work, stop, &mut suspect_runs)?;
    let footprint = footprints(&plan, work, stop, &mut suspect_runs)?;
    machine.other_load = cpu_start
        .zip(CpuMark::read())
        .and_then(|(a, b)| a.other_share(&b));
    let mut report = Report {
        command: std::env::args().collect::<Vec<_>>().join(" "),
        quick: args.quick,
        machine,
        plan,
        hop_iceoryx2: hops.iceoryx2,
        hop_udp: hops.udp,
        hop_iceoryx2_warm: hops.iceoryx2_warm,
        hop_udp_warm: hops.udp_warm,
        hop_iceoryx2_poll: hops.iceoryx2_poll,
        hop_udp_poll: hops.udp_poll,
        hop_system,
        lockstep,
        realtime,
        glider,
        footprint,
        overhead,
        goals: Vec::new(),
        work_dir: None,
        suspect_runs,
        total_wall_s: 0.0,
    };
    report.goals = goals(&report);
    report.total_wall_s = started.elapsed().as_secs_f64();
    Ok(report)
}

/// The hop floors: idle, CPUs kept awake, busy polling.
struct HopFloors {
    iceoryx2: HopFloor,
    udp: HopFloor,
    iceoryx2_warm: Option<HopFloor>,
    udp_warm: Option<HopFloor>,
    iceoryx2_poll: HopFloor,
    udp_poll: HopFloor,
}

/// 1. The hop floors.
fn hop_floors(plan: &Plan, work: &Path, stop: &StopFlag) -> Result<HopFloors> {
    let (warmup, samples) = (plan.pingpong_warmup, plan.pingpong_samples);
    phase("raw iceoryx2 ping-pong (VehicleState, pub-sub + event, blocking WaitSet)");
    let iceoryx2 = floors::iceoryx2_ping_pong(work, warmup, samples, false, stop)?;
    stop.check()?;
    phase("UDP loopback ping-pong (the same payload bytes, blocking recv)");
    let udp = floors::udp_ping_pong(work, warmup, samples, false, stop)?;
    stop.check()?;
    phase("the same two ping-pongs with every CPU kept awake (nice -n 19 spinners)");
    let (iceoryx2_warm, udp_warm) = match floors::Warm::start(work) {
        Some(_warm) => (
            Some(floors::iceoryx2_ping_pong(
                work, warmup, samples, false, stop,
            )?),
            Some(floors::udp_ping_pong(work, warmup, samples, false, stop)?),
        ),
        None => (None, None),
    };
    stop.check()?;
    phase("the same two ping-pongs busy polling (nothing sleeps: each side burns a CPU)");
    let iceoryx2_poll = floors::iceoryx2_ping_pong(work, warmup, samples, true, stop)?;
    let udp_poll = floors::udp_ping_pong(work, warmup, samples, true, stop)?;
    stop.check()?;
    Ok(HopFloors {
        iceoryx2,
        udp,
        iceoryx2_warm,
        udp_warm,
        iceoryx2_poll,
        udp_poll,
    })
}

/// 2. Lockstep scaling, with the hop of each run.
fn lockstep_scaling(
    plan: &Plan,
    work: &Path,
    stop: &StopFlag,
    suspect_runs: &mut Vec<PathBuf>,
    overhead: &mut Overhead,
) -> Result<(Vec<LockstepRow>, Vec<SystemHop>)> {
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
        phase(&format!("skeleton floor, N = {n} ({rounds} ticks)"));
        let skeleton = super::skeleton::skeleton_floor(work, n, rounds, stop)?;
        stop.check()?;
        phase(&format!("vbap run, N = {n}, {ticks} ticks, lockstep"));
        let run = system::run(&mission, work, stop, false)?;
        suspect(&run, suspect_runs);
        let cpus = std::thread::available_parallelism().map_or(1, |c| c.get());
        overhead.skeleton_row(
            n,
            skeleton,
            run.tick_rate,
            sim.tick_rate,
            Some(&sim.parts),
            cpus,
        );
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
            command_mean_b: sim.link_bytes.as_ref().map(|b| b.command_mean_b),
            command_max_b: sim.link_bytes.as_ref().map(|b| b.command_max_b),
            shared_snapshot_b: shared_snapshot_bytes(n),
        });
    }
    Ok((lockstep, hop_system))
}

/// The bytes of the shared command's fixed part and `n` snapshot entries: what every vehicle
/// read of each command before the neighbour lists.
fn shared_snapshot_bytes(n: usize) -> u64 {
    use vbap_ipc::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
    (std::mem::offset_of!(BodyCommand, leaders) + n * std::mem::size_of::<SnapshotEntry>()) as u64
}

/// 3. Real-time capacity at dt = 0.1 s: N up to the first that does not hold pace.
fn realtime_capacity(
    plan: &Plan,
    work: &Path,
    stop: &StopFlag,
    suspect_runs: &mut Vec<PathBuf>,
) -> Result<Realtime> {
    let dt = REALTIME_DT;
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
        suspect(&run, suspect_runs);
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
    Ok(realtime)
}

/// 4. Glider-days per wall minute, `vbap sim` and `vbap run`.
fn glider_rates(
    plan: &Plan,
    work: &Path,
    stop: &StopFlag,
    suspect_runs: &mut Vec<PathBuf>,
) -> Result<Glider> {
    let (period, window) = (7200.0, 600.0);
    let glider_mission = glider_mission(6, plan.glider_duration_s, period, window)?;
    let days = plan.glider_duration_s / 86_400.0;
    phase(&format!("vbap sim, 6 gliders, {days} days"));
    let sim = system::simulate(&glider_mission, work)?;
    stop.check()?;
    phase(&format!("vbap run, 6 gliders, {days} days, lockstep"));
    let run = system::run(&glider_mission, work, stop, false)?;
    suspect(&run, suspect_runs);
    let glider_dt = glider_mission.mission.dt;
    let per_min = |ticks_per_s: f64| ticks_per_s * glider_dt / 86_400.0 * 60.0;
    Ok(Glider {
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
    })
}

/// 5. Start-up and memory of each N of the plan.
fn footprints(
    plan: &Plan,
    work: &Path,
    stop: &StopFlag,
    suspect_runs: &mut Vec<PathBuf>,
) -> Result<Vec<Footprint>> {
    let mut footprint = Vec::new();
    for &n in &plan.footprint {
        phase(&format!(
            "vbap run, N = {n}, pace 1.0: start-up and PSS of every process"
        ));
        let mission = paper_mission(n, plan.footprint_duration_s, REALTIME_DT, Pace::Factor(1.0))?;
        let run: SystemRun = system::run(&mission, work, stop, true)?;
        suspect(&run, suspect_runs);
        footprint.push(run.footprint(n));
    }
    Ok(footprint)
}

/// Records `run`'s directory when it is worth keeping.
fn suspect(run: &SystemRun, out: &mut Vec<PathBuf>) {
    if run.suspect() {
        out.push(run.dir.clone());
    }
}
