//! The agent's acoustic modem over IPC (`[acoustic]`): it publishes its vehicle's frames on
//! `<m>/acoustic` and hands every other vehicle's to the vehicle's receiver
//! (`vbap_mission::acoustic::Ear`), which decides in mission time what is heard.
//!
//! No wake-up of its own: in lockstep every frame a step needs is published before its
//! sender's state of the same tick, hence before the command that lets the step go
//! (`Pilot::lockstep_step`), and the agent drains the modem after every command.

use std::collections::BTreeMap;

use anyhow::Result;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::ipc;
use tracing::warn;
use vbap_ipc::msg::agent_to_agent::AcousticFrame;
use vbap_ipc::msg::{from_vec3, to_vec3, Header};
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::ports::{notifier, publisher, subscriber};
use vbap_ipc::topics::{Domain, Limits};
use vbap_ipc::wait::Event;
use vbap_mission::acoustic::{Frame, Verdict};

use crate::Vehicle;

/// The hop name of acoustic frames in the message records.
pub const HOP: &str = "acoustic";

/// One agent's side of the acoustic service.
pub struct Modem {
    id: u32,
    out: Publisher<ipc::Service, AcousticFrame, ()>,
    inbox: Subscriber<ipc::Service, AcousticFrame, ()>,
    /// Every other agent's wake service (a frame wakes its receivers).
    peers: Vec<Notifier<ipc::Service>>,
    seq: u64,
    /// The newest sequence number read from each sender (gaps: frames lost to a full
    /// buffer).
    last: BTreeMap<u32, u64>,
    /// Frames lost to a full buffer (gaps in a sender's sequence numbers).
    pub overflow: u64,
}

impl Modem {
    /// The modem of vehicle `id` on `domain`'s acoustic service.
    pub fn open(
        domain: &Domain,
        node: &iceoryx2::node::Node<ipc::Service>,
        id: u32,
        limits: &Limits,
    ) -> Result<Self> {
        let service = domain.acoustic_service(node, limits)?;
        let peers = (0..limits.vehicles as u32)
            .filter(|&p| p != id)
            .map(|p| notifier(&domain.vehicle_wake(node, p, limits)?, Event::Data))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            id,
            out: publisher(&service)?,
            inbox: subscriber(&service)?,
            peers,
            seq: 0,
            last: BTreeMap::new(),
            overflow: 0,
        })
    }

    /// The vehicle was admitted back: the frames read from now on are its new receiver's
    /// (those left in the buffer meanwhile leave gaps that are not losses).
    pub fn rejoined(&mut self) {
        self.last.clear();
    }

    /// Sends the frames `vehicle` transmits during tick `k` (its state being that of `k`),
    /// and wakes the other agents.
    pub fn transmit(&mut self, vehicle: &mut Vehicle, k: u64) -> Result<()> {
        let frames = vehicle.transmit(k);
        for f in &frames {
            self.seq += 1;
            let msg = AcousticFrame {
                header: Header::new(self.id, f.tick, f.at, self.seq),
                n: f.n,
                source: from_vec3(&f.source),
                position: from_vec3(&f.position),
                velocity: from_vec3(&f.velocity),
            };
            self.out
                .send_copy(msg)
                .map_err(|e| anyhow::anyhow!("publishing an acoustic frame: {e:?}"))?;
        }
        if !frames.is_empty() {
            for p in &self.peers {
                // A peer that is gone (its listener dropped) is no error.
                let _ = p.notify();
            }
        }
        Ok(())
    }

    /// Hands every frame read to `vehicle`'s receiver (and hands this agent's recent frames
    /// to a subscriber that came late: iceoryx2's history).
    pub fn drain(&mut self, vehicle: &mut Vehicle) -> Result<()> {
        self.out
            .update_connections()
            .map_err(|e| anyhow::anyhow!("acoustic publisher: {e:?}"))?;
        let Some(ear) = vehicle.ear_mut() else {
            return Ok(());
        };
        while let Some(sample) = self
            .inbox
            .receive()
            .map_err(|e| anyhow::anyhow!("reading acoustic frames: {e:?}"))?
        {
            let m = *sample.payload();
            let h = m.header;
            if h.sender == self.id {
                continue;
            }
            let last = self.last.entry(h.sender).or_insert(0);
            if h.seq > *last + 1 && *last > 0 {
                self.overflow += h.seq - *last - 1;
                warn!(
                    vehicle = self.id,
                    sender = h.sender,
                    lost = h.seq - *last - 1,
                    "acoustic frames lost to a full buffer"
                );
            }
            *last = (*last).max(h.seq);
            ear.hear(Frame {
                sender: h.sender,
                n: m.n,
                tick: h.tick,
                at: h.t,
                source: to_vec3(&m.source),
                position: to_vec3(&m.position),
                velocity: to_vec3(&m.velocity),
            });
        }
        Ok(())
    }
}

/// Writes the verdicts `vehicle`'s receiver reached since the last call to the message
/// records: `held` with the latency for a frame heard, `drop` with the verdict otherwise.
pub fn log_verdicts(vehicle: &mut Vehicle, msgs: &mut MsgLog) {
    let me = vehicle.agent.id;
    let Some(ear) = vehicle.ear_mut() else {
        return;
    };
    for (sender, tick, verdict) in ear.take_verdicts() {
        match verdict {
            Verdict::Heard { latency } => msgs.held(HOP, sender, me, tick, latency),
            other => msgs.drop(HOP, sender, me, tick, other.as_str()),
        }
    }
}
