//! The agent process: wires iceoryx2 ports around [`crate::Agent::step`].

use std::time::Duration;

use anyhow::{bail, Context, Result};
use iceoryx2::prelude::*;
use shared::config::{Mission, Pace};
use shared::math::potential::PairPotential;
use shared::math::Vec3;
use shared::msg::agent_to_coordinator::VehicleState;
use shared::msg::agent_to_field::SampleRequest;
use shared::msg::coordinator_to_agent::BodyCommand;
use shared::msg::{from_vec3, to_vec3, wall_ns, Header};
use shared::telemetry::MSG_TARGET;
use shared::topics::{self, wait_for_wake, Domain, Limits, Wake};
use tracing::{debug, info, warn};

use crate::{initial_agent, initial_design, Agent, AgentInputs};

/// How long an agent waits for its sensor reading before it gives up (wall time).
const SAMPLE_TIMEOUT: Duration = Duration::from_secs(10);

/// The last command heard from the coordinator.
struct LastCommand {
    leaders: Vec<Vec3>,
    neighbours: Vec<Vec3>,
    inter: PairPotential,
    leader: PairPotential,
    damping: f64,
}

/// Runs vehicle `id` of `mission` until the mission ends or a termination signal.
pub fn run(mission: &Mission, id: u32, on_ready: impl FnOnce()) -> Result<()> {
    let name = &mission.mission.name;
    let dt = mission.mission.dt;
    let domain = Domain::new(name)?;
    let limits = Limits::for_fleet(mission.vehicles.count);
    let node = domain.node(&topics::agent_node_name(id))?;

    let state_service = domain.state_service(&node, id, &limits)?;
    let state_pub = state_service.publisher_builder().create().map_err(|e| {
        anyhow::anyhow!(
            "vehicle {id}: cannot publish on {}: {e:?} (is another agent running with this id?)",
            domain.state_name(id)
        )
    })?;
    let body_sub = domain
        .body_service(&node, &limits)?
        .subscriber_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("subscribing to the body service: {e:?}"))?;
    let client = domain
        .field_service(&node, &limits)?
        .client_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("creating the field client: {e:?}"))?;
    let wake = domain
        .vehicle_wake(&node, id, &limits)?
        .listener_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("creating the wake listener: {e:?}"))?;
    let coordinator_notifier = domain
        .coordinator_wake(&node, &limits)?
        .notifier_builder()
        .default_event_id(topics::EVENT_DATA)
        .create()
        .map_err(|e| anyhow::anyhow!("creating the coordinator notifier: {e:?}"))?;
    let field_notifier = domain
        .field_wake(&node, &limits)?
        .notifier_builder()
        .default_event_id(topics::EVENT_DATA)
        .create()
        .map_err(|e| anyhow::anyhow!("creating the field notifier: {e:?}"))?;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<ipc::Service>()
        .map_err(|e| anyhow::anyhow!("creating the waitset: {e:?}"))?;
    let _guard = waitset
        .attach_notification(&wake)
        .map_err(|e| anyhow::anyhow!("attaching the wake listener: {e:?}"))?;

    let design = initial_design(mission).context("initial formation design")?;
    let mut agent: Agent = initial_agent(mission, &design, id);
    // Paced runs hold station when the coordinator is silent for a few ticks.
    let hold_after = match mission.mission.pace {
        Pace::Lockstep => None,
        Pace::Factor(f) => Some(Duration::from_secs_f64((4.0 * dt / f).max(0.5))),
    };
    let mut seq: u64 = 0;
    let mut k: u64 = 0;
    let mut last_body_seq: Option<u64> = None;
    let mut rejected: u64 = 0;
    let mut last: Option<LastCommand> = None;
    info!(
        vehicle = id,
        x = agent.position.x,
        y = agent.position.y,
        z = agent.position.z,
        "agent up"
    );
    on_ready();

    // The sensor reading at the current tick, then the state report.
    let report = |agent: &Agent, k: u64, seq: &mut u64, holding: bool| -> Result<bool> {
        let t = k as f64 * dt;
        *seq += 1;
        let request = SampleRequest {
            header: Header {
                sender: id,
                flags: 0,
                tick: k,
                t,
                seq: *seq,
                sent_ns: wall_ns(),
            },
            position: from_vec3(&agent.position),
        };
        let pending = client
            .send_copy(request)
            .map_err(|e| anyhow::anyhow!("sending a sample request: {e:?}"))?;
        field_notifier
            .notify()
            .map_err(|e| anyhow::anyhow!("waking the field server: {e:?}"))?;
        let started = std::time::Instant::now();
        let value = loop {
            if let Some(reply) = pending
                .receive()
                .map_err(|e| anyhow::anyhow!("receiving a sample: {e:?}"))?
            {
                let recv_ns = wall_ns();
                let h = reply.header;
                debug!(target: MSG_TARGET, hop = "field_reply", sender = h.sender, receiver = id, tick = h.tick,
                       seq = h.seq, sent_ns = h.sent_ns, recv_ns, "recv");
                if reply.rejected != 0 || !reply.value.is_finite() {
                    bail!("the field server rejected our sample request at tick {k}");
                }
                break reply.value;
            }
            let left = SAMPLE_TIMEOUT.saturating_sub(started.elapsed());
            if left.is_zero() {
                bail!("no sensor reading from the field server within {SAMPLE_TIMEOUT:?}");
            }
            if wait_for_wake(&waitset, &wake, left)? == Wake::Stop {
                return Ok(false);
            }
        };
        *seq += 1;
        let state = VehicleState {
            header: Header {
                sender: id,
                flags: if holding { VehicleState::HOLDING } else { 0 },
                tick: k,
                t,
                seq: *seq,
                sent_ns: wall_ns(),
            },
            position: from_vec3(&agent.position),
            velocity: from_vec3(&agent.velocity),
            measurement: value,
        };
        state_pub
            .send_copy(state)
            .map_err(|e| anyhow::anyhow!("publishing the state: {e:?}"))?;
        coordinator_notifier
            .notify()
            .map_err(|e| anyhow::anyhow!("waking the coordinator: {e:?}"))?;
        Ok(true)
    };

    if !report(&agent, k, &mut seq, false)? {
        info!(vehicle = id, "stopped by signal");
        return Ok(());
    }
    // Check for commands first, wait only when there is nothing to act on: a command may
    // have arrived (and its wake-up been consumed) while we waited for a sensor reading.
    let mut idle = false;
    loop {
        if idle {
            let timeout = hold_after.unwrap_or(Duration::from_secs(3600));
            match wait_for_wake(&waitset, &wake, timeout)? {
                Wake::Stop => {
                    info!(vehicle = id, tick = k, "stopped by signal");
                    return Ok(());
                }
                Wake::Timeout => {
                    if let (Some(_), Some(cmd)) = (hold_after, last.as_ref()) {
                        agent.hold_station(&cmd.leaders, &cmd.leader, cmd.damping, dt);
                        k += 1;
                        warn!(
                            vehicle = id,
                            tick = k,
                            "coordinator silent: holding station"
                        );
                        if !report(&agent, k, &mut seq, true)? {
                            return Ok(());
                        }
                    }
                    continue;
                }
                Wake::Events => {}
            }
        }
        idle = true;
        // Read the newest valid body command in place.
        let mut newest: Option<(u64, bool)> = None;
        while let Some(sample) = body_sub
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving the body: {e:?}"))?
        {
            let body: &BodyCommand = &sample;
            let h = body.header;
            let recv_ns = wall_ns();
            debug!(target: MSG_TARGET, hop = "body", sender = h.sender, receiver = id, tick = h.tick, seq = h.seq,
                   sent_ns = h.sent_ns, recv_ns, "recv");
            let replay = last_body_seq.is_some_and(|s| h.seq <= s);
            if h.sender != Header::COORDINATOR || replay || !body.is_valid() {
                rejected += 1;
                warn!(
                    vehicle = id,
                    tick = h.tick,
                    seq = h.seq,
                    rejected,
                    "rejected a body command"
                );
                continue;
            }
            last_body_seq = Some(h.seq);
            if h.flags & BodyCommand::FINISHED != 0 {
                newest = Some((h.tick, true));
                break;
            }
            let n_l = body.n_leaders as usize;
            let n_v = body.n_vehicles as usize;
            let cmd = LastCommand {
                leaders: body.leaders[..n_l].iter().map(to_vec3).collect(),
                neighbours: body.snapshot[..n_v]
                    .iter()
                    .filter(|e| e.id != id && e.alive != 0)
                    .map(|e| to_vec3(&e.position))
                    .collect(),
                inter: PairPotential {
                    alpha: body.inter[0],
                    d0: body.inter[1],
                    d1: body.inter[2],
                },
                leader: PairPotential {
                    alpha: body.leader[0],
                    d0: body.leader[1],
                    d1: body.leader[2],
                },
                damping: body.damping,
            };
            last = Some(cmd);
            newest = Some((h.tick, false));
        }
        let Some((tick, finished)) = newest else {
            continue;
        };
        if finished {
            info!(vehicle = id, tick = k, rejected, "mission finished");
            return Ok(());
        }
        if tick < k {
            continue; // an old command (paced runs): we already stepped past it
        }
        idle = false;
        let cmd = last.as_ref().expect("set with newest");
        let inputs = AgentInputs {
            leaders: &cmd.leaders,
            neighbours: &cmd.neighbours,
            inter: cmd.inter,
            leader: cmd.leader,
            damping: cmd.damping,
        };
        agent.step(&inputs, dt);
        k = tick + 1;
        if !report(&agent, k, &mut seq, false)? {
            info!(vehicle = id, tick = k, "stopped by signal");
            return Ok(());
        }
    }
}
