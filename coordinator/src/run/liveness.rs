//! How the coordinator learns that vehicle processes died, apart from the tick: the
//! supervisor's reports of the processes it reaped (certain, at once), join requests of
//! new processes, and a scan of the node list when a vehicle is silent (the fallback of a
//! coordinator started without a supervisor); and how long silence is tolerated.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Result;
use iceoryx2::prelude::*;
use serde::Serialize;
use tracing::warn;
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::{wall_ns, Header};
use vbap_ipc::topics;

use super::inbox::Peer;
use super::{Coordinator, LOCKSTEP_TIMEOUT};
use crate::membership::{self, Loss};
use crate::plan::Plan;

/// Wall time a vehicle may be missing from a lockstep gather, or silent in a paced run (and
/// at least [`SUSPECT_TICKS`] tick periods), before the node list is scanned for its
/// process. A wall-clock deadline of the coordinator's own: it does not depend on the tick.
pub(super) const SUSPECT_AFTER: Duration = Duration::from_millis(50);
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
/// How often the supervisor's record of deaths ([`crate::exits`]) is read again.
const RECORD_EVERY: Duration = Duration::from_millis(250);
/// How long a lockstep tick waits for a member whose agent the supervisor saw stopped: a
/// stop shorter than this (a debugger or `strace -p` attaching) keeps the run equal to
/// the simulator; a longer one (Ctrl-Z, SIGSTOP) loses the member, so the decisions of the
/// tick under way wait at most this long for it.
const STOPPED_GRACE: Duration = Duration::from_millis(250);
/// How long after a recorded stop a vehicle's message may still be one it sent before the
/// stop (in flight, or read late): one heard later means the process was continued.
const STOP_HEARD_SLACK: Duration = Duration::from_millis(50);
/// How old a recorded death must be before the record, not the supervisor's report, acts
/// on it: the supervisor writes the record first and reports at once, so a death recorded
/// this long ago and not heard of was a report this coordinator missed (one published
/// before its subscriber was connected, at a restart).
const REPORT_GRACE: Duration = Duration::from_millis(500);

/// The supervisor's reports and the state of the node-list scans.
pub(super) struct Liveness {
    /// The supervisor's process exits (`<m>/supervisor/exits`).
    pub exits: iceoryx2::port::subscriber::Subscriber<ipc::Service, ProcessExit, ()>,
    /// Agent exits heard and not acted on yet.
    pub agent_exits: Vec<ProcessExit>,
    /// Agent deaths read from the supervisor's record ([`crate::exits`]) by a resumed
    /// coordinator, not acted on yet: those it missed while no coordinator ran.
    pub recorded: Vec<ProcessExit>,
    /// Agents the supervisor reported stopped and not continued since, by vehicle (acted on
    /// in lockstep only: a paced tick does not wait for them).
    pub stopped: BTreeMap<u32, ProcessExit>,
    /// Agents stopped and not continued by the supervisor's record, not acted on yet: stops
    /// whose report this coordinator missed.
    pub recorded_stops: Vec<ProcessExit>,
    /// Vehicles lost while their process lived on (stopped), by vehicle: that process's
    /// pid. Its later death is written as a `died` event (no loss: the vehicle is out
    /// already); it is forgotten when the process speaks again.
    pub out_alive: BTreeMap<u32, u32>,
    /// The run directory whose record is read again every [`RECORD_EVERY`].
    pub record_root: PathBuf,
    /// When the record was last read.
    pub record_read: Instant,
    pub last_scan: Instant,
    /// Wall time the last node-list scan took.
    pub scan_cost: Duration,
    /// When this coordinator process started: the silence of a vehicle it has not heard
    /// from yet counts from here.
    pub since: Instant,
    /// The same, wall clock, ns since the Unix epoch.
    pub since_ns: u64,
    /// A resumed coordinator: the instant its peers' last receipts were restored from the
    /// checkpoint at (each `now − silence`, so never later). Only a receipt after it was
    /// heard by this process.
    pub inherited_until: Option<Instant>,
    /// When this coordinator published its first command: before it, agents that have
    /// reported wait for it in silence however long the set takes to start (seconds at
    /// N = 1024 on a busy machine), and silence counts from it at the earliest.
    pub commanded: Option<Instant>,
    /// True when this coordinator resumed from a checkpoint (every vehicle alive in it has
    /// had a process: one whose node is gone is dead).
    pub resumed: bool,
    /// Vehicles whose node the last scan found gone (a complete listing without it): gone
    /// at two scans in a row, the process is dead. A node missing from one listing only
    /// may have been read at a bad instant (its details being rewritten, the listing
    /// interrupted); a dead process's node never comes back.
    pub gone_at_last_scan: std::collections::BTreeSet<u32>,
}

