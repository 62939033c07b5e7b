//! The coordinator process: gathers states, reads the tick's sensors through the field
//! server (one batched request), applies the link model, detects lost and returning
//! vehicles, applies scheduled kills, steps the planner, publishes the body.

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use iceoryx2::prelude::*;
use shared::config::{Mission, Pace, RestartPolicy};
use shared::faults::FaultPlan;
use shared::link::Fate;
use shared::msg::agent_to_coordinator::VehicleState;
use shared::msg::coordinator_to_agent::BodyCommand;
use shared::msg::coordinator_to_field::{SampleBatch, SensorRead};
use shared::msg::field_to_coordinator::ReadingBatch;
use shared::msg::supervisor_to_coordinator::ProcessExit;
use shared::msg::{from_vec3, to_vec3, wall_ns, Header, MAX_LEADERS, MAX_VEHICLES};
use shared::msglog::MsgLog;
use shared::rundir::{MessageCounts, RunDir};
use shared::topics::{self, wait_for_wake_ids, Domain, Limits, Wake};
use tracing::{debug, info, warn};

use crate::checkpoint::{Checkpoint, CheckpointRef, CheckpointWriter, JournalMarks, PeerMark};
use crate::fleet::Fleet;
use crate::planner::{Planner, PlannerParams, Report};
use crate::record::Recorder;
use crate::tick::{plan_tick, TickOutcome};

/// Wall time a lockstep tick waits for a silent vehicle before going on without it (a
/// vehicle heard from before is then lost as `silent`: see [`SILENCE_LIMIT`]).
pub const LOCKSTEP_TIMEOUT: Duration = Duration::from_secs(10);
/// Wall time a vehicle may be missing from a lockstep gather, or silent in a paced run (and
/// at least [`SUSPECT_TICKS`] tick periods), before the node list is scanned for its
/// process. A wall-clock deadline of the coordinator's own: it does not depend on the tick.
const SUSPECT_AFTER: Duration = Duration::from_millis(50);
/// Tick periods of silence (paced runs) before a vehicle is suspect.
const SUSPECT_TICKS: f64 = 3.0;
/// Least wall time between two node-list scans (one scan costs ~0.2 ms at 6 nodes, ~40 ms
/// at 257). A scan checks every vehicle, so deaths at once are found together.
const LIVENESS_EVERY: Duration = Duration::from_millis(100);
/// Scans take at most 1 / SCAN_SHARE of the coordinator's wall time: the least time
/// between two scans is also SCAN_SHARE times the last scan's cost (large fleets).
const SCAN_SHARE: u32 = 5;
/// Silence tolerated of a vehicle whose process is alive (stopped by SIGSTOP, hung,
/// starved): past it the vehicle is lost (cause `silent`) and the formation redesigned; its
/// process is readmitted as soon as it speaks again (SIGCONT). In lockstep this is the
/// tick's wait.
const SILENCE_LIMIT: Duration = LOCKSTEP_TIMEOUT;
/// How long a scheduled kill waits for the victim's node to be seen dead.
const KILL_TIMEOUT: Duration = Duration::from_secs(5);
/// How long the coordinator waits for the readings of a tick before it wakes the field
/// server again (a lost wake-up must not stall the mission).
const RENOTIFY_AFTER: Duration = Duration::from_millis(500);
/// How long the coordinator waits for the readings of a tick before it sends the request
/// again (a field server restarted unseen: without a supervisor, or its start-up event
/// missed). A restart the supervisor reports is acted on at once.
const RESEND_AFTER: Duration = Duration::from_secs(1);
/// How long the coordinator waits for the readings of a tick before it gives up.
const SAMPLE_TIMEOUT: Duration = Duration::from_secs(10);

/// What the coordinator knows of each vehicle's process.
#[derive(Clone, Copy, Debug, Default)]
struct Peer {
    pid: u32,
    last_seq: Option<u64>,
    last_recv: Option<Instant>,
    join_request: Option<Instant>,
    /// Silence before a new process of this vehicle spoke (its predecessor's last message to
    /// the new one's first), ms: an upper bound of the detection latency of a restart.
    restart_gap_ms: Option<f64>,
    /// Commands its agent has read (`VehicleState::commands_read`).
    commands_read: u64,
}

/// The coordinator's I/O state, apart from the pure planner and fleet.
struct Inbox {
    /// The states received and not used yet, per vehicle by tick (lockstep agents may run
    /// ahead: see `vehicle_agent::Vehicle::ready_to_step`).
    states: BTreeMap<u32, BTreeMap<u64, VehicleState>>,
    peers: Vec<Peer>,
    joins: BTreeSet<u32>,
    counts: MessageCounts,
    msgs: MsgLog,
}

