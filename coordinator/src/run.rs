//! The coordinator process: gathers states, steps the planner, publishes the body.

use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use iceoryx2::prelude::*;
use shared::config::{Mission, Pace};
use shared::msg::agent_to_coordinator::VehicleState;
use shared::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
use shared::msg::{from_vec3, to_vec3, wall_ns, Header, MAX_LEADERS};
use shared::rundir::{MessageCounts, RunDir};
use shared::telemetry::MSG_TARGET;
use shared::topics::{self, wait_for_wake, Domain, Limits, Wake};
use tracing::{debug, info, warn};

use crate::planner::{Planner, PlannerParams, Report};
use crate::record::Recorder;

/// Wall time a lockstep tick waits for a silent vehicle before going on without it.
pub const LOCKSTEP_TIMEOUT: Duration = Duration::from_secs(10);

/// Message figures gathered by the coordinator.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counters {
    pub messages: MessageCounts,
    pub late_ticks: u64,
}

/// Runs the coordinator of `mission`, writing into `dir`. `on_ready` is called once every
/// port exists. Returns when the mission is over or on a termination signal.
pub fn run(mission: &Mission, dir: &RunDir, on_ready: impl FnOnce()) -> Result<()> {
    let n = mission.vehicles.count;
    let dt = mission.mission.dt;
    let ticks = mission.ticks();
    let domain = Domain::new(&mission.mission.name)?;
    let limits = Limits::for_fleet(n);
    let node = domain.node(topics::COORDINATOR_NODE)?;

    let mut subscribers = Vec::with_capacity(n);
    let mut notifiers = Vec::with_capacity(n);
    for id in 0..n as u32 {
        subscribers.push(
            domain
                .state_service(&node, id, &limits)?
                .subscriber_builder()
                .create()
                .map_err(|e| anyhow::anyhow!("subscribing to {}: {e:?}", domain.state_name(id)))?,
        );
        notifiers.push(
            domain
                .vehicle_wake(&node, id, &limits)?
                .notifier_builder()
                .default_event_id(topics::EVENT_BODY)
                .create()
                .map_err(|e| anyhow::anyhow!("notifier of vehicle {id}: {e:?}"))?,
        );
    }
    let body_pub = domain
        .body_service(&node, &limits)?
        .publisher_builder()
        .create()
        .map_err(|e| {
            anyhow::anyhow!("publishing the body (is another coordinator running?): {e:?}")
        })?;
    let field_notifier = domain
        .field_wake(&node, &limits)?
        .notifier_builder()
        .default_event_id(topics::EVENT_BODY)
        .create()
        .map_err(|e| anyhow::anyhow!("field notifier: {e:?}"))?;
    let wake = domain
        .coordinator_wake(&node, &limits)?
        .listener_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("coordinator wake listener: {e:?}"))?;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<ipc::Service>()
        .map_err(|e| anyhow::anyhow!("creating the waitset: {e:?}"))?;
    let _guard = waitset
        .attach_notification(&wake)
        .map_err(|e| anyhow::anyhow!("attaching: {e:?}"))?;

    let ids: Vec<u32> = (0..n as u32).collect();
    let mut planner = Planner::new(
        PlannerParams::from_mission(mission),
        mission.start_vec(),
        &ids,
    )?;
    let mut recorder = Recorder::open(mission, dir).context("opening the run directory files")?;
    let mut latest: Vec<Option<VehicleState>> = vec![None; n];
    let mut last_seq: Vec<Option<u64>> = vec![None; n];
    let mut counters = Counters::default();
    let mut seq = 0u64;
    let mut body = Box::new(BodyCommand::empty());
    info!(vehicles = n, ticks, "coordinator up");
    on_ready();

    let paced = match mission.mission.pace {
        Pace::Lockstep => None,
        Pace::Factor(f) => Some(dt / f),
    };
    let mut clock_start: Option<Instant> = None;
    let mut stopped = false;
    let mut k = 0u64;
    'ticks: while k < ticks {
        // Gather the states of tick k: all of them (lockstep), or what is in at the
        // tick's deadline (paced).
        let first = k == 0;
        let wait_limit = if first {
            Duration::from_secs(30) + Duration::from_millis(100) * n as u32
        } else {
            LOCKSTEP_TIMEOUT
        };
        let gather_start = Instant::now();
        loop {
            for (id, sub) in subscribers.iter().enumerate() {
                while let Some(sample) = sub
                    .receive()
                    .map_err(|e| anyhow::anyhow!("receiving state {id}: {e:?}"))?
                {
                    let s: VehicleState = *sample;
                    let recv_ns = wall_ns();
                    let h = s.header;
                    debug!(target: MSG_TARGET, hop = "state", sender = h.sender, tick = h.tick, seq = h.seq,
                           sent_ns = h.sent_ns, recv_ns, "recv");
                    let replay = last_seq[id].is_some_and(|q| h.seq <= q);
                    let future = h.tick > k + 1;
                    if h.sender as usize != id || replay || future || !s.is_finite() {
                        counters.messages.rejected += 1;
                        warn!(
                            vehicle = id,
                            tick = h.tick,
                            seq = h.seq,
                            replay,
                            future,
                            "rejected a state"
                        );
                        continue;
                    }
                    last_seq[id] = Some(h.seq);
                    counters.messages.delivered += 1;
                    if latest[id].is_none_or(|old| h.tick >= old.header.tick) {
                        latest[id] = Some(s);
                    }
                }
            }
            let complete = latest.iter().all(|s| s.is_some_and(|s| s.header.tick >= k));
            let timeout = match paced {
                None => {
                    if complete {
                        break;
                    }
                    let left = wait_limit.saturating_sub(gather_start.elapsed());
                    if left.is_zero() {
                        warn!(
                            tick = k,
                            "lockstep timeout: going on without the silent vehicles"
                        );
                        break;
                    }
                    left
                }
                Some(period) => {
                    if first && !complete {
                        wait_limit.saturating_sub(gather_start.elapsed())
                    } else {
                        let start = *clock_start.get_or_insert_with(Instant::now);
                        let deadline = start + Duration::from_secs_f64(period * k as f64);
                        let now = Instant::now();
                        if now >= deadline {
                            if !complete {
                                counters.late_ticks += 1;
                                debug!(
                                    tick = k,
                                    "late tick: not every state was in at the deadline"
                                );
                            }
                            break;
                        }
                        if complete {
                            // Everyone reported: sleep in the waitset until the deadline.
                            deadline - now
                        } else {
                            deadline - now
                        }
                    }
                }
            };
            if wait_for_wake(&waitset, &wake, timeout)? == Wake::Stop {
                stopped = true;
                break 'ticks;
            }
        }
        let reports: Vec<Report> = latest
            .iter()
            .flatten()
            .filter(|s| paced.is_some() || s.header.tick == k)
            .map(|s| Report {
                id: s.header.sender,
                tick: s.header.tick,
                position: to_vec3(&s.position),
                velocity: to_vec3(&s.velocity),
                measurement: s.measurement,
            })
            .collect();
        let command = planner.step(k, &reports, &reports, dt)?;
        recorder.inputs(k, &reports, &reports)?;
        recorder.tick(k, &reports, &command)?;

        seq += 1;
        let b = &mut *body;
        b.header = Header {
            sender: Header::COORDINATOR,
            flags: if command.holding {
                BodyCommand::HOLDING
            } else {
                0
            },
            tick: k,
            t: k as f64 * dt,
            seq,
            sent_ns: 0,
        };
        b.s = command.body.s;
        b.sdot = command.sdot;
        b.r = from_vec3(&command.body.r);
        b.scale = command.body.scale;
        b.inter = [command.inter.alpha, command.inter.d0, command.inter.d1];
        b.leader = [command.leader.alpha, command.leader.d0, command.leader.d1];
        b.damping = command.damping;
        let n_l = command.leaders.len().min(MAX_LEADERS);
        b.n_leaders = n_l as u32;
        for (slot, l) in b.leaders.iter_mut().zip(&command.leaders[..n_l]) {
            *slot = from_vec3(l);
        }
        b.n_vehicles = reports.len() as u32;
        for (slot, q) in b.snapshot.iter_mut().zip(&reports) {
            *slot = SnapshotEntry {
                id: q.id,
                alive: 1,
                position: from_vec3(&q.position),
                velocity: from_vec3(&q.velocity),
            };
        }
        b.header.sent_ns = wall_ns();
        body_pub
            .send_copy(*b)
            .map_err(|e| anyhow::anyhow!("publishing the body: {e:?}"))?;
        counters.messages.sent += 1;
        for notifier in &notifiers {
            let _ = notifier.notify();
        }
        k += 1;
    }

    // Tell everyone the mission is over.
    seq += 1;
    body.header = Header {
        sender: Header::COORDINATOR,
        flags: BodyCommand::FINISHED,
        tick: k,
        t: k as f64 * dt,
        seq,
        sent_ns: wall_ns(),
    };
    body.n_leaders = 0;
    body.n_vehicles = 0;
    let _ = body_pub.send_copy(*body);
    for notifier in &notifiers {
        let _ = notifier.notify();
    }
    let _ = field_notifier.notify();

    recorder.flush()?;
    let mut summary = recorder.summary(&planner, "multi-process");
    summary.messages = counters.messages;
    summary.late_ticks = counters.late_ticks;
    summary.write(dir).context("writing summary.json")?;
    if let Err(e) = recorder.write_plot() {
        warn!(error = %e, "plot failed");
    }
    info!(
        ticks = k,
        stopped,
        delivered = counters.messages.delivered,
        rejected = counters.messages.rejected,
        late_ticks = counters.late_ticks,
        "coordinator done"
    );
    Ok(())
}
