//! The states the coordinator received: drained from the vehicles' subscribers,
//! validated, kept by vehicle and tick until a tick uses them; what it knows of each
//! vehicle's process; the join requests of new processes.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use anyhow::Result;
use tracing::{info, warn};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::Header;
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::topics::{self, Limits};
use vbap_mission::rundir::MessageCounts;

use super::ports::StateSubscriber;
use crate::fleet::Fleet;

/// What the coordinator knows of each vehicle's process.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Peer {
    pub pid: u32,
    pub last_seq: Option<u64>,
    pub last_recv: Option<Instant>,
    pub join_request: Option<Instant>,
    /// Silence before a new process of this vehicle spoke (its predecessor's last message to
    /// the new one's first), ms: an upper bound of the detection latency of a restart.
    pub restart_gap_ms: Option<f64>,
    /// Commands its agent has read (`VehicleState::commands_read`).
    pub commands_read: u64,
}

/// The coordinator's I/O state, apart from the pure planner and fleet.
pub(super) struct Inbox {
    /// The states received and not used yet, per vehicle by tick (lockstep agents may run
    /// ahead: see `vehicle_agent::Vehicle::ready_to_step`).
    pub states: BTreeMap<u32, BTreeMap<u64, VehicleState>>,
    pub peers: Vec<Peer>,
    pub joins: BTreeSet<u32>,
    pub counts: MessageCounts,
    pub msgs: MsgLog,
}

impl Inbox {
    /// An empty inbox for `n` vehicles, its message records going to `msgs`.
    pub fn new(n: usize, msgs: MsgLog) -> Self {
        Self {
            states: BTreeMap::new(),
            peers: vec![Peer::default(); n],
            joins: BTreeSet::new(),
            counts: MessageCounts::default(),
            msgs,
        }
    }

    /// Vehicle `v`'s state for tick `k`: of that very tick in lockstep, the newest one in
    /// paced runs.
    pub fn state(&self, v: u32, k: u64, paced: bool) -> Option<&VehicleState> {
        let states = self.states.get(&v)?;
        if paced {
            states.values().next_back()
        } else {
            states.get(&k)
        }
    }

    /// Forgets the states tick `k` has used (lockstep), or every state (paced: a state is
    /// used once, never again as if it were new; a vehicle with no newer one at the next
    /// deadline is dead-reckoned from its last report).
    pub fn used(&mut self, k: u64, paced: bool) {
        for states in self.states.values_mut() {
            if paced {
                states.clear();
            } else {
                *states = states.split_off(&(k + 1));
            }
        }
    }

    /// Drains every state subscriber; validates; keeps the states of alive vehicles by tick
    /// and the join requests.
    pub fn drain(&mut self, subscribers: &[StateSubscriber], fleet: &Fleet, k: u64) -> Result<()> {
        self.drain_some(subscribers, fleet, k, None)
    }

    /// [`Inbox::drain`] of the subscribers whose vehicles woke us (`woken`: event ids),
    /// or of all of them.
    pub fn drain_some(
        &mut self,
        subscribers: &[StateSubscriber],
        fleet: &Fleet,
        k: u64,
        woken: Option<&[usize]>,
    ) -> Result<()> {
        let selected: Vec<usize> = match woken {
            None => (0..subscribers.len()).collect(),
            Some(ids) => {
                let mut v: Vec<usize> = ids
                    .iter()
                    .filter_map(|e| e.checked_sub(topics::EVENT_VEHICLE_BASE))
                    .filter(|i| *i < subscribers.len())
                    .collect();
                v.sort_unstable();
                v.dedup();
                v
            }
        };
        for id in selected {
            let sub = &subscribers[id];
            let id = id as u32;
            while let Some(sample) = sub
                .receive()
                .map_err(|e| anyhow::anyhow!("receiving state {id}: {e:?}"))?
            {
                self.take_in(id, *sample, fleet, k);
            }
        }
        Ok(())
    }

    /// Takes in state `s` read from vehicle `id`'s subscriber while tick `k` is under way.
    fn take_in(&mut self, id: u32, s: VehicleState, fleet: &Fleet, k: u64) {
        let h = s.header;
        let hop = if h.flags & VehicleState::ACK != 0 {
            "state_ack"
        } else {
            "state"
        };
        self.msgs.recv_now(hop, &h, Header::COORDINATOR);
        let peer = &mut self.peers[id as usize];
        let joining = h.flags & VehicleState::JOINING != 0;
        // A join request comes from a new process (another pid): flagged, or any state of
        // a vehicle that was lost. A lost vehicle's last words from its old process are
        // not one.
        let new_process = s.pid != peer.pid && (joining || fleet.is_lost(id));
        let replay = !new_process && peer.last_seq.is_some_and(|q| h.seq <= q);
        // Lockstep agents may run ahead by LOOKAHEAD_TICKS.
        let future = h.tick > k + 1 + Limits::LOOKAHEAD_TICKS;
        if h.sender != id || replay || future || !s.is_finite() {
            self.counts.rejected += 1;
            warn!(
                vehicle = id,
                sender = h.sender,
                tick = h.tick,
                seq = h.seq,
                replay,
                future,
                finite = s.is_finite(),
                "rejected a state"
            );
            return;
        }
        peer.last_seq = Some(h.seq);
        peer.pid = s.pid;
        if new_process {
            peer.restart_gap_ms = peer.last_recv.map(|t| t.elapsed().as_secs_f64() * 1e3);
        }
        peer.last_recv = Some(Instant::now());
        peer.commands_read = if new_process {
            s.commands_read
        } else {
            peer.commands_read.max(s.commands_read)
        };
        if h.flags & VehicleState::ACK != 0 {
            return; // no new state, only what the agent has read
        }
        if joining || fleet.is_lost(id) {
            if new_process {
                info!(vehicle = id, tick = h.tick, pid = s.pid, "join request");
                peer.join_request = Some(Instant::now());
                self.joins.insert(id);
                self.states.remove(&id);
            }
            return;
        }
        if !fleet.is_alive(id) {
            return;
        }
        self.counts.delivered += 1;
        self.states.entry(id).or_default().insert(h.tick, s);
    }

    /// True when publishing command `k` could overflow the command buffer of vehicle `v`'s
    /// agent, which ran ahead and reads late (lockstep flow control).
    pub fn behind(&self, v: u32, k: u64) -> bool {
        let unread = k.saturating_sub(self.peers[v as usize].commands_read) + 1;
        unread > Limits::BODY_BUFFER as u64
    }
}