impl Inbox {
    /// Vehicle `v`'s state for tick `k`: of that very tick in lockstep, the newest one in
    /// paced runs.
    fn state(&self, v: u32, k: u64, paced: bool) -> Option<&VehicleState> {
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
    fn used(&mut self, k: u64, paced: bool) {
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
    fn drain(
        &mut self,
        subscribers: &[iceoryx2::port::subscriber::Subscriber<ipc::Service, VehicleState, ()>],
        fleet: &Fleet,
        k: u64,
    ) -> Result<()> {
        self.drain_some(subscribers, fleet, k, None)
    }

    /// [`Inbox::drain`] of the subscribers whose vehicles woke us (`woken`: event ids),
    /// or of all of them.
    fn drain_some(
        &mut self,
        subscribers: &[iceoryx2::port::subscriber::Subscriber<ipc::Service, VehicleState, ()>],
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
                let s: VehicleState = *sample;
                let h = s.header;
                let hop = if h.flags & VehicleState::ACK != 0 {
                    "state_ack"
                } else {
                    "state"
                };
                self.msgs.recv_now(hop, &h, Header::COORDINATOR);
                let peer = &mut self.peers[id as usize];
                let joining = h.flags & VehicleState::JOINING != 0;
                // A join request comes from a new process (another pid): flagged, or any
                // state of a vehicle that was lost. A lost vehicle's last words from its
                // old process are not one.
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
                    continue;
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
                    continue; // no new state, only what the agent has read
                }
                if joining || fleet.is_lost(id) {
                    if new_process {
                        info!(vehicle = id, tick = h.tick, pid = s.pid, "join request");
                        peer.join_request = Some(Instant::now());
                        self.joins.insert(id);
                        self.states.remove(&id);
                    }
                    continue;
                }
                if !fleet.is_alive(id) {
                    continue;
                }
                self.counts.delivered += 1;
                self.states.entry(id).or_default().insert(h.tick, s);
            }
        }
        Ok(())
    }
}

/// The request-response types of the sensor reads.
type SampleResponse =
    iceoryx2::pending_response::PendingResponse<ipc::Service, SampleBatch, (), ReadingBatch, ()>;

/// The client side of the field server's batched sensor reads. It reads ahead: the
/// states of later ticks already in (agents that ran ahead) are read while the coordinator
/// computes, so with lookahead a tick seldom waits for the field server at all.
struct SensorReads {
    client: iceoryx2::port::client::Client<ipc::Service, SampleBatch, (), ReadingBatch, ()>,
    field: iceoryx2::port::notifier::Notifier<ipc::Service>,
    batch: Box<SampleBatch>,
    seq: u64,
    /// The request in flight and the (vehicle, tick) of its entries.
    pending: Option<(SampleResponse, Vec<(u32, u64)>)>,
    /// When the request in flight was sent.
    sent_at: Instant,
    /// Readings received and not used yet: (vehicle, tick) → reading (None: rejected).
    readings: BTreeMap<(u32, u64), Option<f64>>,
}

/// The key of a state's sensor read.
fn read_key(s: &VehicleState) -> (u32, u64) {
    (s.header.sender, s.header.tick)
}

impl SensorReads {
    /// Asks for the readings of the states in `wanted` (in order) that are neither in
    /// nor asked for, unless a request is in flight (one at a time).
    fn request(&mut self, k: u64, dt: f64, wanted: &[VehicleState]) -> Result<()> {
        if self.pending.is_some() {
            return Ok(());
        }
        let mut keys = Vec::new();
        for s in wanted {
            if keys.len() == MAX_VEHICLES {
                break;
            }
            let key = read_key(s);
            if self.readings.contains_key(&key) || keys.contains(&key) {
                continue;
            }
            self.batch.reads[keys.len()] = SensorRead {
                vehicle: s.header.sender,
                _pad: 0,
                tick: s.header.tick,
                t: s.header.t,
                position: s.position,
            };
            keys.push(key);
        }
        if keys.is_empty() {
            return Ok(());
        }
        self.seq += 1;
        self.batch.n = keys.len() as u32;
        self.batch.header = Header {
            sender: Header::COORDINATOR,
            flags: 0,
            tick: k,
            t: k as f64 * dt,
            seq: self.seq,
            sent_ns: wall_ns(),
        };
        let pending = self
            .client
            .send_copy(*self.batch)
            .map_err(|e| anyhow::anyhow!("sending the sensor reads of tick {k}: {e:?}"))?;
        self.field
            .notify()
            .map_err(|e| anyhow::anyhow!("waking the field server: {e:?}"))?;
        self.pending = Some((pending, keys));
        self.sent_at = Instant::now();
        Ok(())
    }

    /// Forgets the request in flight (its server died, or a new server started: a request
    /// reaches only the servers connected when it was sent); the next wait sends it again.
    fn forget_pending(&mut self, why: &str) {
        if let Some((_, keys)) = self.pending.take() {
            info!(
                reads = keys.len(),
                why, "sending the pending sensor request again"
            );
        }
    }

    /// Acts on the events of a wake-up: a (re)started field server gets the pending
    /// request again.
    fn note_events(&mut self, ids: &[usize]) {
        if ids.contains(&topics::EVENT_FIELD_UP.as_value()) {
            self.forget_pending("a field server started");
        }
    }

