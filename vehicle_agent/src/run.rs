//! The agent process: wires iceoryx2 ports around [`crate::Vehicle`].
//!
//! Every body command is the lockstep clock (it always arrives, over shared memory);
//! the link model decides when its *content* becomes visible to the vehicle. A
//! (re)started agent that finds a mission under way asks to join (state flag
//! `JOINING`) and waits until the coordinator admits it, then resumes from the state the
//! coordinator hands back.
//!
//! One wake-up per tick: the command arrives, the vehicle steps, publishes its new state
//! and waits again. Its sensor reading is taken by the field server where and when that
//! state says, in the coordinator's batched read of the tick (see
//! `vbap_ipc::msg::coordinator_to_field`).

use std::cell::RefCell;
use std::collections::VecDeque;
use std::time::Duration;

use anyhow::{Context, Result};
use iceoryx2::prelude::*;
use tracing::{info, warn};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
use vbap_ipc::msg::{from_vec3, to_vec3, wall_ns, Header};
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::topics::{self, wait_for_wake, Domain, Limits, Wake};
use vbap_mission::config::{Mission, Pace};
use vbap_mission::link::{Fate, LinkModel};

use crate::{initial_agent, initial_design, Agent, Guidance, Vehicle};

/// Runs vehicle `id` of `mission` until the mission ends or a termination signal.
/// `rejoin`: the process is a restart (the supervisor says so) and asks to join the
/// mission under way instead of starting at tick 0. `msgs` receives the message records;
/// `on_ready` is called once every port exists.
pub fn run(
    mission: &Mission,
    id: u32,
    rejoin: bool,
    mut msgs: MsgLog,
    on_ready: impl FnOnce(),
) -> Result<()> {
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
    let mut vehicle = Vehicle::new(initial_agent(mission, &design, id), initial.clone(), 0);
    let ticks = mission.ticks();
    // Paced runs hold station when the coordinator is silent for a few ticks.
    let hold_after = match mission.mission.pace {
        Pace::Lockstep => None,
        Pace::Factor(f) => Some(Duration::from_secs_f64((4.0 * dt / f).max(0.5))),
    };
    let pid = std::process::id();
    let mut seq: u64 = 0;
    let mut last_body_seq: Option<u64> = None;
    let mut rejected: u64 = 0;

    // The states published lately: a restarted coordinator asks for them again.
    let recent: RefCell<VecDeque<VehicleState>> = RefCell::new(VecDeque::new());
    let send = |state: VehicleState| -> Result<()> {
        state_pub
            .send_copy(state)
            .map_err(|e| anyhow::anyhow!("publishing the state: {e:?}"))?;
        coordinator_notifier
            .notify_with_custom_event_id(topics::vehicle_event(id))
            .map_err(|e| anyhow::anyhow!("waking the coordinator: {e:?}"))?;
        Ok(())
    };
    // `read`: the commands read so far (`VehicleState::commands_read`).
    let publish = |agent: &Agent, k: u64, flags: u32, seq: &mut u64, read: u64| -> Result<()> {
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
            commands_read: read,
        };
        send(state)?;
        let mut recent = recent.borrow_mut();
        recent.push_back(state);
        while recent.len() > Limits::LOOKAHEAD_TICKS as usize + 2 {
            recent.pop_front();
        }
        Ok(())
    };
    // The link model's verdicts on commands, for the message records.
    let log_fates = |vehicle: &mut Vehicle, msgs: &mut MsgLog| {
        for (tick, fate) in vehicle.take_drawn() {
            match fate {
                Fate::Deliver { injected, .. } if injected > 0.0 => {
                    msgs.held("body", Header::COORDINATOR, id, tick, injected)
                }
                Fate::Drop(reason) => {
                    msgs.drop("body", Header::COORDINATOR, id, tick, reason.as_str())
                }
                _ => {}
            }
        }
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
    let flags = if joining { VehicleState::JOINING } else { 0 };
    publish(&vehicle.agent, k, flags, &mut seq, 0)?;

    // Lockstep: the newest command received bounds how far the vehicle may run ahead.
    let mut newest_command: Option<u64> = None;
    let read = |newest: Option<u64>| newest.map_or(0, |c| c + 1);
    // The commands read as last reported to the coordinator.
    let mut reported_read = 0;
    // Check for commands first, wait only when there is nothing to act on.
    let mut idle = false;
    loop {
        if idle {
            // Lockstep: a deadline as a safety net, so a lost wake-up costs a second, not the
            // mission (on a timeout the body subscriber is read once).
            let timeout = hold_after.unwrap_or(Duration::from_secs(1));
            // The records so far reach the file before every wait (at least once a tick):
            // a SIGKILL loses at most those of the tick under way.
            msgs.flush();
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
                        publish(
                            &vehicle.agent,
                            k,
                            VehicleState::HOLDING,
                            &mut seq,
                            read(newest_command),
                        )?;
                        continue;
                    }
                }
                Wake::Events => {}
            }
        }
        idle = true;
        // Every new valid body command, in order, read in place.
        let mut commands: Vec<(u64, Guidance, Option<SnapshotEntry>)> = Vec::new();
        let mut finished = false;
        let mut resend_after: Option<u64> = None;
        while let Some(sample) = body_sub
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving the body: {e:?}"))?
        {
            let body: &BodyCommand = &sample;
            let h = body.header;
            msgs.recv_now("body", &h, id);
            if h.sender == Header::COORDINATOR && last_body_seq == Some(h.seq) {
                // A duplicate: a restarted coordinator re-sends its last command. Send it
                // our states since again (a new subscriber's history arrives only with
                // the publisher's next sample).
                resend_after = Some(h.tick);
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
            let pot = |p: &[f64; 3]| vbap_math::potential::PairPotential {
                alpha: p[0],
                d0: p[1],
                d1: p[2],
            };
            let guidance = Guidance::of_command(
                h.tick,
                body.leaders[..n_l].iter().map(to_vec3).collect(),
                pot(&body.inter),
                pot(&body.leader),
                body.damping,
                to_vec3(&body.velocity),
                mission.body.v0,
            )
            .with_neighbours(id, snapshot);
            let own = snapshot.iter().find(|e| e.id == id).copied();
            commands.push((h.tick, guidance, own));
        }
        if finished {
            // Commands read in the same drain as the end (a slow agent finds both in its
            // buffer) still had their link fates: draw them (up to the newest, in order),
            // so the downlink counts equal the simulator's, which draws every command's.
            if !joining {
                if let Some((tick, guidance, _)) = commands.pop() {
                    vehicle.receive(&model, guidance, tick, dt);
                }
            }
            log_fates(&mut vehicle, &mut msgs);
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
        if let (Some(after), true) = (resend_after, commands.is_empty()) {
            for last in recent.borrow().iter().filter(|s| s.header.tick > after) {
                seq += 1;
                send(VehicleState {
                    header: Header {
                        seq,
                        sent_ns: wall_ns(),
                        ..last.header
                    },
                    commands_read: read(newest_command),
                    ..*last
                })?;
                info!(
                    vehicle = id,
                    tick = last.header.tick,
                    "re-sent a state to a restarted coordinator"
                );
            }
        }
        if hold_after.is_some() && commands.len() > 1 {
            // Paced: only the newest command counts (the older ones are late).
            commands.drain(..commands.len() - 1);
        }
        for (tick, guidance, own) in commands {
            newest_command = Some(tick);
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
                            tick,
                        );
                        joining = false;
                        k = tick;
                        info!(vehicle = id, tick, "admitted back into the formation");
                    }
                    _ => continue,
                }
            } else if hold_after.is_some() {
                if tick < k {
                    continue; // an old command (paced runs): we already stepped past it
                }
                k = tick;
            }
            vehicle.receive(&model, guidance, tick, dt);
            if hold_after.is_some() {
                // Paced: step on every command, from its tick (late ones are skipped).
                vehicle.forget_before(tick);
                vehicle.step(k, dt);
                k += 1;
                idle = false;
                if k < ticks {
                    publish(&vehicle.agent, k, 0, &mut seq, read(newest_command))?;
                    reported_read = read(newest_command);
                }
            }
        }
        // Lockstep: step whenever every command the step needs is in; a submerged glider
        // (or a long link delay) needs none, and runs ahead (up to LOOKAHEAD_TICKS).
        if hold_after.is_none() && !joining {
            let limit = newest_command.map_or(0, |c| c + 1) + Limits::LOOKAHEAD_TICKS;
            if k + 1 < ticks && k < limit && vehicle.ready_to_step(&model, k, dt) {
                vehicle.step(k, dt);
                k += 1;
                idle = false;
                publish(&vehicle.agent, k, 0, &mut seq, read(newest_command))?;
                reported_read = read(newest_command);
            } else if read(newest_command) >= reported_read + 2 {
                // Waiting, but still reading commands: say so, so the coordinator may go on
                // publishing without overflowing our command buffer.
                let last = recent.borrow().back().copied();
                if let Some(last) = last {
                    seq += 1;
                    send(VehicleState {
                        header: Header {
                            flags: VehicleState::ACK,
                            seq,
                            sent_ns: wall_ns(),
                            ..last.header
                        },
                        commands_read: read(newest_command),
                        ..last
                    })?;
                    reported_read = read(newest_command);
                }
            }
        }
        log_fates(&mut vehicle, &mut msgs);
    }
}