impl Liveness {
    /// The liveness watch of a coordinator starting now, told of process exits by `exits`
    /// and by the supervisor's record of run directory `record_root`.
    pub fn new(
        exits: iceoryx2::port::subscriber::Subscriber<ipc::Service, ProcessExit, ()>,
        record_root: PathBuf,
    ) -> Self {
        Self {
            exits,
            agent_exits: Vec::new(),
            recorded: Vec::new(),
            stopped: BTreeMap::new(),
            recorded_stops: Vec::new(),
            out_alive: BTreeMap::new(),
            record_root,
            record_read: Instant::now(),
            last_scan: Instant::now(),
            scan_cost: Duration::ZERO,
            since: Instant::now(),
            inherited_until: None,
            since_ns: wall_ns(),
            commanded: None,
            resumed: false,
            gone_at_last_scan: Default::default(),
        }
    }

    /// Takes in the supervisor's reports; true when one says the field server died.
    pub fn hear(&mut self) -> Result<bool> {
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
                ProcessExit::AGENT | ProcessExit::UNREACHABLE => self.agent_exits.push(e),
                ProcessExit::FIELD_SERVER => field_died = true,
                ProcessExit::STOPPED => {
                    self.stopped.insert(e.vehicle, e);
                }
                ProcessExit::CONTINUED
                    if self.stopped.get(&e.vehicle).is_some_and(|s| s.pid == e.pid) =>
                {
                    self.stopped.remove(&e.vehicle);
                }
                _ => {}
            }
        }
        Ok(field_died)
    }

    /// Every [`RECORD_EVERY`]: takes in the agents' deaths the supervisor recorded at least
    /// [`REPORT_GRACE`] ago. Each is acted on at most once ([`Coordinator::lose`] skips a
    /// vehicle already lost or a process no longer its own), so a death whose report never
    /// reached this coordinator is still decided, within `RECORD_EVERY + REPORT_GRACE`.
    fn reread_record(&mut self) {
        if self.record_read.elapsed() < RECORD_EVERY {
            return;
        }
        self.record_read = Instant::now();
        let before = wall_ns().saturating_sub(REPORT_GRACE.as_nanos() as u64);
        self.recorded
            .extend(crate::exits::agent_deaths_by(&self.record_root, before));
        self.recorded_stops = crate::exits::agents_stopped_by(&self.record_root, before);
    }

    /// How long `peer` has been silent (since this process started, when never heard).
    fn silence(&self, peer: &Peer) -> Duration {
        peer.last_recv.unwrap_or(self.since).elapsed()
    }

    /// [`Liveness::silence`] not counting the time before the first command (zero until
    /// then): what [`SILENCE_LIMIT`] is held against.
    fn silence_since_commanded(&self, peer: &Peer) -> Duration {
        let Some(commanded) = self.commanded else {
            return Duration::ZERO;
        };
        peer.last_recv
            .unwrap_or(self.since)
            .max(commanded)
            .elapsed()
    }
}