    /// Takes in the answer to the request in flight, if it has come.
    fn poll(&mut self, msgs: &mut MsgLog) -> Result<()> {
        let Some((pending, keys)) = &self.pending else {
            return Ok(());
        };
        let Some(reply) = pending
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving sensor readings: {e:?}"))?
        else {
            return Ok(());
        };
        let h = reply.header;
        msgs.recv_now("field_reply", &h, Header::COORDINATOR);
        let readings = reply.readings();
        anyhow::ensure!(
            h.sender == Header::FIELD_SERVER
                && reply.request_seq == self.seq
                && readings.len() == keys.len(),
            "the field server answered sensor reads out of turn (sender {}, request {} of {}, \
             {} readings for {})",
            h.sender,
            reply.request_seq,
            self.seq,
            readings.len(),
            keys.len()
        );
        for (r, key) in readings.iter().zip(keys) {
            let good = (r.vehicle, r.tick) == *key && r.rejected == 0 && r.value.is_finite();
            self.readings.insert(*key, good.then_some(r.value));
        }
        drop(reply);
        self.pending = None;
        Ok(())
    }

    /// Blocks until the readings of every state in `needed` are in (asking for them when
    /// no request is in flight). None on a termination signal. Vehicle events consumed
    /// meanwhile are harmless (every tick starts with a full drain); the supervisor's
    /// process exits are kept in `live` for the tick's liveness check.
    #[allow(clippy::too_many_arguments)]
    fn wait_for(
        &mut self,
        k: u64,
        dt: f64,
        needed: &[VehicleState],
        waitset: &iceoryx2::waitset::WaitSet<ipc::Service>,
        wake: &iceoryx2::port::listener::Listener<ipc::Service>,
        msgs: &mut MsgLog,
        live: &mut Liveness,
    ) -> Result<Option<()>> {
        let started = Instant::now();
        loop {
            if live.hear()? {
                self.forget_pending("the field server died");
            }
            self.poll(msgs)?;
            if needed
                .iter()
                .all(|s| self.readings.contains_key(&read_key(s)))
            {
                return Ok(Some(()));
            }
            if self.pending.is_some() && self.sent_at.elapsed() >= RESEND_AFTER {
                self.forget_pending("no answer");
            }
            self.request(k, dt, needed)?;
            let left = SAMPLE_TIMEOUT.saturating_sub(started.elapsed());
            anyhow::ensure!(
                !left.is_zero(),
                "no sensor readings from the field server within {SAMPLE_TIMEOUT:?} (tick {k})"
            );
            let mut ids = Vec::new();
            match wait_for_wake_ids(waitset, wake, left.min(RENOTIFY_AFTER), &mut ids)? {
                Wake::Stop => return Ok(None),
                Wake::Timeout => {
                    warn!(
                        tick = k,
                        "no sensor readings yet: waking the field server again"
                    );
                    self.field
                        .notify()
                        .map_err(|e| anyhow::anyhow!("waking the field server: {e:?}"))?;
                }
                Wake::Events => self.note_events(&ids),
            }
        }
    }

    /// The reading of state `s` (None: rejected, or never asked for), forgotten here.
    fn take(&mut self, s: &VehicleState) -> Option<f64> {
        self.readings.remove(&read_key(s)).flatten()
    }
}

/// How the coordinator learns that vehicle processes died, apart from the tick: the
/// supervisor's reports of the processes it reaped (certain, at once), join requests of
/// new processes, and a scan of the node list when a vehicle is silent (the fallback of a
/// coordinator started without a supervisor). See [`detect`].
struct Liveness {
    /// The supervisor's process exits (`<m>/supervisor/exits`).
    exits: iceoryx2::port::subscriber::Subscriber<ipc::Service, ProcessExit, ()>,
    /// Agent exits heard and not acted on yet.
    agent_exits: Vec<ProcessExit>,
    last_scan: Instant,
    /// Wall time the last node-list scan took.
    scan_cost: Duration,
    /// When this coordinator process started: the silence of a vehicle it has not heard
    /// from yet counts from here.
    since: Instant,
    /// The same, wall clock, ns since the Unix epoch.
    since_ns: u64,
    /// True when this coordinator resumed from a checkpoint (every vehicle alive in it has
    /// had a process: one whose node is gone is dead).
    resumed: bool,
}

impl Liveness {
    /// Takes in the supervisor's reports; true when one says the field server died.
    fn hear(&mut self) -> Result<bool> {
        let mut field_died = false;
        while let Some(sample) = self
            .exits
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving a process exit: {e:?}"))?
        {
            let e: ProcessExit = *sample;
            if e.header.sender != Header::SUPERVISOR {
                continue;
            }
            match e.role {
                ProcessExit::AGENT => self.agent_exits.push(e),
                ProcessExit::FIELD_SERVER => field_died = true,
                _ => {}
            }
        }
        Ok(field_died)
    }
}

/// What the coordinator knows of a death: how it learnt it and how long after the death.
struct Verdict<'a> {
    cause: &'a str,
    /// `supervisor` (it reaped the process), `scan` (the node is listed dead or gone),
    /// `join` (a new process of the vehicle asked to join), `silence`.
    by: &'a str,
    /// Wall ms from the death to this verdict: exact (the supervisor's reap time) for
    /// `supervisor`; an upper bound (from the vehicle's last message) otherwise; for
    /// `silence`, how long the vehicle was silent.
    detection_ms: Option<f64>,
    pid: u32,
}

/// The mutable state a liveness verdict touches.
struct Books<'a> {
    fleet: &'a mut Fleet,
    inbox: &'a mut Inbox,
    recorder: &'a mut Recorder,
    detection_ms: &'a mut Vec<f64>,
}

