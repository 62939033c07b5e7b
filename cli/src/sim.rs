//! `vbap sim`: the in-process reference simulator.
//!
//! The same mission as `vbap run`, through the same pure steps ([`Agent::step`],
//! [`Planner::step`], [`Sensors::read`]) and the same recorder, in one process with no
//! IPC. In lockstep the multi-process system must reproduce its files byte for byte; it
//! is also the speed baseline of the IPC system.

use std::time::Instant;

use crate::plugins::Plugins;
use anyhow::{Context, Result};
use coordinator::fleet::Fleet;
use coordinator::membership::{self, Loss};
use coordinator::plan::Plan;
use coordinator::planner::{Planner, PlannerParams, Report, Told};
use coordinator::record::Recorder;
use coordinator::tally::LinkTally;
use coordinator::tick::{plan_tick, TickOutcome};
use field_server::{Sensors, World};
use std::collections::BTreeMap;
use vbap_mission::config::Mission;
use vbap_mission::faults::FaultPlan;
use vbap_mission::rundir::{RunDir, Summary};
use vehicle_agent::motion::Kinematics;
use vehicle_agent::{initial_agent, initial_design, Agent, Guidance, Vehicle};

/// Set (by the command line's SIGINT/SIGTERM handler) to stop a simulation early: it
/// ends after the tick in progress and writes its files and summary (verdict
/// "interrupted").
pub static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Progress callback: (tick, ticks, mission time s, distance to optimum if known).
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64, f64, Option<f64>);

/// Runs `mission` in process with the paper's planner, writing the run directory `dir`.
/// Returns the summary.
pub fn simulate(mission: &Mission, dir: &RunDir, progress: Progress<'_>) -> Result<Summary> {
    simulate_plugins(mission, dir, &Plugins::default(), progress)
}

/// [`simulate`] with a user's own field and control law (`plugins`) and the paper's planner.
pub fn simulate_plugins(
    mission: &Mission,
    dir: &RunDir,
    plugins: &Plugins,
    progress: Progress<'_>,
) -> Result<Summary> {
    let ids: Vec<u32> = (0..mission.vehicles.count as u32).collect();
    let planner = Planner::new(
        PlannerParams::from_mission(mission),
        mission.start_vec(),
        &ids,
    )?;
    simulate_with(mission, dir, planner, plugins, progress)
}

/// [`simulate`] with any planner (`planner`: for every vehicle of the mission) and a user's
/// own parts (`plugins`): the field sampled and judged by, the vehicles' control law.
pub fn simulate_with(
    mission: &Mission,
    dir: &RunDir,
    mut planner: impl Plan,
    plugins: &Plugins,
    progress: Progress<'_>,
) -> Result<Summary> {
    let wall = Instant::now();
    let field = plugins.field_of(mission);
    let law = plugins.law_of(mission);
    let dt = mission.mission.dt;
    let ticks = mission.ticks();
    let dim = mission.mission.dim;
    let design = initial_design(mission).context("initial formation design")?;
    let initial = Guidance::initial(mission, &design);
    let plan = FaultPlan::new(mission);
    let ids: Vec<u32> = (0..mission.vehicles.count as u32).collect();
    let kin = Kinematics::of(mission);
    let mut vehicles: BTreeMap<u32, Vehicle> = ids
        .iter()
        .map(|&id| {
            (
                id,
                Vehicle::new(initial_agent(mission, &design, id), initial.clone(), 0)
                    .with_law(law.clone())
                    .with_motion(kin.clone(), dt),
            )
        })
        .collect();
    let mut sensors = Sensors::in_world(mission, World::with_field(mission, field.clone()));
    let mut fleet = Fleet::new(mission, &ids);
    let mut recorder = Recorder::open_with(mission, dir, field.clone())
        .context("opening the run directory files")?;
    let every = (ticks / 200).max(1);
    let mut tally = LinkTally::default();
    for k in 0..ticks {
        if STOP.load(std::sync::atomic::Ordering::Relaxed) {
            break;
        }
        let t = k as f64 * dt;
        recorder.faults_starting(k)?;
        for v in plan.kills_at(k).collect::<Vec<_>>() {
            if let Some(event) = membership::lose(&mut fleet, k, dt, v, &Loss::scheduled_kill()) {
                if let Some(gone) = vehicles.remove(&v) {
                    tally.add_downlink(gone.counts.delivered, gone.counts.dropped);
                }
                recorder.event(event)?;
            }
        }
        for v in plan.restarts_at(k).collect::<Vec<_>>() {
            if let Some((restore, event)) = membership::rejoin(&mut fleet, k, dt, v) {
                let agent = Agent {
                    id: v,
                    dim,
                    position: restore.position,
                    velocity: restore.velocity,
                };
                vehicles.insert(
                    v,
                    Vehicle::new(agent, initial.clone(), k)
                        .with_law(law.clone())
                        .with_motion(kin.clone(), dt),
                );
                recorder.event(event)?;
            }
        }
        let (truth, told) = read_sensors(&vehicles, &fleet, &mut sensors, k, t);
        let TickOutcome {
            command, snapshot, ..
        } = plan_tick(
            k,
            dt,
            &truth,
            &told,
            &mut fleet,
            &mut planner,
            &mut recorder,
        )?;
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
            .with_neighbours(id, &snapshot)
            .with_plan(command.schedule.clone(), command.body.r, command.body.scale);
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
        tally.add_downlink(veh.counts.delivered, veh.counts.dropped);
    }
    recorder.flush()?;
    let mut summary = recorder.summary(&planner, "in-process");
    summary.messages = tally.counts(&fleet);
    summary.wall_time_s = wall.elapsed().as_secs_f64();
    summary.write(dir).context("writing summary.json")?;
    vbap_report::draw_run_with(dir, None, plugins.field.as_deref())
        .context("drawing the run's pictures")?;
    Ok(summary)
}

/// The true state and sensor reading (taken at the true position) at tick `k` (time `t`,
/// s) of every vehicle not waiting for admission, and what each says of itself (its
/// belief).
fn read_sensors(
    vehicles: &BTreeMap<u32, Vehicle>,
    fleet: &Fleet,
    sensors: &mut Sensors,
    k: u64,
    t: f64,
) -> (Vec<Report>, Vec<Told>) {
    let admitted: Vec<u32> = fleet.admitted().iter().map(|r| r.id).collect();
    vehicles
        .iter()
        .filter(|(id, _)| !admitted.contains(id))
        .map(|(&id, veh)| {
            let measurement = sensors
                .read(id, k, t, &veh.agent.position)
                .unwrap_or(f64::NAN);
            let said = veh.reported();
            (
                Report {
                    id,
                    tick: k,
                    position: veh.agent.position,
                    velocity: veh.agent.velocity,
                    measurement,
                },
                Told {
                    id,
                    position: said.position,
                    water: said.water,
                    current: said.current,
                },
            )
        })
        .unzip()
}
