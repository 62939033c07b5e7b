//! `vbap-sim`: the in-process reference simulator (`vbap sim`).
//!
//! The same mission as `vbap run`, through the same pure steps ([`Agent::step`],
//! [`Planner::step`], [`Sensors::read`]) and the same recorder, in one process with no
//! IPC. In lockstep the multi-process system must reproduce its files byte for byte; it
//! is also the speed baseline of the IPC system.

use std::time::Instant;

pub mod front;
pub mod plugins;

pub use front::{create_run_dir, mission_warnings, RunDirRefused};
pub use plugins::Plugins;

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
use vbap_mission::acoustic::AcousticModel;
use vbap_mission::config::Mission;
use vbap_mission::faults::FaultPlan;
use vbap_mission::rundir::{RunDir, Summary};
use vbap_wire::msg::coordinator_to_agent::own_index;
use vehicle_agent::motion::Kinematics;
use vehicle_agent::{initial_agent, initial_design, Agent, Guidance, Telling, Vehicle};

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

/// Wall time of the simulator's tick by the process that does each part in `vbap run`
/// (summed over the ticks run): what a lockstep tick of the process set cannot do without,
/// part by part ([`simulate_timed`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TickParts {
    /// Ticks run.
    pub ticks: u64,
    /// The field server's part: the true states' sensor readings, s.
    pub field_s: f64,
    /// The coordinator's part: link model, planner, rows of the run directory
    /// ([`plan_tick`]), membership, s.
    pub coordinator_s: f64,
    /// Every agent's part: guidance from the command, control law, motion, s (summed over
    /// the agents).
    pub agents_s: f64,
}

impl TickParts {
    /// The part of one tick that is serial in lockstep (field server, then coordinator:
    /// nothing else runs meanwhile) plus the agents' part spread over `cpus` CPUs (at most
    /// one per agent), s per tick; 0 without ticks.
    pub fn critical_path_s(&self, cpus: usize, agents: usize) -> f64 {
        if self.ticks == 0 {
            return 0.0;
        }
        let lanes = cpus.min(agents).max(1) as f64;
        (self.field_s + self.coordinator_s + self.agents_s / lanes) / self.ticks as f64
    }
}

/// [`simulate`], its tick timed part by part ([`TickParts`]; the files it writes are the
/// same).
pub fn simulate_timed(
    mission: &Mission,
    dir: &RunDir,
    progress: Progress<'_>,
) -> Result<(Summary, TickParts)> {
    let mut parts = TickParts::default();
    let summary = simulate_parts(
        mission,
        dir,
        paper_planner(mission)?,
        &Plugins::default(),
        progress,
        &mut parts,
    )?;
    Ok((summary, parts))
}

/// [`simulate`] with a user's own field and control law (`plugins`) and the paper's planner.
pub fn simulate_plugins(
    mission: &Mission,
    dir: &RunDir,
    plugins: &Plugins,
    progress: Progress<'_>,
) -> Result<Summary> {
    simulate_with(mission, dir, paper_planner(mission)?, plugins, progress)
}

/// The paper's planner for every vehicle of `mission`.
fn paper_planner(mission: &Mission) -> Result<Planner> {
    let ids: Vec<u32> = (0..mission.vehicles.count as u32).collect();
    Ok(Planner::new(
        PlannerParams::from_mission(mission),
        mission.start_vec(),
        &ids,
    )?)
}

/// [`simulate`] with any planner (`planner`: for every vehicle of the mission) and a user's
/// own parts (`plugins`): the field sampled and judged by, the vehicles' control law.
pub fn simulate_with(
    mission: &Mission,
    dir: &RunDir,
    planner: impl Plan,
    plugins: &Plugins,
    progress: Progress<'_>,
) -> Result<Summary> {
    simulate_parts(
        mission,
        dir,
        planner,
        plugins,
        progress,
        &mut TickParts::default(),
    )
}