impl Books<'_> {
    /// Vehicle `v` is lost at tick `k`: formation redesigned without it, its states
    /// forgotten, the event written (with how and how fast it was found).
    fn lose(&mut self, k: u64, v: u32, verdict: Verdict) -> Result<()> {
        if !self.fleet.lose(v) {
            return Ok(());
        }
        warn!(
            vehicle = v,
            tick = k,
            cause = verdict.cause,
            by = verdict.by,
            pid = verdict.pid,
            detection_ms = verdict.detection_ms,
            "vehicle process is dead"
        );
        self.inbox.states.remove(&v);
        let mut detail = serde_json::json!({ "cause": verdict.cause, "by": verdict.by,
            "pid": verdict.pid });
        if let Some(ms) = verdict.detection_ms {
            // Silence is no death: how long it lasted, not a detection latency.
            let key = if verdict.cause == "silent" {
                "silent_ms"
            } else {
                self.detection_ms.push(ms);
                "detection_ms"
            };
            detail[key] = serde_json::json!(ms);
        }
        self.recorder.lost_with(k, v, detail)?;
        Ok(())
    }
}

/// One liveness check at tick `k`, whatever the tick's pace: acts on the supervisor's
/// reports and on join requests of vehicles still believed alive, then, when a vehicle is
/// suspect (missing from a lockstep gather for [`SUSPECT_AFTER`], or silent for as long
/// and [`SUSPECT_TICKS`] periods in a paced run) and no scan ran for [`LIVENESS_EVERY`],
/// scans the node list once for every vehicle; a paced vehicle whose process is alive but
/// silent for [`SILENCE_LIMIT`] is lost as `silent`. True when a vehicle was lost.
#[allow(clippy::too_many_arguments)]
fn detect(
    k: u64,
    paced: Option<f64>,
    missing: &[u32],
    gather_start: Instant,
    live: &mut Liveness,
    sensors: &mut SensorReads,
    domain: &Domain,
    plan: &FaultPlan,
    books: &mut Books,
) -> Result<bool> {
    let mut lost = false;
    if live.hear()? {
        sensors.forget_pending("the field server died");
    }
    for e in std::mem::take(&mut live.agent_exits) {
        let v = e.vehicle;
        let Some(peer) = books.inbox.peers.get(v as usize) else {
            continue;
        };
        // The process we know for this vehicle (or, never heard of, one that died since
        // we started); a report of an older process is old news.
        let ours = peer.pid == e.pid || (peer.pid == 0 && e.died_ns >= live.since_ns);
        if !books.fleet.is_alive(v) || !ours {
            continue;
        }
        let ms = wall_ns().saturating_sub(e.died_ns) as f64 / 1e6;
        let cause = if e.signal != 0 {
            "process died"
        } else {
            "process ended"
        };
        books.lose(
            k,
            v,
            Verdict {
                cause,
                by: "supervisor",
                detection_ms: Some(ms),
                pid: e.pid,
            },
        )?;
        lost = true;
    }
    // A new process asked to join for a vehicle still believed alive: the old one is gone
    // (admitted at the start of the next tick).
    for v in books.inbox.joins.clone() {
        if !books.fleet.is_alive(v) || plan.restart_pending(v, k) {
            continue;
        }
        let peer = &mut books.inbox.peers[v as usize];
        let ms = peer.restart_gap_ms.take();
        let pid = peer.pid;
        books.lose(
            k,
            v,
            Verdict {
                cause: "process restarted",
                by: "join",
                detection_ms: ms,
                pid,
            },
        )?;
        lost = true;
    }
    let since = live.since;
    let silence = |peer: &Peer| peer.last_recv.unwrap_or(since).elapsed();
    let suspect = match paced {
        None => !missing.is_empty() && gather_start.elapsed() >= SUSPECT_AFTER,
        Some(period) => {
            let after = SUSPECT_AFTER.max(Duration::from_secs_f64(SUSPECT_TICKS * period));
            books
                .fleet
                .alive()
                .any(|v| silence(&books.inbox.peers[v as usize]) >= after)
        }
    };
    let every = LIVENESS_EVERY.max(live.scan_cost * SCAN_SHARE);
    if !suspect || live.last_scan.elapsed() < every {
        return Ok(lost);
    }
    live.last_scan = Instant::now();
    let states = domain.node_states();
    live.scan_cost = live.last_scan.elapsed();
    let alive: Vec<u32> = books.fleet.alive().collect();
    let mut any_dead = false;
    for v in alive {
        let peer = books.inbox.peers[v as usize];
        // Dead: its node is listed dead, or gone after a process of it was known (a
        // vehicle still starting up has no node yet).
        let heard = peer.last_recv.is_some() || live.resumed;
        let verdict = match states.get(&topics::agent_node_name(v)) {
            Some(true) => None,
            Some(false) => Some("process died"),
            None => heard.then_some("process gone"),
        };
        if let Some(cause) = verdict {
            let ms = peer.last_recv.map(|t| t.elapsed().as_secs_f64() * 1e3);
            books.lose(
                k,
                v,
                Verdict {
                    cause,
                    by: "scan",
                    detection_ms: ms,
                    pid: peer.pid,
                },
            )?;
            any_dead = true;
        } else if paced.is_some() && states.get(&topics::agent_node_name(v)) == Some(&true) {
            let quiet = silence(&peer);
            if quiet >= SILENCE_LIMIT {
                books.inbox.peers[v as usize].pid = 0; // its next word is a join request
                books.lose(
                    k,
                    v,
                    Verdict {
                        cause: "silent",
                        by: "silence",
                        detection_ms: Some(quiet.as_secs_f64() * 1e3),
                        pid: peer.pid,
                    },
                )?;
                lost = true;
            }
        }
    }
    if any_dead {
        domain.cleanup_dead_nodes();
    }
    Ok(lost || any_dead)
}