impl<P: Plan + Serialize> Coordinator<'_, P> {
    /// Vehicle `v` is lost at this tick: formation redesigned without it (at the planner's
    /// next step), its states forgotten, the event written with how and how fast it was
    /// found.
    pub(super) fn lose(&mut self, v: u32, loss: Loss) -> Result<()> {
        let k = self.k;
        let Some((event, dropped)) = membership::lose(&mut self.fleet, k, self.dt, v, &loss) else {
            return Ok(());
        };
        // Its reports the link still held die with it: dropped, as the simulator counts them.
        for tick in dropped {
            self.inbox
                .msgs
                .drop("state", v, Header::COORDINATOR, tick, "lost");
        }
        if let Some(f) = loss.found {
            warn!(
                vehicle = v,
                tick = k,
                cause = loss.cause,
                by = f.by,
                pid = f.pid,
                ms = f.ms,
                "{}",
                if loss.is_death() {
                    "vehicle process is dead"
                } else {
                    "vehicle lost: its process lives on but does not report"
                }
            );
        }
        self.inbox.states.remove(&v);
        if let Some(ms) = loss.detection_ms() {
            self.books.detection_ms.push(ms);
        }
        self.recorder.event(event)?;
        Ok(())
    }

    /// One liveness check, whatever the tick's pace: acts on the supervisor's reports and
    /// on join requests of vehicles still believed alive, then, when a vehicle is suspect
    /// (`missing` from a lockstep gather for [`SUSPECT_AFTER`], or silent for as long and
    /// [`SUSPECT_TICKS`] periods in a paced run) and no scan ran for [`LIVENESS_EVERY`],
    /// scans the node list once for every vehicle. True when a vehicle was lost.
    pub(super) fn detect(&mut self, missing: &[u32], gather_start: Instant) -> Result<bool> {
        if self.live.hear()? {
            self.sensors.forget_pending("the field server died");
        }
        self.live.reread_record();
        let mut lost = self.supervisor_reports()?;
        lost |= self.stopped_members()?;
        lost |= self.restarted_unseen()?;
        let suspect = match self.paced {
            None => !missing.is_empty() && gather_start.elapsed() >= SUSPECT_AFTER,
            Some(period) => {
                let after = SUSPECT_AFTER.max(Duration::from_secs_f64(SUSPECT_TICKS * period));
                self.fleet
                    .alive()
                    .any(|v| self.live.silence(&self.inbox.peers[v as usize]) >= after)
            }
        };
        let every = LIVENESS_EVERY.max(self.live.scan_cost * SCAN_SHARE);
        if !suspect || self.live.last_scan.elapsed() < every {
            return Ok(lost);
        }
        Ok(self.scan()? || lost)
    }

    /// Loses the vehicles whose process the supervisor reported dead, or recorded dead
    /// while no coordinator ran or without a report this coordinator heard (`by =
    /// "record"`); true when one was.
    pub(super) fn supervisor_reports(&mut self) -> Result<bool> {
        // A process lost while stopped that speaks again (continued) is no longer out
        // alive: it asks to join.
        let (joins, peers) = (&self.inbox.joins, &self.inbox.peers);
        self.live
            .out_alive
            .retain(|v, pid| !(joins.contains(v) && peers[*v as usize].pid == *pid));
        let mut lost = false;
        let recorded = std::mem::take(&mut self.live.recorded);
        let heard = std::mem::take(&mut self.live.agent_exits);
        // The supervisor's own reports first: a death both reported and recorded is
        // found by the report.
        let reports = heard
            .into_iter()
            .map(|e| (e, "supervisor"))
            .chain(recorded.into_iter().map(|e| (e, "record")));
        for (e, by) in reports {
            let v = e.vehicle;
            let Some(peer) = self.inbox.peers.get(v as usize) else {
                continue;
            };
            // The process we know for this vehicle (or, never heard of, one that died since
            // we started); a report of an older process is old news.
            let ours = peer.pid == e.pid || (peer.pid == 0 && e.died_ns >= self.live.since_ns);
            if ours && e.role == ProcessExit::UNREACHABLE && e.pid != 0 {
                // Across hosts: even a vehicle already lost (its proxy node found dead when
                // the shore's bridge died) may live on: its next word is a join request.
                self.inbox.peers[v as usize].pid = 0;
            }
            if self.live.out_alive.get(&v) == Some(&e.pid) && e.role == ProcessExit::AGENT {
                // The process of a vehicle lost while stopped died: no loss (it is out
                // already), but the death is told.
                self.live.out_alive.remove(&v);
                self.recorder.event(vbap_mission::rundir::Event {
                    t: self.k as f64 * self.dt,
                    k: self.k,
                    kind: "died".into(),
                    vehicle: Some(v),
                    detail: serde_json::json!({ "by": by, "pid": e.pid, "signal": e.signal }),
                })?;
                continue;
            }
            if !self.fleet.is_alive(v) || !ours {
                continue;
            }
            let ms = wall_ns().saturating_sub(e.died_ns) as f64 / 1e6;
            if e.role == ProcessExit::UNREACHABLE {
                // Its host's link is gone (across hosts): the process may live on, so its
                // next word, when the link is back, is a join request (as after silence).
                self.inbox.peers[v as usize].pid = 0;
                self.lose(
                    v,
                    Loss::found("host unreachable", "bridge", e.pid, Some(ms)),
                )?;
                lost = true;
                continue;
            }
            let cause = if e.signal != 0 {
                "process died"
            } else {
                "process ended"
            };
            self.lose(v, Loss::found(cause, by, e.pid, Some(ms)))?;
            lost = true;
        }
        Ok(lost)
    }

    /// Lockstep: loses the members whose agent the supervisor reported (or recorded) stopped
    /// [`STOPPED_GRACE`] ago and not continued: they will not report until continued, and
    /// a lockstep tick would wait for them (cause `stopped`, `by = "supervisor"`). The process stays: its next
    /// word, once continued, is a join request. A recorded stop is taken only when the
    /// vehicle was not heard from since ([`STOP_HEARD_SLACK`] after it): one heard later
    /// was continued, whatever the record says yet. A paced tick does not wait for a
    /// stopped member: there its silence is held to [`SILENCE_LIMIT`]. True when a vehicle
    /// was lost.
    fn stopped_members(&mut self) -> Result<bool> {
        let recorded = std::mem::take(&mut self.live.recorded_stops);
        if self.paced.is_some() {
            self.live.stopped.clear();
            return Ok(false);
        }
        let now = wall_ns();
        for e in recorded {
            let Some(peer) = self.inbox.peers.get(e.vehicle as usize) else {
                continue;
            };
            // Heard by this process (a resumed coordinator's silences are inherited: a stop
            // recorded while no coordinator ran, its last receipt restored after it, was
            // taken for a continue and the member lost as `silent` 10 s later).
            let heard_ns = heard_here(peer.last_recv, self.live.since, self.live.inherited_until)
                .map(|t| now.saturating_sub(t.elapsed().as_nanos() as u64));
            let heard_since =
                heard_ns.is_some_and(|h| h > e.died_ns + STOP_HEARD_SLACK.as_nanos() as u64);
            if !heard_since {
                self.live.stopped.entry(e.vehicle).or_insert(e);
            }
        }
        let mut lost = false;
        let due_ns = now.saturating_sub(STOPPED_GRACE.as_nanos() as u64);
        let (due, waiting): (BTreeMap<u32, ProcessExit>, _) =
            std::mem::take(&mut self.live.stopped)
                .into_iter()
                .partition(|(_, e)| e.died_ns <= due_ns);
        self.live.stopped = waiting;
        for (v, e) in due {
            let Some(peer) = self.inbox.peers.get(v as usize) else {
                continue;
            };
            // The supervisor tells only of its live children: a stopped process is the
            // vehicle's unless another is known (pid 0: none known yet, as in a resumed
            // coordinator, whose checkpoint keeps no pids).
            let ours = peer.pid == e.pid || peer.pid == 0;
            if !ours || !self.fleet.is_alive(v) {
                continue;
            }
            self.inbox.peers[v as usize].pid = 0; // its next word is a join request
            self.live.out_alive.insert(v, e.pid);
            let ms = now.saturating_sub(e.died_ns) as f64 / 1e6;
            self.lose(v, Loss::found("stopped", "supervisor", e.pid, Some(ms)))?;
            lost = true;
        }
        Ok(lost)
    }

    /// A new process asked to join for a vehicle still believed alive: the old one is gone
    /// (admitted at the start of the next tick). True when a vehicle was lost.
    fn restarted_unseen(&mut self) -> Result<bool> {
        let mut lost = false;
        for v in self.inbox.joins.clone() {
            if !self.fleet.is_alive(v) || self.faults.restart_pending(v, self.k) {
                continue;
            }
            let peer = &mut self.inbox.peers[v as usize];
            let ms = peer.restart_gap_ms.take();
            let pid = peer.pid;
            self.lose(v, Loss::found("process restarted", "join", pid, ms))?;
            lost = true;
        }
        Ok(lost)
    }

    /// Scans the node list once for every alive vehicle: a node listed dead, or gone after
    /// a process of it was known (at two scans in a row, both complete listings), is a
    /// death (`scan`); in a paced run a vehicle whose process is alive but silent for
    /// [`SILENCE_LIMIT`] is lost as `silent`. True when a vehicle was lost.
    fn scan(&mut self) -> Result<bool> {
        self.live.last_scan = Instant::now();
        let listing = self.ports.domain.node_listing();
        self.live.scan_cost = self.live.last_scan.elapsed();
        let alive: Vec<u32> = self.fleet.alive().collect();
        let (mut lost, mut any_dead) = (false, false);
        let gone_before = std::mem::take(&mut self.live.gone_at_last_scan);
        for v in alive {
            let peer = self.inbox.peers[v as usize];
            // A vehicle still starting up has no node yet.
            let heard = peer.last_recv.is_some() || self.live.resumed;
            let node = listing.states.get(&topics::agent_node_name(v));
            let gone = node.is_none() && heard && listing.complete;
            if gone {
                self.live.gone_at_last_scan.insert(v);
            }
            let verdict = match node {
                Some(true) => None,
                Some(false) => Some("process died"),
                None => (gone && gone_before.contains(&v)).then_some("process gone"),
            };
            if let Some(cause) = verdict {
                let ms = peer.last_recv.map(|t| t.elapsed().as_secs_f64() * 1e3);
                self.lose(v, Loss::found(cause, "scan", peer.pid, ms))?;
                any_dead = true;
            } else if self.paced.is_some() && node == Some(&true) {
                let quiet = self.live.silence_since_commanded(&peer);
                if quiet >= SILENCE_LIMIT {
                    self.inbox.peers[v as usize].pid = 0; // its next word is a join request
                    let ms = Some(quiet.as_secs_f64() * 1e3);
                    self.lose(v, Loss::found("silent", "silence", peer.pid, ms))?;
                    lost = true;
                }
            }
        }
        if any_dead {
            self.ports.domain.cleanup_dead_nodes();
        }
        Ok(lost || any_dead)
    }
}