/// [`simulate_with`], the time of each part of the tick added to `parts`.
fn simulate_parts(
    mission: &Mission,
    dir: &RunDir,
    mut planner: impl Plan,
    plugins: &Plugins,
    progress: Progress<'_>,
    parts: &mut TickParts,
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
    let channel = AcousticModel::new(mission);
    // A vehicle's process from its first state at tick k (at the start, or restarted).
    let spawn = |agent: Agent, k: u64| {
        let guidance = if k == 0 {
            initial.clone()
        } else {
            Guidance::restarted(mission, &design, k)
        };
        Vehicle::new(agent, guidance, k)
            .with_law(law.clone())
            .with_motion(kin.clone(), dt)
            .with_acoustic(channel.clone(), mission.control.neighbour_memory, false)
    };
    let mut vehicles: BTreeMap<u32, Vehicle> = ids
        .iter()
        .map(|&id| (id, spawn(initial_agent(mission, &design, id), 0)))
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
        let mut world = FaultWorld {
            fleet: &mut fleet,
            vehicles: &mut vehicles,
            tally: &mut tally,
            recorder: &mut recorder,
        };
        world.apply(&plan, k, dt, dim, &spawn)?;
        let sensing = Instant::now();
        let (truth, told) = read_sensors(&vehicles, &fleet, &mut sensors, k, t);
        let planning = Instant::now();
        let outcome = plan_tick(
            k,
            dt,
            &truth,
            &told,
            &mut fleet,
            &mut planner,
            &mut recorder,
        )?;
        let stepping = Instant::now();
        exchange_frames(&mut vehicles, k);
        step_vehicles(&mut vehicles, &fleet, &outcome, k, dt, mission.body.v0);
        let stepped = Instant::now();
        fleet.end_tick();
        parts.ticks += 1;
        parts.field_s += (planning - sensing).as_secs_f64();
        parts.coordinator_s += (stepping - planning).as_secs_f64();
        parts.agents_s += (stepped - stepping).as_secs_f64();
        if k.is_multiple_of(every) || k + 1 == ticks {
            let distance = field
                .optimum(t, mission.mission.goal)
                .map(|o| (outcome.command.body.r - o).norm());
            progress(k + 1, ticks, t, distance);
        }
    }
    for veh in vehicles.values() {
        tally.add_downlink(
            veh.counts.delivered,
            veh.counts.dropped,
            veh.counts.superseded,
        );
        if let Some(ear) = veh.ear() {
            tally.acoustic.merge(&ear.counts);
        }
    }
    recorder.flush()?;
    let mut summary = recorder.summary(&planner, "in-process");
    summary.messages = tally.counts(&fleet);
    summary.acoustic = tally.acoustic_totals(channel.as_deref());
    summary.wall_time_s = wall.elapsed().as_secs_f64();
    summary.write(dir).context("writing summary.json")?;
    vbap_report::draw_run_with(dir, None, plugins.field.as_deref())
        .context("drawing the run's pictures")?;
    Ok(summary)
}

/// What the scheduled faults of a tick change in the in-process simulator.
struct FaultWorld<'a> {
    fleet: &'a mut Fleet,
    vehicles: &'a mut BTreeMap<u32, Vehicle>,
    tally: &'a mut LinkTally,
    recorder: &'a mut Recorder,
}