/// Runs the coordinator of `mission`, writing into `dir`. `msgs` receives the message
/// records; `on_ready` is called once every port exists. Returns when the mission is over
/// or on a termination signal.
pub fn run(mission: &Mission, dir: &RunDir, msgs: MsgLog, on_ready: impl FnOnce()) -> Result<()> {
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
    let mut sensors = SensorReads {
        client: domain
            .sample_service(&node, &limits)?
            .client_builder()
            .create()
            .map_err(|e| anyhow::anyhow!("creating the sensor-read client: {e:?}"))?,
        field: domain
            .field_wake(&node, &limits)?
            .notifier_builder()
            .default_event_id(topics::EVENT_DATA)
            .create()
            .map_err(|e| anyhow::anyhow!("field notifier: {e:?}"))?,
        batch: Box::new(SampleBatch::empty()),
        seq: 0,
        pending: None,
        sent_at: Instant::now(),
        readings: BTreeMap::new(),
    };
    let mut live = Liveness {
        exits: domain
            .exits_service(&node, &limits)?
            .subscriber_builder()
            .create()
            .map_err(|e| anyhow::anyhow!("subscribing to the supervisor's process exits: {e:?}"))?,
        agent_exits: Vec::new(),
        last_scan: Instant::now(),
        scan_cost: Duration::ZERO,
        since: Instant::now(),
        since_ns: wall_ns(),
        resumed: false,
    };
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
    let plan = FaultPlan::new(mission);
    let mut inbox = Inbox {
        states: BTreeMap::new(),
        peers: vec![Peer::default(); n],
        joins: BTreeSet::new(),
        counts: MessageCounts::default(),
        msgs,
    };
    // A restarted coordinator resumes from its checkpoint.
    let mut republish: Option<BodyRecord> = None;
    let resumed = Checkpoint::load(dir).context("reading the checkpoint")?;
    let resumed_marks = resumed.as_ref().map(|cp| cp.journal);
    let mut detection_ms = Vec::new();
    let mut rejoin_ms = Vec::new();
    let mut late_ticks = 0u64;
    let mut sent = 0u64;
    // The wall clock of a paced mission: when its tick 0 was due (kept across restarts).
    let mut clock_start: Option<Instant> = None;
    let mut clock_start_ns: Option<u64> = None;
    let (mut planner, mut fleet, mut recorder, mut k) = match resumed {
        Some(cp) => {
            dir.truncate_to(&cp.offsets)
                .context("cutting the run files back to the checkpoint")?;
            for (peer, mark) in inbox.peers.iter_mut().zip(&cp.peers) {
                peer.pid = mark.pid;
                peer.last_seq = mark.last_seq;
            }
            inbox.counts = cp.counts;
            info!(
                tick = cp.next_tick,
                "resumed from the checkpoint: re-publishing the last command"
            );
            republish = Some(cp.body.clone());
            detection_ms = cp.detection_ms;
            rejoin_ms = cp.rejoin_ms;
            late_ticks = cp.late_ticks;
            sent = cp.sent;
            live.resumed = true;
            // The mission's wall clock goes on: the ticks missed while no coordinator ran
            // are due already (caught up, late), not postponed by the outage.
            if let Some(ns) = cp.clock_start_ns {
                let ago = Duration::from_nanos(wall_ns().saturating_sub(ns));
                clock_start = Some(Instant::now().checked_sub(ago).unwrap_or_else(Instant::now));
                clock_start_ns = Some(ns);
            }
            let recorder = Recorder::resume(mission, dir, cp.stats)
                .context("opening the run directory files")?;
            (cp.planner, cp.fleet, recorder, cp.next_tick)
        }
        None => (
            Planner::new(
                PlannerParams::from_mission(mission),
                mission.start_vec(),
                &ids,
            )?,
            Fleet::new(mission, &ids),
            Recorder::open(mission, dir).context("opening the run directory files")?,
            0,
        ),
    };
    // A coordinator that is never restarted needs no checkpoint.
    let mut checkpoints = match mission.restart.coordinator {
        RestartPolicy::Never => None,
        _ => Some(
            CheckpointWriter::open(dir, resumed_marks).context("opening the checkpoint files")?,
        ),
    };
    let mut body = Box::new(BodyCommand::empty());
    info!(vehicles = n, ticks, start_tick = k, "coordinator up");
    on_ready();
    if let Some(record) = republish {
        publish(&mut body, &record, &body_pub)?;
        for notifier in &notifiers {
            let _ = notifier.notify();
        }
    }

    let paced = match mission.mission.pace {
        Pace::Lockstep => None,
        Pace::Factor(f) => Some(dt / f),
    };
    let mut stopped = false;
    'ticks: while k < ticks {
        recorder.faults_starting(k)?;
        // Scheduled kills: a real SIGKILL of the agent's process, then wait until its
        // node is seen dead.
        for v in plan.kills_at(k).collect::<Vec<_>>() {
            if !fleet.is_alive(v) {
                continue;
            }
            let pid = inbox.peers[v as usize].pid;
            let killed = shared::process::sigkill(pid);
            let name = topics::agent_node_name(v);
            let started = Instant::now();
            while domain.node_states().get(&name).copied().unwrap_or(false)
                && started.elapsed() < KILL_TIMEOUT
            {
                let mut ids = Vec::new();
                if wait_for_wake_ids(&waitset, &wake, Duration::from_millis(2), &mut ids)?
                    == Wake::Stop
                {
                    stopped = true;
                    break 'ticks;
                }
                sensors.note_events(&ids);
            }
            domain.cleanup_dead_nodes();
            info!(
                vehicle = v,
                pid,
                killed,
                tick = k,
                ms = started.elapsed().as_secs_f64() * 1e3,
                "scheduled kill done"
            );
            fleet.lose(v);
            inbox.states.remove(&v);
            recorder.lost(k, v, "scheduled kill")?;
        }
        // Scheduled restarts: wait for the restarted agent's join request, then admit.
        for v in plan.restarts_at(k).collect::<Vec<_>>() {
            let started = Instant::now();
            while !inbox.joins.contains(&v) && started.elapsed() < LOCKSTEP_TIMEOUT {
                inbox.drain(&subscribers, &fleet, k)?;
                if inbox.joins.contains(&v) {
                    break;
                }
                let mut ids = Vec::new();
                if wait_for_wake_ids(&waitset, &wake, Duration::from_millis(100), &mut ids)?
                    == Wake::Stop
                {
                    stopped = true;
                    break 'ticks;
                }
                sensors.note_events(&ids);
            }
            if inbox.joins.remove(&v) && fleet.admit(v).is_some() {
                if let Some(at) = inbox.peers[v as usize].join_request {
                    rejoin_ms.push(at.elapsed().as_secs_f64() * 1e3);
                }
                recorder.rejoined(k, v)?;
            } else {
                warn!(
                    vehicle = v,
                    tick = k,
                    "scheduled restart: the vehicle did not ask to join in time"
                );
            }
        }
        // Unscheduled returns (a process restarted after a crash): admit at once.
        inbox.drain(&subscribers, &fleet, k)?;
        for v in inbox.joins.clone() {
            if plan.restart_pending(v, k) {
                continue;
            }
            if fleet.is_alive(v) {
                // Its process was restarted before we noticed it die.
                let peer = &mut inbox.peers[v as usize];
                let verdict = Verdict {
                    cause: "process restarted",
                    by: "join",
                    detection_ms: peer.restart_gap_ms.take(),
                    pid: peer.pid,
                };
                Books {
                    fleet: &mut fleet,
                    inbox: &mut inbox,
                    recorder: &mut recorder,
                    detection_ms: &mut detection_ms,
                }
                .lose(k, v, verdict)?;
            }
            if fleet.admit(v).is_some() {
                inbox.joins.remove(&v);
                if let Some(at) = inbox.peers[v as usize].join_request {
                    rejoin_ms.push(at.elapsed().as_secs_f64() * 1e3);
                }
                recorder.rejoined(k, v)?;
            }
        }

        // Gather the states of tick k: all of them (lockstep), or what is in at the
        // tick's deadline (paced). Missing vehicles are checked for liveness.
        let admitted: BTreeSet<u32> = fleet.admitted().iter().map(|r| r.id).collect();
        let first = k == 0 || inbox.peers.iter().all(|p| p.last_recv.is_none());
        // A paced mission waits for every vehicle once, at its very start; a resumed
        // coordinator keeps the mission's clock instead.
        let starting = k == 0 && !live.resumed;
        let wait_limit = if first {
            Duration::from_secs(30) + Duration::from_millis(100) * n as u32
        } else {
            LOCKSTEP_TIMEOUT
        };
        let gather_start = Instant::now();
        // Everything was just drained (above): from here on, read only what wakes us.
        let mut woken: Option<Vec<usize>> = Some(Vec::new());
        loop {
            inbox.drain_some(&subscribers, &fleet, k, woken.as_deref())?;
            let missing: Vec<u32> = fleet
                .alive()
                .filter(|v| !admitted.contains(v))
                .filter(|&v| {
                    // Lockstep flow control: publishing command k must not overflow the
                    // command buffer of an agent that ran ahead and reads late.
                    let unread = k.saturating_sub(inbox.peers[v as usize].commands_read) + 1;
                    let behind = paced.is_none() && unread > Limits::BODY_BUFFER as u64;
                    behind
                        || inbox
                            .state(v, k, paced.is_some())
                            .is_none_or(|s| s.header.tick < k)
                })
                .collect();
            // Liveness, on a wall clock of its own: tell a dead process from a slow one.
            let mut books = Books {
                fleet: &mut fleet,
                inbox: &mut inbox,
                recorder: &mut recorder,
                detection_ms: &mut detection_ms,
            };
            if detect(
                k,
                paced,
                &missing,
                gather_start,
                &mut live,
                &mut sensors,
                &domain,
                &plan,
                &mut books,
            )? {
                continue;
            }
            let complete = missing.is_empty();
            let timeout = match paced {
                None => {
                    if complete {
                        break;
                    }
                    let left = wait_limit.saturating_sub(gather_start.elapsed());
                    if left.is_zero() {
                        warn!(
                            tick = k,
                            ?missing,
                            "lockstep timeout: going on without the silent vehicles"
                        );
                        // Alive but silent past the limit (stopped, hung): lost, and
                        // readmitted when it speaks again.
                        for &v in &missing {
                            let peer = &mut inbox.peers[v as usize];
                            let Some(last) = peer.last_recv else {
                                continue; // never heard: still starting up
                            };
                            let pid = std::mem::take(&mut peer.pid);
                            Books {
                                fleet: &mut fleet,
                                inbox: &mut inbox,
                                recorder: &mut recorder,
                                detection_ms: &mut detection_ms,
                            }
                            .lose(
                                k,
                                v,
                                Verdict {
                                    cause: "silent",
                                    by: "silence",
                                    detection_ms: Some(last.elapsed().as_secs_f64() * 1e3),
                                    pid,
                                },
                            )?;
                        }
                        break;
                    }
                    left.min(SUSPECT_AFTER)
                }
                Some(period) => {
                    if starting && !complete {
                        wait_limit
                            .saturating_sub(gather_start.elapsed())
                            .min(SUSPECT_AFTER)
                    } else {
                        let start = *clock_start.get_or_insert_with(|| {
                            clock_start_ns = Some(wall_ns());
                            Instant::now()
                        });
                        let deadline = start + Duration::from_secs_f64(period * k as f64);
                        let now = Instant::now();
                        if now >= deadline {
                            // Late: not every state was in at the deadline, or the
                            // coordinator itself came to the tick a period or more after it
                            // (an outage being caught up, an overload).
                            let behind = gather_start >= deadline + Duration::from_secs_f64(period);
                            if !complete || behind {
                                late_ticks += 1;
                                debug!(
                                    tick = k,
                                    ?missing,
                                    behind,
                                    "late tick: not every state was in at the deadline"
                                );
                            }
                            break;
                        }
                        (deadline - now).min(SUSPECT_AFTER)
                    }
                }
            };
            let mut ids = Vec::new();
            match wait_for_wake_ids(&waitset, &wake, timeout, &mut ids)? {
                Wake::Stop => {
                    stopped = true;
                    break 'ticks;
                }
                // Only vehicle events: drain just those subscribers; anything else (a
                // timeout, another event): drain all.
                Wake::Events
                    if !ids.is_empty() && ids.iter().all(|e| *e >= topics::EVENT_VEHICLE_BASE) =>
                {
                    woken = Some(ids)
                }
                _ => {
                    sensors.note_events(&ids);
                    woken = None
                }
            }
        }

        // The states of the tick, and their sensor readings in one batched read.
        let states: Vec<VehicleState> = fleet
            .alive()
            .filter(|v| !admitted.contains(v))
            .filter_map(|v| inbox.state(v, k, paced.is_some()).copied())
            .collect();
        if sensors
            .wait_for(k, dt, &states, &waitset, &wake, &mut inbox.msgs, &mut live)?
            .is_none()
        {
            stopped = true;
            break 'ticks;
        }
        if paced.is_none() {
            // Read ahead: the states of later ticks already in, in tick order (not past a
            // vehicle's scheduled kill: its sensor is never read then).
            let mut ahead: Vec<VehicleState> = fleet
                .alive()
                .filter(|v| !admitted.contains(v))
                .filter_map(|v| inbox.states.get(&v))
                .flat_map(|m| m.range(k + 1..).map(|(_, s)| *s))
                .filter(|s| {
                    !plan.kills.iter().any(|x| {
                        x.vehicle == s.header.sender && x.tick > k && x.tick <= s.header.tick
                    })
                })
                .collect();
            ahead.sort_by_key(|s| (s.header.tick, s.header.sender));
            sensors.request(k, dt, &ahead)?;
        }
        let mut truth: Vec<Report> = Vec::with_capacity(states.len());
        for s in &states {
            let Some(measurement) = sensors.take(s) else {
                inbox.counts.rejected += 1;
                warn!(
                    vehicle = s.header.sender,
                    tick = s.header.tick,
                    "the field server rejected this vehicle's sensor read: state dropped"
                );
                continue;
            };
            truth.push(Report {
                id: s.header.sender,
                tick: s.header.tick,
                position: to_vec3(&s.position),
                velocity: to_vec3(&s.velocity),
                measurement,
            });
        }
        inbox.used(k, paced.is_some());
        // Readings of states that will never be used (their vehicle was lost).
        sensors.readings.retain(|(_, tick), _| *tick > k);
        let t = k as f64 * dt;
        let TickOutcome {
            fates,
            command,
            snapshot,
        } = plan_tick(k, dt, &truth, &mut fleet, &mut planner, &mut recorder)?;
        for (v, fate) in &fates {
            match fate {
                Fate::Deliver { injected, .. } if *injected > 0.0 => {
                    inbox
                        .msgs
                        .held("state", *v, Header::COORDINATOR, k, *injected)
                }
                Fate::Drop(reason) => {
                    inbox
                        .msgs
                        .drop("state", *v, Header::COORDINATOR, k, reason.as_str())
                }
                _ => {}
            }
        }

        // Deterministic sequence numbers: a resumed coordinator re-sends a tick's command
        // under the same number, which agents that already have it ignore.
        let record = BodyRecord {
            tick: k,
            t,
            seq: k + 1,
            holding: command.holding,
            s: command.body.s,
            sdot: command.sdot,
            r: from_vec3(&command.body.r),
            scale: command.body.scale,
            inter: [command.inter.alpha, command.inter.d0, command.inter.d1],
            leader: [command.leader.alpha, command.leader.d0, command.leader.d1],
            damping: command.damping,
            velocity: from_vec3(&command.velocity),
            leaders: command.leaders.iter().map(from_vec3).collect(),
            snapshot,
        };
        fleet.end_tick();
        // Checkpoint before publishing: a coordinator restarted after this point
        // re-publishes this very command and goes on with the next tick.
        if let Some(writer) = checkpoints.as_mut() {
            recorder.flush()?;
            let peers: Vec<PeerMark> = inbox
                .peers
                .iter()
                .map(|p| PeerMark {
                    pid: p.pid,
                    last_seq: p.last_seq,
                })
                .collect();
            CheckpointRef {
                next_tick: k + 1,
                planner: &planner,
                fleet: &fleet,
                stats: recorder.stats(),
                offsets: recorder.offsets(),
                counts: inbox.counts,
                sent: sent + 1,
                late_ticks,
                detection_ms: &detection_ms,
                rejoin_ms: &rejoin_ms,
                peers: &peers,
                body: &record,
                clock_start_ns,
                journal: JournalMarks::default(),
            }
            .save_with(writer)
            .context("writing the checkpoint")?;
        }
        publish(&mut body, &record, &body_pub)?;
        sent += 1;
        for notifier in &notifiers {
            let _ = notifier.notify();
        }
        k += 1;
    }

    // Tell everyone the mission is over.
    body.header = Header {
        sender: Header::COORDINATOR,
        flags: BodyCommand::FINISHED,
        tick: k,
        t: k as f64 * dt,
        seq: k + 1,
        sent_ns: wall_ns(),
    };
    body.n_leaders = 0;
    body.n_vehicles = 0;
    let _ = body_pub.send_copy(*body);
    for notifier in &notifiers {
        let _ = notifier.notify();
    }
    let _ = sensors.field.notify();
    inbox.msgs.flush();

    recorder.flush()?;
    let mut summary = recorder.summary(&planner, "multi-process");
    summary.messages = inbox.counts;
    summary.messages.sent = sent;
    summary.messages.dropped_injected = fleet.counts.dropped_injected;
    summary.late_ticks = late_ticks;
    summary.detection_latency_ms = detection_ms;
    summary.rejoin_latency_ms = rejoin_ms;
    summary.write(dir).context("writing summary.json")?;
    info!(
        ticks = k,
        stopped,
        delivered = inbox.counts.delivered,
        rejected = inbox.counts.rejected,
        late_ticks,
        "coordinator done"
    );
    Ok(())
}

