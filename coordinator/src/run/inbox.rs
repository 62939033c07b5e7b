//! The states the coordinator received: drained from the vehicles' subscribers,
//! validated, kept by vehicle and tick until a tick uses them; what it knows of each
//! vehicle's process; the join requests of new processes.

use std::collections::{BTreeMap, BTreeSet};
use std::time::Instant;

use anyhow::Result;
use tracing::{debug, info, warn};
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::Header;
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::topics::{self, Limits};
use vbap_mission::rundir::MessageCounts;

use crate::fleet::Fleet;

/// A vehicle's state subscriber.
pub(super) type StateSubscriber =
    iceoryx2::port::subscriber::Subscriber<iceoryx2::prelude::ipc::Service, VehicleState, ()>;

/// What the coordinator knows of each vehicle's process.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Peer {
    pub pid: u32,
    /// Incarnation of the process [`Peer::pid`] (`VehicleState::incarnation`; 0: unknown).
    pub incarnation: u32,
    pub last_seq: Option<u64>,
    /// The newest tick whose state of this vehicle a tick has used ([`Inbox::used`]): a
    /// state of it or of an older tick is never kept again, whatever its sequence number
    /// (an agent re-sends its recent states, under new numbers, to a restarted
    /// coordinator; the one of a tick already used must not be used for another tick).
    pub used_tick: Option<u64>,
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
    /// Commands an agent's body subscriber holds unread (`Limits::body_buffer`).
    body_buffer: u64,
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
            body_buffer: Limits::for_fleet(n).body_buffer() as u64,
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
    /// deadline is dead-reckoned from its last report). The tick of the state each vehicle
    /// had for tick `k` (the one [`Inbox::state`] gave) becomes its [`Peer::used_tick`].
    pub fn used(&mut self, k: u64, paced: bool) {
        for (&v, states) in self.states.iter_mut() {
            let used = if paced {
                states.keys().next_back().copied()
            } else {
                states.contains_key(&k).then_some(k)
            };
            if let Some(tick) = used {
                let peer = &mut self.peers[v as usize];
                peer.used_tick = peer.used_tick.max(Some(tick));
            }
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
        // Acknowledgements and join requests are the protocol's, not reports the link
        // model carries (the simulator's rejoin sends none): hops of their own, outside
        // the summary's `messages`.
        let hop = if h.flags & VehicleState::ACK != 0 {
            "state_ack"
        } else if h.flags & VehicleState::JOINING != 0 {
            "join"
        } else {
            "state"
        };
        // Its size as the vehicle's own link would carry it (`vbap_ipc::compact`).
        let bytes = vbap_ipc::compact::StateReport::LEN as u64;
        self.msgs
            .recv_now_sized(hop, &h, Header::COORDINATOR, bytes);
        let peer = &mut self.peers[id as usize];
        let joining = h.flags & VehicleState::JOINING != 0;
        let (new_process, older) = identify(peer, &s, joining || fleet.is_lost(id));
        let replay = !new_process && peer.last_seq.is_some_and(|q| h.seq <= q);
        // Lockstep agents may run ahead by LOOKAHEAD_TICKS.
        let future = h.tick > k + 1 + Limits::LOOKAHEAD_TICKS;
        if h.sender != id || replay || future || older || !s.is_finite() {
            self.counts.rejected += 1;
            warn!(
                vehicle = id,
                sender = h.sender,
                tick = h.tick,
                seq = h.seq,
                replay,
                future,
                older_incarnation = older,
                finite = s.is_finite(),
                "rejected a state"
            );
            return;
        }
        peer.last_seq = Some(h.seq);
        peer.pid = s.pid;
        peer.incarnation = peer.incarnation.max(s.incarnation);
        if new_process {
            peer.restart_gap_ms = peer.last_recv.map(|t| t.elapsed().as_secs_f64() * 1e3);
        }
        peer.last_recv = Some(Instant::now());
        peer.commands_read = if new_process {
            s.commands_read
        } else {
            peer.commands_read.max(s.commands_read)
        };
        if new_process {
            // Whatever it says, an acknowledgement included: a lost process continued
            // after a stop may only acknowledge the commands it finds (it cannot step on
            // them, the one it waited for having overflowed its buffer).
            info!(vehicle = id, tick = h.tick, pid = s.pid, "join request");
            peer.join_request = Some(Instant::now());
            self.joins.insert(id);
            self.states.remove(&id);
            return;
        }
        if h.flags & VehicleState::ACK != 0 || joining || fleet.is_lost(id) {
            return; // only what the agent has read; or a request already taken
        }
        if !fleet.is_alive(id) {
            return;
        }
        self.counts.delivered += 1;
        if self.peers[id as usize]
            .used_tick
            .is_some_and(|u| h.tick <= u)
        {
            // A state of a tick already used (re-sent to a restarted coordinator): the
            // tick's state is used once, never for a later tick as if it were new.
            debug!(
                vehicle = id,
                tick = h.tick,
                seq = h.seq,
                "a state of a tick already used: not kept"
            );
            return;
        }
        self.states.entry(id).or_default().insert(h.tick, s);
    }

    /// The incarnation of the process the coordinator takes as vehicle `v`'s (0: unknown).
    pub fn incarnation(&self, v: u32) -> u32 {
        self.peers.get(v as usize).map_or(0, |p| p.incarnation)
    }

    /// Lockstep, command `k` just published: whether vehicle `v`'s agent must be woken for
    /// it. Not when it runs ahead (its state of tick k + 2 or later is in: it needs no
    /// command to step for now) and at most `Limits::body_buffer` − 2 commands are unread
    /// (it is woken for the next one at the latest, before [`Inbox::behind`] could hold).
    /// Results do not change (an agent steps on what its commands say, whenever it reads
    /// them); a submerged glider is woken every few ticks instead of every tick.
    pub fn needs_wake(&self, v: u32, k: u64) -> bool {
        let ahead = self
            .states
            .get(&v)
            .and_then(|m| m.keys().next_back())
            .is_some_and(|&t| t >= k + 2);
        let unread = (k + 1).saturating_sub(self.peers[v as usize].commands_read);
        !ahead || unread + 2 > self.body_buffer
    }

    /// True when publishing command `k` could overflow the command buffer of vehicle `v`'s
    /// agent, which ran ahead and reads late (lockstep flow control).
    pub fn behind(&self, v: u32, k: u64) -> bool {
        let unread = k.saturating_sub(self.peers[v as usize].commands_read) + 1;
        unread > self.body_buffer
    }
}