impl FaultWorld<'_> {
    /// The kills, then the restarts, of tick `k` (length `dt`, s) in `plan`: a killed
    /// vehicle is lost (its downlink counts kept), a restarted one is admitted back at its
    /// restore state and its process started again by `spawn` (mission dimension `dim`).
    fn apply(
        &mut self,
        plan: &FaultPlan,
        k: u64,
        dt: f64,
        dim: usize,
        spawn: &dyn Fn(Agent, u64) -> Vehicle,
    ) -> Result<()> {
        for v in plan.kills_at(k).collect::<Vec<_>>() {
            if let Some((event, _)) =
                membership::lose(self.fleet, k, dt, v, &Loss::scheduled_kill())
            {
                if let Some(gone) = self.vehicles.remove(&v) {
                    self.tally.add_downlink(
                        gone.counts.delivered,
                        gone.counts.dropped,
                        gone.counts.superseded,
                    );
                    if let Some(ear) = gone.ear() {
                        self.tally.acoustic.merge(&ear.counts);
                    }
                }
                self.recorder.event(event)?;
            }
        }
        for v in plan.restarts_at(k).collect::<Vec<_>>() {
            if let Some((restore, event)) = membership::rejoin(self.fleet, k, dt, v) {
                let agent = Agent {
                    id: v,
                    dim,
                    position: restore.position,
                    velocity: restore.velocity,
                };
                self.vehicles.insert(v, spawn(agent, k));
                self.recorder.event(event)?;
            }
        }
        Ok(())
    }
}

/// The acoustic frames every vehicle sends during tick `k` (its state being that of `k`),
/// handed to every other vehicle's receiver (`[acoustic]`; nothing without). The agents
/// do the same over IPC (`vehicle_agent::run`).
fn exchange_frames(vehicles: &mut BTreeMap<u32, Vehicle>, k: u64) {
    let frames: Vec<_> = vehicles
        .values_mut()
        .flat_map(|veh| veh.transmit(k))
        .collect();
    if frames.is_empty() {
        return;
    }
    for veh in vehicles.values_mut() {
        if let Some(ear) = veh.ear_mut() {
            for f in &frames {
                ear.hear(*f);
            }
        }
    }
}

/// Every vehicle takes the command of tick `k` (with the swarm snapshot of `outcome`, through its
/// downlink in `fleet`'s link model) and steps to k + 1 (length `dt`, s; cruise `v0`).
fn step_vehicles(
    vehicles: &mut BTreeMap<u32, Vehicle>,
    fleet: &Fleet,
    outcome: &TickOutcome,
    k: u64,
    dt: f64,
    v0: f64,
) {
    let (command, snapshot) = (&outcome.command, &outcome.snapshot);
    // What each vehicle is told of, as the coordinator publishes it (`BodyRecord::fill`).
    let lists = &outcome.near;
    for (&id, veh) in vehicles.iter_mut() {
        let own = own_index(snapshot, id);
        let told = Guidance::of_command(
            k,
            command.leaders.clone(),
            command.inter,
            command.leader,
            command.damping,
            command.velocity,
            v0,
        )
        .tell(
            id,
            snapshot,
            own,
            own.map_or(&[][..], |i| lists.of_point(i))
                .iter()
                .map(|&j| j as usize),
            &Telling {
                horizon: fleet.command_horizon(),
                precision: fleet.precision(),
                origin: command.body.r,
            },
            command.schedule.as_ref().map(|s| s.segments.len()),
        );
        let guidance =
            told.guidance
                .with_plan(command.schedule.clone(), command.body.r, command.body.scale);
        veh.on_command(fleet.model(), guidance, told.bytes, k, dt);
    }
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

#[cfg(test)]
mod tests {
    use super::TickParts;

    #[test]
    fn the_critical_path_is_field_and_coordinator_in_series_and_the_agents_over_the_cpus() {
        let parts = TickParts {
            ticks: 10,
            field_s: 0.001,
            coordinator_s: 0.002,
            agents_s: 0.008,
        };
        // Per tick: 100 µs + 200 µs + 800 µs over 2 CPUs.
        assert!((parts.critical_path_s(2, 16) - 700e-6).abs() < 1e-15);
        // One agent keeps its work on one CPU, however many there are.
        assert!((parts.critical_path_s(8, 1) - 1100e-6).abs() < 1e-15);
        assert!((parts.critical_path_s(0, 4) - 1100e-6).abs() < 1e-15);
        assert_eq!(TickParts::default().critical_path_s(2, 4), 0.0);
    }
}
