//! The field-server process: answers every pending sample request when woken.

use std::collections::BTreeMap;
use std::time::Duration;

use anyhow::Result;
use iceoryx2::prelude::*;
use shared::config::Mission;
use shared::msg::agent_to_field::SampleRequest;
use shared::msg::field_to_agent::SampleReply;
use shared::msg::{to_vec3, wall_ns, Header};
use shared::telemetry::MSG_TARGET;
use shared::topics::{self, wait_for_wake_ids, Domain, Limits, Wake};
use tracing::{debug, info, warn};

use crate::World;

/// Wall time without any event after which every vehicle's port is polled once.
const FALLBACK_POLL: Duration = Duration::from_millis(100);

/// Serves `mission`'s field until the mission ends or a termination signal.
/// `on_ready` is called once every port exists.
pub fn run(mission: &Mission, on_ready: impl FnOnce()) -> Result<()> {
    let domain = Domain::new(&mission.mission.name)?;
    let limits = Limits::for_fleet(mission.vehicles.count);
    let node = domain.node(topics::FIELD_SERVER_NODE)?;
    let mut servers = Vec::with_capacity(mission.vehicles.count);
    for id in 0..mission.vehicles.count as u32 {
        servers.push(
            domain
                .field_service(&node, id, &limits)?
                .server_builder()
                .create()
                .map_err(|e| {
                    anyhow::anyhow!("creating the field server port of vehicle {id}: {e:?}")
                })?,
        );
    }
    let wake = domain
        .field_wake(&node, &limits)?
        .listener_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("creating the field wake listener: {e:?}"))?;
    let body_sub = domain
        .body_service(&node, &limits)?
        .subscriber_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("subscribing to the body: {e:?}"))?;
    // One notifier per vehicle's wake service, opened when first needed.
    let mut notifiers = BTreeMap::new();
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<ipc::Service>()
        .map_err(|e| anyhow::anyhow!("creating the waitset: {e:?}"))?;
    let _guard = waitset
        .attach_notification(&wake)
        .map_err(|e| anyhow::anyhow!("attaching: {e:?}"))?;
    let world = World::new(mission);
    let n = mission.vehicles.count as u32;
    let mut seq = 0u64;
    let mut served = 0u64;
    let mut rejected = 0u64;
    info!(vehicles = n, "field server up");
    on_ready();
    let mut ids = Vec::new();
    loop {
        ids.clear();
        // A deadline as a safety net: with no event for FALLBACK_POLL, poll every port once
        // (a lost wake-up costs at most that, never a stall).
        if wait_for_wake_ids(&waitset, &wake, FALLBACK_POLL, &mut ids)? == Wake::Stop {
            break;
        }
        // Poll the servers of the vehicles that woke us; on anything else, all of them.
        let targeted = !ids.is_empty() && ids.iter().all(|e| *e >= topics::EVENT_VEHICLE_BASE);
        let mut slots: Vec<usize> = if targeted {
            ids.iter()
                .map(|e| e - topics::EVENT_VEHICLE_BASE)
                .filter(|i| *i < servers.len())
                .collect()
        } else {
            (0..servers.len()).collect()
        };
        slots.sort_unstable();
        slots.dedup();
        for &slot in &slots {
            let server = &servers[slot];
            while let Some(request) = server
                .receive()
                .map_err(|e| anyhow::anyhow!("receiving a request: {e:?}"))?
            {
                let req: SampleRequest = *request;
                let h = req.header;
                let recv_ns = wall_ns();
                debug!(target: MSG_TARGET, hop = "field_request", sender = h.sender, tick = h.tick, seq = h.seq,
                   sent_ns = h.sent_ns, recv_ns, "recv");
                let value = if h.sender as usize == slot {
                    world.sample(h.sender, h.tick, h.t, &to_vec3(&req.position))
                } else {
                    None
                };
                if value.is_none() {
                    rejected += 1;
                    warn!(
                        sender = h.sender,
                        tick = h.tick,
                        rejected,
                        "rejected a sample request"
                    );
                }
                seq += 1;
                let reply = SampleReply {
                    header: Header {
                        sender: Header::FIELD_SERVER,
                        flags: 0,
                        tick: h.tick,
                        t: h.t,
                        seq,
                        sent_ns: wall_ns(),
                    },
                    request_seq: h.seq,
                    value: value.unwrap_or(f64::NAN),
                    rejected: u32::from(value.is_none()),
                    _pad: 0,
                };
                request
                    .send_copy(reply)
                    .map_err(|e| anyhow::anyhow!("replying: {e:?}"))?;
                served += 1;
                if h.sender as usize == slot {
                    let notifier = match notifiers.entry(h.sender) {
                        std::collections::btree_map::Entry::Occupied(o) => o.into_mut(),
                        std::collections::btree_map::Entry::Vacant(v) => v.insert(
                            domain
                                .vehicle_wake(&node, h.sender, &limits)?
                                .notifier_builder()
                                .default_event_id(topics::EVENT_SAMPLE)
                                .create()
                                .map_err(|e| {
                                    anyhow::anyhow!("notifier for vehicle {}: {e:?}", h.sender)
                                })?,
                        ),
                    };
                    let _ = notifier.notify();
                }
            }
        }
        let mut finished = false;
        while let Some(sample) = body_sub
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving the body: {e:?}"))?
        {
            if sample.header.sender == Header::COORDINATOR
                && sample.header.flags & shared::msg::coordinator_to_agent::BodyCommand::FINISHED
                    != 0
            {
                finished = true;
            }
        }
        if finished {
            break;
        }
    }
    info!(served, rejected, "field server done");
    Ok(())
}