/// The content of one body command (kept in the checkpoint for a re-send).
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct BodyRecord {
    pub tick: u64,
    pub t: f64,
    pub seq: u64,
    pub holding: bool,
    pub s: f64,
    pub sdot: f64,
    pub r: [f64; 3],
    pub scale: f64,
    pub inter: [f64; 3],
    pub leader: [f64; 3],
    pub damping: f64,
    pub velocity: [f64; 3],
    pub leaders: Vec<[f64; 3]>,
    pub snapshot: Vec<shared::msg::coordinator_to_agent::SnapshotEntry>,
}

/// Fills the reusable command buffer from `record` and publishes it (zero copy into the
/// subscribers' shared memory).
fn publish(
    body: &mut BodyCommand,
    record: &BodyRecord,
    publisher: &iceoryx2::port::publisher::Publisher<ipc::Service, BodyCommand, ()>,
) -> Result<()> {
    body.header = Header {
        sender: Header::COORDINATOR,
        flags: if record.holding {
            BodyCommand::HOLDING
        } else {
            0
        },
        tick: record.tick,
        t: record.t,
        seq: record.seq,
        sent_ns: 0,
    };
    body.s = record.s;
    body.sdot = record.sdot;
    body.r = record.r;
    body.scale = record.scale;
    body.inter = record.inter;
    body.leader = record.leader;
    body.damping = record.damping;
    body.velocity = record.velocity;
    let n_l = record.leaders.len().min(MAX_LEADERS);
    body.n_leaders = n_l as u32;
    body.leaders[..n_l].copy_from_slice(&record.leaders[..n_l]);
    let n_v = record.snapshot.len().min(MAX_VEHICLES);
    body.n_vehicles = n_v as u32;
    body.snapshot[..n_v].copy_from_slice(&record.snapshot[..n_v]);
    body.header.sent_ns = wall_ns();
    publisher
        .send_copy(*body)
        .map_err(|e| anyhow::anyhow!("publishing the body: {e:?}"))?;
    Ok(())
}
