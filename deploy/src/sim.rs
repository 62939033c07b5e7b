//! `vbap sim`: the in-process reference simulator.
//!
//! The same mission as `vbap run`, through the same pure steps ([`Agent::step`],
//! [`Planner::step`], [`World::sample`]) and the same recorder, in one process with no
//! IPC. In lockstep the multi-process system must reproduce its files byte for byte; it
//! is also the speed baseline of the IPC system.

use std::time::Instant;

use anyhow::{Context, Result};
use coordinator::planner::{Planner, PlannerParams, Report};
use coordinator::record::Recorder;
use field_server::World;
use shared::config::Mission;
use shared::math::Vec3;
use shared::rundir::{RunDir, Summary};
use vehicle_agent::{initial_agent, initial_design, Agent, AgentInputs};

/// Progress callback: (tick, ticks, mission time s, distance to optimum if known).
pub type Progress<'a> = &'a mut dyn FnMut(u64, u64, f64, Option<f64>);

/// Runs `mission` in process, writing the run directory `dir`. Returns the summary.
pub fn simulate(mission: &Mission, dir: &RunDir, progress: Progress<'_>) -> Result<Summary> {
    let wall = Instant::now();
    let dt = mission.mission.dt;
    let ticks = mission.ticks();
    let design = initial_design(mission).context("initial formation design")?;
    let mut agents: Vec<Agent> = (0..mission.vehicles.count as u32)
        .map(|id| initial_agent(mission, &design, id))
        .collect();
    let ids: Vec<u32> = agents.iter().map(|a| a.id).collect();
    let world = World::new(mission);
    let field = mission.field();
    let mut planner = Planner::new(
        PlannerParams::from_mission(mission),
        mission.start_vec(),
        &ids,
    )?;
    let mut recorder = Recorder::open(mission, dir).context("opening the run directory files")?;
    let every = (ticks / 200).max(1);
    let mut positions: Vec<Vec3> = Vec::with_capacity(agents.len());
    let mut neighbours: Vec<Vec3> = Vec::with_capacity(agents.len());
    for k in 0..ticks {
        let t = k as f64 * dt;
        let reports: Vec<Report> = agents
            .iter()
            .map(|a| Report {
                id: a.id,
                tick: k,
                position: a.position,
                velocity: a.velocity,
                measurement: world.sample(a.id, k, t, &a.position).unwrap_or(f64::NAN),
            })
            .collect();
        let command = planner.step(k, &reports, &reports, dt)?;
        recorder.inputs(k, &reports, &reports)?;
        recorder.tick(k, &reports, &command)?;
        positions.clear();
        positions.extend(reports.iter().map(|q| q.position));
        for (i, agent) in agents.iter_mut().enumerate() {
            neighbours.clear();
            neighbours.extend(
                positions
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .map(|(_, p)| *p),
            );
            let inputs = AgentInputs {
                leaders: &command.leaders,
                neighbours: &neighbours,
                inter: command.inter,
                leader: command.leader,
                damping: command.damping,
            };
            agent.step(&inputs, dt);
        }
        if k.is_multiple_of(every) || k + 1 == ticks {
            let distance = field
                .optimum(t, mission.mission.goal)
                .map(|o| (command.body.r - o).norm());
            progress(k + 1, ticks, t, distance);
        }
    }
    recorder.flush()?;
    let mut summary = recorder.summary(&planner, "in-process");
    summary.wall_time_s = wall.elapsed().as_secs_f64();
    summary.write(dir).context("writing summary.json")?;
    recorder.write_plot().context("writing plot.svg")?;
    crate::report_plots::write_run_plots(dir).context("writing the time-series plots")?;
    Ok(summary)
}
