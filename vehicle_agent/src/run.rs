//! The agent process: wires iceoryx2 ports around [`crate::Vehicle`].
//!
//! Every body command is the lockstep clock (it always arrives, over shared memory);
//! the link model decides when its *content* becomes visible to the vehicle. A
//! (re)started agent that finds a mission under way asks to join (state flag
//! `JOINING`) and waits until the coordinator admits it, then resumes from the state the
//! coordinator hands back.

use std::time::Duration;

use anyhow::{bail, Context, Result};
use iceoryx2::prelude::*;
use shared::config::{Mission, Pace};
use shared::faults::FaultPlan;
use shared::link::{Fate, LinkModel};
use shared::msg::agent_to_coordinator::VehicleState;
use shared::msg::agent_to_field::SampleRequest;
use shared::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
use shared::msg::{from_vec3, to_vec3, wall_ns, Header};
use shared::telemetry::MSG_TARGET;
use shared::topics::{self, wait_for_wake, Domain, Limits, Wake};
use tracing::{debug, info, warn};

use crate::{initial_agent, initial_design, Agent, Guidance, Vehicle};

/// How long an agent waits for a sensor reading before it wakes the field server again.
const RENOTIFY_AFTER: Duration = Duration::from_millis(500);
/// How long an agent waits for its sensor reading before it gives up (wall time).
const SAMPLE_TIMEOUT: Duration = Duration::from_secs(10);

