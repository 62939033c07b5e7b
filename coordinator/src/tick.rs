//! One tick of the coordinator's decision, as `vbap sim` and the coordinator process both
//! run it: the true reports pass the link model, the planner steps on what was delivered,
//! and the run directory records it all. Sharing this one function is what keeps the two
//! byte-identical. The planner is any [`Plan`] (the binaries ship [`crate::planner::Planner`]).

use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
use vbap_math::neighbourhood::Neighbourhoods;
use vbap_mission::config::LawKind;
use vbap_mission::link::Fate;

use crate::fleet::Fleet;
use crate::near::{command_sizes, neighbour_lists};
use crate::plan::Plan;
use crate::planner::{Command, PlannerError, Report, Told};
use crate::record::Recorder;

/// What a tick produced.
pub struct TickOutcome {
    /// The link model's verdict on every true report, for the logs.
    pub fates: Vec<(u32, Fate)>,
    /// The command for the step from tick k to k + 1.
    pub command: Command,
    /// The swarm snapshot published with it.
    pub snapshot: Vec<SnapshotEntry>,
    /// Each snapshot entry's neighbour list, published with it ([`crate::near`]).
    pub near: Neighbourhoods,
}

/// Errors of a tick.
#[derive(Debug, thiserror::Error)]
pub enum TickError {
    /// The planner refused the tick.
    #[error(transparent)]
    Planner(#[from] PlannerError),
    /// A run-directory file could not be written.
    #[error("writing the run directory: {0}")]
    Io(#[from] std::io::Error),
}

/// Tick `k` (length `dt`, s) with the true reports `truth` (ordered by id) and what the
/// vehicles say of themselves, `told` (their beliefs: what the link carries to the
/// planner; empty = the truth): link model, body track, planner step, run-directory rows,
/// each vehicle's neighbour list and the bytes of its command.
#[allow(clippy::too_many_arguments)]
pub fn plan_tick(
    k: u64,
    dt: f64,
    truth: &[Report],
    told: &[Told],
    fleet: &mut Fleet,
    planner: &mut impl Plan,
    recorder: &mut Recorder,
) -> Result<TickOutcome, TickError> {
    let t = k as f64 * dt;
    let fates = fleet.receive_told(k, dt, truth, told);
    recorder.uplink(k, &fates)?;
    fleet.track_body(k, planner.motion_point());
    let joined: Vec<u32> = fleet.admitted().iter().map(|r| r.id).collect();
    let (members, fresh) = fleet.deliver(t, dt);
    planner.see_hulls(&fleet.hulls());
    let command = planner.step(k, &members, &fresh, &joined, dt)?;
    recorder.inputs(k, &members, &fresh, &joined)?;
    recorder.tick(k, truth, told, &command)?;
    recorder.truth(k, truth, &command, planner.design(), fleet)?;
    let mut snapshot = fleet.snapshot(&members, &command.rejoining);
    crate::slots::annotate(&mut snapshot, k, dt, &members);
    if planner.law() == LawKind::Robust {
        let slots = planner.member_slots(&command, &members);
        crate::slots::give_slots(&mut snapshot, &slots);
    }
    let horizon = fleet.command_horizon();
    let near = neighbour_lists(&snapshot, &command.inter, &command.velocity, horizon);
    let delivered = fates
        .iter()
        .filter(|(_, f)| matches!(f, Fate::Deliver { .. }))
        .count() as u64;
    let in_contact = |v: u32| fleet.model().carries_command(v, k);
    let sizes = command_sizes(
        &command,
        &snapshot,
        &near,
        horizon,
        fleet.precision(),
        in_contact,
        fleet.model().iridium().map(|i| i.down_limit),
    );
    recorder.links(&sizes, delivered);
    Ok(TickOutcome {
        fates,
        command,
        snapshot,
        near,
    })
}
