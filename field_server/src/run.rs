//! The field-server process: answers the coordinator's batched sensor reads when woken.
//!
//! One request per tick carries every vehicle's sensor read (vehicle, tick, time,
//! position); the reply carries the readings in the same order. The field server simulates
//! the sensors too: each reading is the field plus the keyed noise of (seed, vehicle,
//! tick), with the mission's sensor faults applied (a stuck sensor remembers its last good
//! reading here, across restarts of the vehicle's process, as a sensor would).

use std::time::Duration;

use anyhow::Result;
use iceoryx2::prelude::*;
use tracing::{info, warn};
use vbap_ipc::msg::coordinator_to_field::SampleBatch;
use vbap_ipc::msg::field_to_coordinator::{Reading, ReadingBatch};
use vbap_ipc::msg::{to_vec3, wall_ns, Header};
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::topics::{self, wait_for_wake, Domain, Limits, Wake};
use vbap_mission::config::Mission;

use crate::Sensors;

/// Wall time without any event after which the request port is polled once.
const FALLBACK_POLL: Duration = Duration::from_millis(100);

/// Serves `mission`'s field until the mission ends or a termination signal.
/// `on_ready` is called once every port exists; `msgs` receives the message records.
pub fn run(mission: &Mission, mut msgs: MsgLog, on_ready: impl FnOnce()) -> Result<()> {
    let domain = Domain::new(&mission.mission.name)?;
    let limits = Limits::for_fleet(mission.vehicles.count);
    let node = domain.node(topics::FIELD_SERVER_NODE)?;
    let server = domain
        .sample_service(&node, &limits)?
        .server_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("creating the sample server: {e:?}"))?;
    let wake = domain
        .field_wake(&node, &limits)?
        .listener_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("creating the field wake listener: {e:?}"))?;
    let coordinator = domain
        .coordinator_wake(&node, &limits)?
        .notifier_builder()
        .default_event_id(topics::EVENT_SAMPLE)
        .create()
        .map_err(|e| anyhow::anyhow!("creating the coordinator notifier: {e:?}"))?;
    let body_sub = domain
        .body_service(&node, &limits)?
        .subscriber_builder()
        .create()
        .map_err(|e| anyhow::anyhow!("subscribing to the body: {e:?}"))?;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<ipc::Service>()
        .map_err(|e| anyhow::anyhow!("creating the waitset: {e:?}"))?;
    let _guard = waitset
        .attach_notification(&wake)
        .map_err(|e| anyhow::anyhow!("attaching: {e:?}"))?;
    let mut sensors = Sensors::new(mission);
    let n = mission.vehicles.count as u32;
    let mut seq = 0u64;
    let mut served = 0u64;
    let mut rejected = 0u64;
    let mut reply = Box::new(ReadingBatch::empty());
    info!(vehicles = n, "field server up");
    on_ready();
    // Tell the coordinator a server is there: after a restart, the request the dead server
    // never answered is sent again at once (a request reaches only the servers connected
    // when it is sent).
    coordinator
        .notify_with_custom_event_id(topics::EVENT_FIELD_UP)
        .map_err(|e| anyhow::anyhow!("waking the coordinator: {e:?}"))?;
    loop {
        // A deadline as a safety net: with no event for FALLBACK_POLL, poll the port once
        // (a lost wake-up costs at most that, never a stall).
        if wait_for_wake(&waitset, &wake, FALLBACK_POLL)? == Wake::Stop {
            break;
        }
        while let Some(request) = server
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving a request: {e:?}"))?
        {
            let batch: &SampleBatch = &request;
            let h = batch.header;
            msgs.recv_now("field_request", &h, Header::FIELD_SERVER);
            let from_coordinator = h.sender == Header::COORDINATOR;
            reply.n = 0;
            for read in batch.reads() {
                // The coordinator reads ahead, at most as far as agents may run ahead.
                let in_reach = read.tick <= h.tick + 2 + Limits::LOOKAHEAD_TICKS;
                let value = if from_coordinator && in_reach {
                    sensors.read(read.vehicle, read.tick, read.t, &to_vec3(&read.position))
                } else {
                    None
                };
                if value.is_none() {
                    rejected += 1;
                    warn!(
                        sender = h.sender,
                        vehicle = read.vehicle,
                        tick = read.tick,
                        rejected,
                        "rejected a sensor read"
                    );
                }
                reply.readings[reply.n as usize] = Reading {
                    vehicle: read.vehicle,
                    rejected: u32::from(value.is_none()),
                    tick: read.tick,
                    value: value.unwrap_or(f64::NAN),
                };
                reply.n += 1;
            }
            seq += 1;
            reply.header = Header {
                sender: Header::FIELD_SERVER,
                flags: 0,
                tick: h.tick,
                t: h.t,
                seq,
                sent_ns: wall_ns(),
            };
            reply.request_seq = h.seq;
            served += u64::from(reply.n);
            // A reply to a client that died meanwhile is lost, which is fine.
            let _ = request.send_copy(*reply);
            let _ = coordinator.notify();
        }
        let mut finished = false;
        while let Some(sample) = body_sub
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving the body: {e:?}"))?
        {
            if sample.header.sender == Header::COORDINATOR
                && sample.header.flags & vbap_ipc::msg::coordinator_to_agent::BodyCommand::FINISHED
                    != 0
            {
                finished = true;
            }
        }
        if finished {
            break;
        }
    }
    msgs.flush();
    info!(served, rejected, "field server done");
    Ok(())
}
