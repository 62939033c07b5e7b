//! `vbap sim`: the in-process reference simulator.
//!
//! The same mission as `vbap run`, through the same pure steps ([`Agent::step`],
//! [`Planner::step`], [`Sensors::read`]) and the same recorder, in one process with no
//! IPC. In lockstep the multi-process system must reproduce its files byte for byte; it
//! is also the speed baseline of the IPC system.

use std::time::Instant;

use anyhow::{Context, Result};
use coordinator::fleet::Fleet;
use coordinator::planner::{Planner, PlannerParams, Report};
use coordinator::record::Recorder;
use coordinator::tick::{plan_tick, TickOutcome};
use field_server::Sensors;
use shared::config::Mission;
use shared::faults::FaultPlan;
use shared::rundir::{RunDir, Summary};
use std::collections::BTreeMap;
use vehicle_agent::{initial_agent, initial_design, Agent, DownlinkCounts, Guidance, Vehicle};

/// Set (by the command line's SIGINT/SIGTERM handler) to stop a simulation early: it
/// ends after the tick in progress and writes its files and summary (verdict
/// "interrupted").
pub static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Progress callback: (tick, ticks, mission time s, distance to optimum if known).
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64, f64, Option<f64>);

/// Runs `mission` in process, writing the run directory `dir`. Returns the summary.
pub fn simulate(mission: &Mission, dir: &RunDir, progress: Progress<'_>) -> Result<Summary> {
    let wall = Instant::now();
    let dt = mission.mission.dt;
    let ticks = mission.ticks();
    let dim = mission.mission.dim;
    let design = initial_design(mission).context("initial formation design")?;
    let initial = Guidance::initial(mission, &design);
    let plan = FaultPlan::new(mission);
    let ids: Vec<u32> = (0..mission.vehicles.count as u32).collect();
    let mut vehicles: BTreeMap<u32, Vehicle> = ids
        .iter()
        .map(|&id| {
            (
                id,
                Vehicle::new(initial_agent(mission, &design, id), initial.clone(), 0),
            )
        })
        .collect();
    let mut sensors = Sensors::new(mission);
    let field = mission.field();
    let mut fleet = Fleet::new(mission, &ids);
    let mut planner = Planner::new(
        PlannerParams::from_mission(mission),
        mission.start_vec(),
        &ids,
    )?;
    let mut recorder = Recorder::open(mission, dir).context("opening the run directory files")?;
    let every = (ticks / 200).max(1);
    let mut downlink = DownlinkCounts::default();
    for k in 0..ticks {
        if STOP.load(std::sync::atomic::Ordering::Relaxed) {
            break;
        }
        let t = k as f64 * dt;
        recorder.faults_starting(k)?;
        for v in plan.kills_at(k).collect::<Vec<_>>() {
            if fleet.lose(v) {
                if let Some(gone) = vehicles.remove(&v) {
                    downlink.delivered += gone.counts.delivered;
                    downlink.dropped += gone.counts.dropped;
                }
                recorder.lost(k, v, "scheduled kill")?;
            }
        }
        for v in plan.restarts_at(k).collect::<Vec<_>>() {
            if let Some(restore) = fleet.admit(v) {
                let agent = Agent {
                    id: v,
                    dim,
                    position: restore.position,
                    velocity: restore.velocity,
                };
                vehicles.insert(v, Vehicle::new(agent, initial.clone(), k));
                recorder.rejoined(k, v)?;
            }
        }
        let admitted: Vec<u32> = fleet.admitted().iter().map(|r| r.id).collect();
        let truth: Vec<Report> = vehicles
            .iter_mut()
            .filter(|(id, _)| !admitted.contains(id))
            .map(|(&id, veh)| {
                let measurement = sensors
                    .read(id, k, t, &veh.agent.position)
                    .unwrap_or(f64::NAN);
                Report {
                    id,
                    tick: k,
                    position: veh.agent.position,
                    velocity: veh.agent.velocity,
                    measurement,
                }
            })
            .collect();
        let TickOutcome {
            command, snapshot, ..
        } = plan_tick(k, dt, &truth, &mut fleet, &mut planner, &mut recorder)?;
        for (&id, veh) in vehicles.iter_mut() {
            let guidance = Guidance::of_command(
                k,
                command.leaders.clone(),
                command.inter,
                command.leader,
                command.damping,
                command.velocity,
                mission.body.v0,
            )
            .with_neighbours(id, &snapshot);
            veh.on_command(fleet.model(), guidance, k, dt);
        }
        fleet.end_tick();
        if k.is_multiple_of(every) || k + 1 == ticks {
            let distance = field
                .optimum(t, mission.mission.goal)
                .map(|o| (command.body.r - o).norm());
            progress(k + 1, ticks, t, distance);
        }
    }
    for veh in vehicles.values() {
        downlink.delivered += veh.counts.delivered;
        downlink.dropped += veh.counts.dropped;
    }
    recorder.flush()?;
    let mut summary = recorder.summary(&planner, "in-process");
    // Reports still held by the uplink when the mission ends were let through by the link
    // model (as the commands' fates count them), their delivery time lies after the end.
    let in_flight = fleet.held_reports().0.len() as u64;
    summary.messages.sent = fleet.counts.delivered
        + in_flight
        + fleet.counts.dropped_injected
        + downlink.delivered
        + downlink.dropped;
    summary.messages.delivered = fleet.counts.delivered + in_flight + downlink.delivered;
    summary.messages.dropped_injected = fleet.counts.dropped_injected + downlink.dropped;
    summary.wall_time_s = wall.elapsed().as_secs_f64();
    summary.write(dir).context("writing summary.json")?;
    crate::report::draw_run(dir).context("drawing the run's pictures")?;
    Ok(summary)
}