/// Runs vehicle `id` of `mission` until the mission ends or a termination signal.
/// `rejoin`: the process is a restart (the supervisor says so) and asks to join the
/// mission under way instead of starting at tick 0. `on_ready` is called once every port
/// exists.
pub fn run(mission: &Mission, id: u32, rejoin: bool, on_ready: impl FnOnce()) -> Result<()> {
    let name = &mission.mission.name;
    let dt = mission.mission.dt;
    let domain = Domain::new(name)?;
    let limits = Limits::for_fleet(mission.vehicles.count);
    let node = domain.agent_node(&topics::agent_node_name(id))?;

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
        .field_service(&node, id, &limits)?
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
    let initial = Guidance::initial(mission, &design);
    let model = LinkModel::new(mission);
    let plan = FaultPlan::new(mission);
    let mut vehicle = Vehicle::new(initial_agent(mission, &design, id), initial.clone());
    // Paced runs hold station when the coordinator is silent for a few ticks.
    let hold_after = match mission.mission.pace {
        Pace::Lockstep => None,
        Pace::Factor(f) => Some(Duration::from_secs_f64((4.0 * dt / f).max(0.5))),
    };
    let pid = std::process::id();
    let mut seq: u64 = 0;
    let mut last_body_seq: Option<u64> = None;
    let mut rejected: u64 = 0;

    // Reads the sensor at the vehicle's position at tick k (through the field server).
    let sample = |agent: &Agent, k: u64, seq: &mut u64| -> Result<Option<f64>> {
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
            .notify_with_custom_event_id(topics::vehicle_event(id))
            .map_err(|e| anyhow::anyhow!("waking the field server: {e:?}"))?;
        let started = std::time::Instant::now();
        loop {
            if let Some(reply) = pending
                .receive()
                .map_err(|e| anyhow::anyhow!("receiving a sample: {e:?}"))?
            {
                let h = reply.header;
                debug!(target: MSG_TARGET, hop = "field_reply", sender = h.sender, receiver = id, tick = h.tick,
                       seq = h.seq, sent_ns = h.sent_ns, recv_ns = wall_ns(), "recv");
                if reply.rejected != 0 || !reply.value.is_finite() {
                    bail!("the field server rejected our sample request at tick {k}");
                }
                return Ok(Some(reply.value));
            }
            let left = SAMPLE_TIMEOUT.saturating_sub(started.elapsed());
            if left.is_zero() {
                bail!("no sensor reading from the field server within {SAMPLE_TIMEOUT:?}");
            }
            match wait_for_wake(&waitset, &wake, left.min(RENOTIFY_AFTER))? {
                Wake::Stop => return Ok(None),
                // No reply yet: ring again (a lost wake-up must not stall the mission).
                Wake::Timeout => {
                    warn!(
                        vehicle = id,
                        tick = k,
                        "no sensor reading yet: waking the field server again"
                    );
                    field_notifier
                        .notify_with_custom_event_id(topics::vehicle_event(id))
                        .map_err(|e| anyhow::anyhow!("waking the field server: {e:?}"))?;
                }
                Wake::Events => {}
            }
        }
    };
    let last_sent: std::cell::Cell<Option<VehicleState>> = std::cell::Cell::new(None);
    let publish = |agent: &Agent, k: u64, value: f64, flags: u32, seq: &mut u64| -> Result<()> {
        *seq += 1;
        let state = VehicleState {
            header: Header {
                sender: id,
                flags,
                tick: k,
                t: k as f64 * dt,
                seq: *seq,
                sent_ns: wall_ns(),
            },
            pid,
            _pad: 0,
            position: from_vec3(&agent.position),
            velocity: from_vec3(&agent.velocity),
            measurement: value,
        };
        state_pub
            .send_copy(state)
            .map_err(|e| anyhow::anyhow!("publishing the state: {e:?}"))?;
        last_sent.set(Some(state));
        coordinator_notifier
            .notify_with_custom_event_id(topics::vehicle_event(id))
            .map_err(|e| anyhow::anyhow!("waking the coordinator: {e:?}"))?;
        Ok(())
    };
    // Measure at tick k (sensor faults applied) and report. False on a stop signal.
    let report = |vehicle: &mut Vehicle, k: u64, seq: &mut u64, flags: u32| -> Result<bool> {
        let Some(raw) = sample(&vehicle.agent, k, seq)? else {
            return Ok(false);
        };
        let value = vehicle.read_sensor(&plan, k as f64 * dt, raw);
        publish(&vehicle.agent, k, value, flags, seq)?;
        Ok(true)
    };

    // A restarted process asks to join the mission under way; the coordinator admits it
    // by handing its last known state back in the snapshot.
    let mut joining = rejoin;
    let mut k: u64 = 0;
    info!(
        vehicle = id,
        joining,
        tick = k,
        x = vehicle.agent.position.x,
        y = vehicle.agent.position.y,
        z = vehicle.agent.position.z,
        "agent up"
    );
    on_ready();
    if joining {
        publish(&vehicle.agent, k, 0.0, VehicleState::JOINING, &mut seq)?;
    } else if !report(&mut vehicle, k, &mut seq, 0)? {
        info!(vehicle = id, "stopped by signal");
        return Ok(());
    }

    // Check for commands first, wait only when there is nothing to act on: a command may
    // have arrived (and its wake-up been consumed) while we waited for a sensor reading.
    let mut idle = false;
    loop {
        if idle {
            // Lockstep: a deadline as a safety net, so a lost wake-up costs a second, not the
            // mission (on a timeout the body subscriber is read once).
            let timeout = hold_after.unwrap_or(Duration::from_secs(1));
            match wait_for_wake(&waitset, &wake, timeout)? {
                Wake::Stop => {
                    info!(vehicle = id, tick = k, "stopped by signal");
                    return Ok(());
                }
                Wake::Timeout => {
                    // Hold station only once the mission is under way: before its first
                    // command a vehicle waits where it was deployed (the set may still be
                    // starting up).
                    if hold_after.is_some() && !joining && last_body_seq.is_some() {
                        // Nothing heard (paced runs): fly the last visible guidance.
                        vehicle.hold_station(dt);
                        k += 1;
                        warn!(
                            vehicle = id,
                            tick = k,
                            "coordinator silent: holding station"
                        );
                        if !report(&mut vehicle, k, &mut seq, VehicleState::HOLDING)? {
                            return Ok(());
                        }
                        continue;
                    }
                }
                Wake::Events => {}
            }
        }
        idle = true;
        // The newest valid body command, read in place.
        let mut newest: Option<(u64, Guidance, Option<SnapshotEntry>)> = None;
        let mut finished = false;
        let mut resend = false;
        while let Some(sample) = body_sub
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving the body: {e:?}"))?
        {
            let body: &BodyCommand = &sample;
            let h = body.header;
            debug!(target: MSG_TARGET, hop = "body", sender = h.sender, receiver = id, tick = h.tick, seq = h.seq,
                   sent_ns = h.sent_ns, recv_ns = wall_ns(), "recv");
            if h.sender == Header::COORDINATOR && last_body_seq == Some(h.seq) {
                // A duplicate: a restarted coordinator re-sends its last command. Send our
                // last state again so it gets it (a new subscriber's history arrives only
                // with the publisher's next sample).
                resend = true;
                continue;
            }
            let replay = last_body_seq.is_some_and(|s| h.seq < s);
            if h.sender != Header::COORDINATOR || replay || !body.is_valid() {
                rejected += 1;
                warn!(
                    vehicle = id,
                    tick = h.tick,
                    seq = h.seq,
                    sender = h.sender,
                    rejected,
                    replay,
                    "rejected a body command"
                );
                continue;
            }
            last_body_seq = Some(h.seq);
            if h.flags & BodyCommand::FINISHED != 0 {
                finished = true;
                break;
            }
            let n_l = body.n_leaders as usize;
            let n_v = body.n_vehicles as usize;
            let snapshot = &body.snapshot[..n_v];
            let pot = |p: &[f64; 3]| shared::math::potential::PairPotential {
                alpha: p[0],
                d0: p[1],
                d1: p[2],
            };
            let guidance = Guidance {
                tick: h.tick,
                leaders: body.leaders[..n_l].iter().map(to_vec3).collect(),
                neighbours: Vec::new(),
                inter: pot(&body.inter),
                leader: pot(&body.leader),
                damping: body.damping,
                velocity: to_vec3(&body.velocity),
            }
            .with_neighbours(id, snapshot);
            let own = snapshot.iter().find(|e| e.id == id).copied();
            newest = Some((h.tick, guidance, own));
        }
        if finished {
            info!(
                vehicle = id,
                tick = k,
                rejected,
                delivered = vehicle.counts.delivered,
                dropped = vehicle.counts.dropped,
                "mission finished"
            );
            return Ok(());
        }
        if resend && newest.is_none() {
            if let Some(last) = last_sent.get() {
                seq += 1;
                let again = VehicleState {
                    header: Header {
                        seq,
                        sent_ns: wall_ns(),
                        ..last.header
                    },
                    ..last
                };
                state_pub
                    .send_copy(again)
                    .map_err(|e| anyhow::anyhow!("re-publishing the state: {e:?}"))?;
                coordinator_notifier
                    .notify_with_custom_event_id(topics::vehicle_event(id))
                    .map_err(|e| anyhow::anyhow!("waking the coordinator: {e:?}"))?;
                info!(
                    vehicle = id,
                    tick = again.header.tick,
                    "re-sent the last state to a restarted coordinator"
                );
            }
        }
        let Some((tick, guidance, own)) = newest else {
            continue;
        };
        let admitted = own.is_some_and(|e| e.alive == SnapshotEntry::ADMITTED);
        if joining || admitted {
            // Admitted when the coordinator hands our state back in the snapshot.
            match own {
                Some(e) if admitted => {
                    vehicle = Vehicle::new(
                        Agent {
                            id,
                            dim: mission.mission.dim,
                            position: to_vec3(&e.position),
                            velocity: to_vec3(&e.velocity),
                        },
                        initial.clone(),
                    );
                    joining = false;
                    info!(vehicle = id, tick, "admitted back into the formation");
                }
                _ => continue,
            }
        } else if tick < k {
            continue; // an old command (paced runs): we already stepped past it
        }
        idle = false;
        let fate = vehicle.on_command(&model, guidance, tick, dt);
        match fate {
            Fate::Deliver { injected, .. } if injected > 0.0 => {
                debug!(target: MSG_TARGET, hop = "body_link", receiver = id, tick, injected_ms = injected * 1e3, "held")
            }
            Fate::Drop(reason) => {
                debug!(target: MSG_TARGET, hop = "body", receiver = id, tick, reason = reason.as_str(), "drop")
            }
            _ => {}
        }
        k = tick + 1;
        if k >= mission.ticks() {
            continue; // the last tick's state is never used: wait for the end of the mission
        }
        if !report(&mut vehicle, k, &mut seq, 0)? {
            info!(vehicle = id, tick = k, "stopped by signal");
            return Ok(());
        }
    }
}