/// A peer's last receipt `last_recv` if this coordinator process heard it: at or after the
/// process started (`since`) and, for a resumed coordinator, after the receipts it
/// restored from the checkpoint (`inherited_until`); None otherwise.
fn heard_here(
    last_recv: Option<Instant>,
    since: Instant,
    inherited_until: Option<Instant>,
) -> Option<Instant> {
    last_recv.filter(|t| *t >= since && inherited_until.is_none_or(|u| *t > u))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_receipt_restored_from_the_checkpoint_was_not_heard_by_this_process() {
        let since = Instant::now();
        let at = |ms: u64| Some(since + Duration::from_millis(ms));
        // A fresh coordinator: every receipt since it started was heard here.
        assert_eq!(heard_here(at(500), since, None), at(500));
        assert_eq!(heard_here(None, since, None), None);
        // Resumed: the receipts restored at 1 s (each `now − silence`) were not.
        let restored = since + Duration::from_secs(1);
        assert_eq!(heard_here(at(500), since, Some(restored)), None);
        assert_eq!(heard_here(at(1000), since, Some(restored)), None);
        assert_eq!(heard_here(at(1001), since, Some(restored)), at(1001));
        // Nothing before the process started counts.
        let later = since + Duration::from_secs(2);
        assert_eq!(heard_here(at(1500), later, None), None);
    }
}