/// Who sent state `s`, against what the coordinator knows of the vehicle's process
/// (`peer`): (a new process, the last words of an older one). A new process is another pid
/// that asks to join (`asks`: flagged `JOINING`, or any state of a vehicle that is lost),
/// or a later incarnation than the one known, whatever it says: a process restarted
/// faster than its death was noticed is a loss and a rejoin, never a silent swap. A state
/// of an earlier incarnation than the one known comes from a process already replaced.
/// Incarnation 0 (unknown) is neither.
fn identify(peer: &Peer, s: &VehicleState, asks: bool) -> (bool, bool) {
    let known = peer.incarnation;
    let later = known != 0 && s.incarnation > known;
    let older = s.incarnation != 0 && s.incarnation < known;
    let new_process = !older && s.pid != peer.pid && (asks || later);
    (new_process, older)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vbap_mission::config::Mission;

    fn mission() -> Mission {
        Mission::from_toml_str(
            "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 3\n",
            "<test>",
        )
        .unwrap()
    }

    /// Vehicle `id`'s state of tick `tick` under sequence number `seq`, at x = `x`.
    fn state(id: u32, tick: u64, seq: u64, x: f64) -> VehicleState {
        VehicleState {
            header: Header {
                sender: id,
                flags: 0,
                tick,
                t: tick as f64 * 0.05,
                seq,
                sent_ns: 0,
            },
            pid: 100 + id,
            incarnation: 0,
            position: [x, 0.0, 0.0],
            velocity: [0.0; 3],
            commands_read: tick,
            ..VehicleState::default()
        }
    }

    fn setup() -> (Inbox, Fleet) {
        let m = mission();
        let fleet = Fleet::new(&m, &[0, 1, 2]);
        (Inbox::new(3, MsgLog::disabled()), fleet)
    }

    /// Paced: the re-sent copy of a state already used (same tick, a newer sequence
    /// number) is not kept, so the next tick cannot use it again; a state of a newer
    /// tick still is.
    #[test]
    fn paced_a_resent_state_of_a_used_tick_is_not_used_again() {
        let (mut inbox, fleet) = setup();
        inbox.take_in(2, state(2, 309, 7, 1.0), &fleet, 309);
        inbox.take_in(2, state(2, 310, 8, 2.0), &fleet, 309);
        // Tick 309 uses the newest state: that of tick 310.
        assert_eq!(inbox.state(2, 309, true).unwrap().header.tick, 310);
        inbox.used(309, true);
        assert_eq!(inbox.peers[2].used_tick, Some(310));
        // The agent re-sends states 309 and 310 under new sequence numbers.
        inbox.take_in(2, state(2, 309, 9, 1.0), &fleet, 310);
        inbox.take_in(2, state(2, 310, 10, 2.0), &fleet, 310);
        assert!(
            inbox.state(2, 310, true).is_none(),
            "tick 310 must not use the state of tick 310 again"
        );
        // Not a rejection: they arrived and were counted, only not kept.
        assert_eq!(inbox.counts.rejected, 0);
        assert_eq!(inbox.counts.delivered, 4);
        // The next state of a new tick is taken.
        inbox.take_in(2, state(2, 311, 11, 3.0), &fleet, 310);
        assert_eq!(inbox.state(2, 310, true).unwrap().header.tick, 311);
        // Other vehicles are not affected by vehicle 2's mark.
        inbox.take_in(1, state(1, 305, 1, 0.0), &fleet, 310);
        assert_eq!(inbox.state(1, 310, true).unwrap().header.tick, 305);
    }

    /// Lockstep: the state of tick k is used at tick k only; a copy of it arriving
    /// later is not kept, while the states of later ticks already in stay.
    #[test]
    fn lockstep_a_state_is_used_at_its_own_tick_only() {
        let (mut inbox, fleet) = setup();
        inbox.take_in(0, state(0, 4, 1, 0.0), &fleet, 4);
        inbox.take_in(0, state(0, 5, 2, 0.0), &fleet, 4);
        assert_eq!(inbox.state(0, 4, false).unwrap().header.tick, 4);
        inbox.used(4, false);
        assert_eq!(inbox.peers[0].used_tick, Some(4));
        assert!(inbox.state(0, 4, false).is_none());
        inbox.take_in(0, state(0, 4, 3, 0.0), &fleet, 5);
        assert!(inbox.state(0, 4, false).is_none());
        assert_eq!(inbox.state(0, 5, false).unwrap().header.tick, 5);
        // A vehicle with no state of tick 4 gets no mark.
        assert_eq!(inbox.peers[1].used_tick, None);
    }

    /// A process restarted faster than its death was noticed: its first state comes from
    /// a later incarnation, unflagged even (an agent that read an old admission), while
    /// the vehicle is still a member. It is a new process (a join request: the loss and
    /// the rejoin follow), never a silent swap; the dead process's last words, read after
    /// it, are rejected.
    #[test]
    fn a_later_incarnation_is_a_new_process_and_an_earlier_one_is_rejected() {
        let (mut inbox, fleet) = setup();
        let of = |inc: u32, pid: u32, tick: u64, seq: u64| VehicleState {
            incarnation: inc,
            pid,
            ..state(1, tick, seq, 0.0)
        };
        inbox.take_in(1, of(1, 500, 10, 40), &fleet, 10);
        assert_eq!(inbox.incarnation(1), 1);
        assert!(inbox.joins.is_empty());
        // The new process: incarnation 2, a new pid, sequence numbers from 1.
        inbox.take_in(1, of(2, 501, 11, 1), &fleet, 11);
        assert!(inbox.joins.contains(&1), "a new process asks to join");
        assert_eq!(inbox.incarnation(1), 2);
        assert_eq!(inbox.peers[1].pid, 501);
        assert!(
            inbox.state(1, 11, false).is_none(),
            "not a report of the tick"
        );
        // The old one's last state, read late.
        let rejected = inbox.counts.rejected;
        inbox.take_in(1, of(1, 500, 11, 41), &fleet, 11);
        assert_eq!(inbox.counts.rejected, rejected + 1);
        assert_eq!(inbox.peers[1].pid, 501, "the old process is not taken back");
        // Unknown incarnations (agents started by hand) keep the pid rule.
        inbox.take_in(2, of(0, 600, 10, 1), &fleet, 10);
        inbox.take_in(2, of(0, 601, 11, 1), &fleet, 11);
        assert!(!inbox.joins.contains(&2));
    }

    /// A member lost while its process lived on (stopped, then continued): the coordinator
    /// forgot its pid, so whatever the process says next is a join request, an
    /// acknowledgement of the commands it finds included (all a lockstep agent whose next
    /// command overflowed its buffer sends). Before, the acknowledgement took the pid back
    /// without a request, and the process was never readmitted.
    #[test]
    fn a_lost_process_that_only_acknowledges_asks_to_join() {
        let (mut inbox, mut fleet) = setup();
        inbox.take_in(1, state(1, 10, 40, 0.0), &fleet, 10);
        assert!(fleet.lose(1).is_some());
        inbox.peers[1].pid = 0;
        let ack = VehicleState {
            header: Header {
                flags: VehicleState::ACK,
                ..state(1, 10, 41, 0.0).header
            },
            commands_read: 30,
            ..state(1, 10, 41, 0.0)
        };
        inbox.take_in(1, ack, &fleet, 30);
        assert!(inbox.joins.contains(&1), "the lost process asks to join");
        assert_eq!(inbox.peers[1].pid, 101);
        assert!(inbox.state(1, 10, false).is_none());
    }

    /// A replay (a sequence number not above the last one) is still rejected as such.
    #[test]
    fn a_replayed_sequence_number_is_rejected() {
        let (mut inbox, fleet) = setup();
        inbox.take_in(0, state(0, 1, 5, 0.0), &fleet, 1);
        inbox.take_in(0, state(0, 2, 5, 0.0), &fleet, 1);
        assert_eq!(inbox.counts.rejected, 1);
        assert!(inbox.state(0, 2, false).is_none());
    }
}
