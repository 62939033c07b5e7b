//! The field-server process: answers the coordinator's batched sensor reads when woken.
//!
//! One request per tick carries every vehicle's sensor read (vehicle, tick, time,
//! position); the reply carries the readings in the same order. The field server simulates
//! the sensors too: each reading is the field plus the keyed noise of (seed, vehicle,
//! tick), with the mission's sensor faults applied (a stuck sensor remembers its last good
//! reading here, across restarts of the vehicle's process, as a sensor would).

use std::time::Duration;

use anyhow::Result;
use iceoryx2::node::Node;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::server::Server;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::ipc;
use tracing::{info, warn};
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::coordinator_to_field::SampleBatch;
use vbap_ipc::msg::field_to_coordinator::{Reading, ReadingBatch};
use vbap_ipc::msg::{to_vec3, Header};
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::ports;
use vbap_ipc::topics::{self, Domain, Limits};
use vbap_ipc::wait::{Event, Wake, WakeListener};
use vbap_mission::config::Mission;

use crate::Sensors;

/// Wall time without any event after which the request port is polled once.
const FALLBACK_POLL: Duration = Duration::from_millis(100);

/// The field server's ports.
struct Ports {
    /// Answers the coordinator's sample batches.
    server: Server<ipc::Service, SampleBatch, (), ReadingBatch, ()>,
    /// Woken by the coordinator when a batch was sent.
    wake: WakeListener,
    /// Wakes the coordinator: readings ready, or a field server is up.
    coordinator: Notifier<ipc::Service>,
    /// The body commands, read for the end of the mission only.
    body: Subscriber<ipc::Service, BodyCommand, ()>,
}

impl Ports {
    fn open(domain: &Domain, node: &Node<ipc::Service>, limits: &Limits) -> Result<Self> {
        let server = domain
            .sample_service(node, limits)?
            .server_builder()
            .create()
            .map_err(|e| anyhow::anyhow!("creating the sample server: {e:?}"))?;
        Ok(Self {
            server,
            wake: WakeListener::new(&domain.field_wake(node, limits)?)?,
            coordinator: ports::notifier(&domain.coordinator_wake(node, limits)?, Event::Sample)?,
            body: ports::subscriber(&domain.body_service(node, limits)?)?,
        })
    }

    /// True when the coordinator has published the mission's final command.
    fn mission_finished(&self) -> Result<bool> {
        let mut finished = false;
        while let Some(sample) = self
            .body
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving the body: {e:?}"))?
        {
            if sample.header.sender == Header::COORDINATOR
                && sample.header.flags & BodyCommand::FINISHED != 0
            {
                finished = true;
            }
        }
        Ok(finished)
    }
}

/// The serving side: the sensors, the reply buffer and the counters.
struct Service {
    sensors: Sensors,
    reply: Box<ReadingBatch>,
    seq: u64,
    served: u64,
    rejected: u64,
}

impl Service {
    /// Answers every request waiting at `ports.server`, waking the coordinator after each.
    fn serve_all(&mut self, ports: &Ports, msgs: &mut MsgLog) -> Result<()> {
        while let Some(request) = ports
            .server
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving a request: {e:?}"))?
        {
            let batch: &SampleBatch = &request;
            msgs.recv_now("field_request", &batch.header, Header::FIELD_SERVER);
            self.answer(batch);
            // A reply to a client that died meanwhile is lost, which is fine.
            let _ = vbap_ipc::prefix::respond(&request, &*self.reply);
            let _ = ports.coordinator.notify();
        }
        Ok(())
    }

    /// Fills the reply to `batch`: a reading per read, in order, rejected (NaN) for a read
    /// not from the coordinator, out of reach or at a non-finite position.
    fn answer(&mut self, batch: &SampleBatch) {
        let h = batch.header;
        let from_coordinator = h.sender == Header::COORDINATOR;
        let reply = &mut self.reply;
        reply.n = 0;
        for read in batch.reads() {
            // The coordinator reads ahead, at most as far as agents may run ahead.
            let in_reach = read.tick <= h.tick + 2 + Limits::LOOKAHEAD_TICKS;
            let value = if from_coordinator && in_reach {
                self.sensors
                    .read(read.vehicle, read.tick, read.t, &to_vec3(&read.position))
            } else {
                None
            };
            if value.is_none() {
                self.rejected += 1;
                warn!(
                    sender = h.sender,
                    vehicle = read.vehicle,
                    tick = read.tick,
                    rejected = self.rejected,
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
        self.seq += 1;
        reply.header = Header::new(Header::FIELD_SERVER, h.tick, h.t, self.seq);
        reply.request_seq = h.seq;
        self.served += u64::from(reply.n);
    }
}

/// Serves `mission`'s field until the mission ends or a termination signal.
/// `on_ready` is called once every port exists; `msgs` receives the message records.
pub fn run(mission: &Mission, msgs: MsgLog, on_ready: impl FnOnce()) -> Result<()> {
    run_with(mission, Sensors::new(mission), msgs, on_ready)
}

/// [`run`] with `sensors` (e.g. over a user's own field: [`crate::World::with_field`]).
pub fn run_with(
    mission: &Mission,
    sensors: Sensors,
    mut msgs: MsgLog,
    on_ready: impl FnOnce(),
) -> Result<()> {
    let domain = Domain::new(&mission.mission.name)?;
    let limits = Limits::for_fleet(mission.vehicles.count);
    let node = domain.node(topics::FIELD_SERVER_NODE)?;
    let ports = Ports::open(&domain, &node, &limits)?;
    let waiter = ports.wake.attach()?;
    let mut service = Service {
        sensors,
        reply: Box::new(ReadingBatch::empty()),
        seq: 0,
        served: 0,
        rejected: 0,
    };
    info!(vehicles = mission.vehicles.count, "field server up");
    on_ready();
    // Tell the coordinator a server is there: after a restart, the request the dead server
    // never answered is sent again at once (a request reaches only the servers connected
    // when it is sent).
    ports
        .coordinator
        .notify_with_custom_event_id(Event::FieldUp.id())
        .map_err(|e| anyhow::anyhow!("waking the coordinator: {e:?}"))?;
    loop {
        // A deadline as a safety net: with no event for FALLBACK_POLL, poll the port once
        // (a lost wake-up costs at most that, never a stall).
        if waiter.wait(FALLBACK_POLL, |_| {})? == Wake::Stop {
            break;
        }
        service.serve_all(&ports, &mut msgs)?;
        if ports.mission_finished()? {
            break;
        }
    }
    msgs.flush();
    info!(
        served = service.served,
        rejected = service.rejected,
        "field server done"
    );
    Ok(())
}
