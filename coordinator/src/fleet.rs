//! The coordinator's view of the fleet: who is alive, what it last heard from each
//! vehicle through the link model, who was lost and who is admitted back. Pure: the
//! in-process simulator and the coordinator process both drive it.

use std::collections::{BTreeMap, BTreeSet};

use vbap_ipc::msg::coordinator_to_agent::SnapshotEntry;
use vbap_ipc::msg::from_vec3;
use vbap_math::Vec3;
use vbap_mission::config::Mission;
use vbap_mission::link::{DelayQueue, Direction, Fate, LinkModel, LinkState};

use crate::planner::{Report, Told};

/// The size of one state report as a vehicle's link carries it, bytes
/// (`vbap_ipc::compact::StateReport`).
const REPORT_BYTES: u64 = vbap_ipc::compact::StateReport::LEN as u64;

/// Counters of the uplink (vehicle → coordinator).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct UplinkCounts {
    /// Reports delivered by the link model.
    pub delivered: u64,
    /// Reports dropped by the link model.
    pub dropped_injected: u64,
}

/// The fleet as the coordinator knows it.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Fleet {
    model: LinkModel,
    links: BTreeMap<u32, LinkState>,
    /// Reports held by the link model. Not in the checkpoint itself: it can hold hours of
    /// stored-and-forwarded reports, so the checkpoint journals it (see
    /// [`Fleet::restore_journaled`]).
    #[serde(skip)]
    inbox: DelayQueue<Report>,
    /// Mission time of the last release from `inbox` (every report due by then is out).
    last_release: f64,
    /// (vehicle, sequence bound): the reports of a lost vehicle held before it was lost
    /// (sequence numbers below the bound) were dropped.
    purged: Vec<(u32, u64)>,
    alive: BTreeSet<u32>,
    latest: BTreeMap<u32, Report>,
    last_truth: BTreeMap<u32, Report>,
    /// The last report delivered from each lost vehicle (its `latest` when it was lost),
    /// dead-reckoned with the body to the loss: where its hull is, which the snapshot tells
    /// the others ([`Fleet::snapshot`]). Until it is admitted back.
    #[serde(default)]
    hulls: BTreeMap<u32, Report>,
    lost: BTreeSet<u32>,
    admitted: Vec<Report>,
    /// Vehicles with at least one report delivered (the planned start states in `latest`
    /// are no information).
    heard: BTreeSet<u32>,
    /// Virtual body centre at each tick still needed for dead reckoning (journaled like
    /// `inbox`).
    #[serde(skip)]
    body_track: BTreeMap<u64, Vec3>,
    /// Uplink counters.
    pub counts: UplinkCounts,
    /// A horizontal formation of diving gliders (`Mission::diving`): what the coordinator
    /// hears is seen in the formation's plane (z and ż dropped).
    horizontal: bool,
    /// The longest a vehicle may fly on one command, s
    /// (`vbap_mission::horizon::plan_horizon` of the links, whatever the law): how far each
    /// vehicle is told of its neighbours reaches that far ([`crate::near`]).
    #[serde(default)]
    command_horizon: f64,
    /// `links.position_quantum`: the precision of what each vehicle is told, length unit
    /// (0: exact).
    #[serde(default)]
    position_quantum: f64,
}

impl Fleet {
    /// The fleet of `mission` at the start: vehicles `ids` alive, nothing heard yet.
    ///
    /// Until a vehicle's first report arrives, the coordinator assumes it where it was
    /// deployed: at rest in its slot of the initial formation around `vehicles.start` (what
    /// the operators planned), so a link that delays the first reports does not make the
    /// formation look smaller than it is.
    pub fn new(mission: &Mission, ids: &[u32]) -> Self {
        let planned = mission
            .formation_design()
            .map(|d| d.slots)
            .unwrap_or_default();
        let latest = ids
            .iter()
            .filter_map(|&id| {
                planned.get(id as usize).map(|slot| {
                    (
                        id,
                        Report {
                            id,
                            tick: 0,
                            position: mission.start_vec() + slot,
                            velocity: Vec3::zeros(),
                            measurement: f64::NAN,
                        },
                    )
                })
            })
            .collect();
        Self {
            model: LinkModel::new(mission),
            links: BTreeMap::new(),
            inbox: DelayQueue::default(),
            last_release: f64::NEG_INFINITY,
            purged: Vec::new(),
            alive: ids.iter().copied().collect(),
            latest,
            last_truth: BTreeMap::new(),
            hulls: BTreeMap::new(),
            lost: BTreeSet::new(),
            admitted: Vec::new(),
            heard: BTreeSet::new(),
            body_track: BTreeMap::new(),
            counts: UplinkCounts::default(),
            horizontal: mission.diving(),
            command_horizon: vbap_mission::horizon::plan_horizon(
                &mission.links,
                mission.mission.dt,
            ),
            position_quantum: mission.links.position_quantum,
        }
    }

    /// The longest a vehicle may fly on one command, s (see the field).
    pub fn command_horizon(&self) -> f64 {
        self.command_horizon
    }

    /// The precision of what each vehicle is told (`links.position_quantum`).
    pub fn precision(&self) -> vbap_ipc::compact::Precision {
        vbap_ipc::compact::Precision::of_quantum(self.position_quantum)
    }

    /// `q` as the coordinator sees it: in the formation's plane for diving gliders.
    fn seen(&self, q: Report) -> Report {
        if !self.horizontal {
            return q;
        }
        let flat = |v: Vec3| Vec3::new(v.x, v.y, 0.0);
        Report {
            position: flat(q.position),
            velocity: flat(q.velocity),
            ..q
        }
    }

    /// The link model.
    pub fn model(&self) -> &LinkModel {
        &self.model
    }

    /// True when vehicle `v` is alive (its process runs, as far as the coordinator knows).
    pub fn is_alive(&self, v: u32) -> bool {
        self.alive.contains(&v)
    }

    /// The alive vehicles, ordered by id.
    pub fn alive(&self) -> impl Iterator<Item = u32> + '_ {
        self.alive.iter().copied()
    }

    /// The newest report of vehicle `v` the link model delivered (the coordinator's newest
    /// information about it, as taken at its `tick`); `None` when none was delivered since
    /// the start or since the vehicle was lost.
    pub fn newest_report(&self, v: u32) -> Option<&Report> {
        if self.heard.contains(&v) {
            self.latest.get(&v)
        } else {
            None
        }
    }

    /// True when vehicle `v` was lost and not admitted back.
    pub fn is_lost(&self, v: u32) -> bool {
        self.lost.contains(&v)
    }

    /// The reports held by the link model: (delivery time, sequence number, report) in
    /// the order they were held, and the sequence number of the next one.
    pub fn held_reports(&self) -> (&[(f64, u64, Report)], u64) {
        (self.inbox.held(), self.inbox.next_seq())
    }

    /// The body track kept for dead reckoning: tick → virtual body centre.
    pub fn body_track(&self) -> &BTreeMap<u64, Vec3> {
        &self.body_track
    }

    /// Restores the journaled parts of a fleet read back from a checkpoint: `held` is
    /// every report ever held up to the checkpoint (in the order held; those released or
    /// purged since are skipped), `next` the sequence number of the next one; `track` the
    /// body track journal, of which the ticks from `track_from` on are kept.
    pub fn restore_journaled(
        &mut self,
        next: u64,
        held: impl IntoIterator<Item = (f64, u64, Report)>,
        track: impl IntoIterator<Item = (u64, Vec3)>,
        track_from: Option<u64>,
    ) {
        let kept = held
            .into_iter()
            .filter(|(at, seq, r)| {
                *at > self.last_release
                    && *seq < next
                    && !self
                        .purged
                        .iter()
                        .any(|(v, bound)| *v == r.id && *seq < *bound)
            })
            .collect();
        self.inbox = DelayQueue::from_parts(next, kept);
        self.body_track = match track_from {
            Some(from) => track.into_iter().filter(|(k, _)| *k >= from).collect(),
            None => BTreeMap::new(),
        };
    }

    /// Vehicle `v` is gone (killed, dead): forget what it sent that is still in flight
    /// (a glider that dies under water takes its held reports with it), counted as
    /// dropped by the link. Returns the ticks of those reports (for the message records);
    /// None when it was not alive.
    pub fn lose(&mut self, v: u32) -> Option<Vec<u64>> {
        if !self.alive.remove(&v) {
            return None;
        }
        self.lost.insert(v);
        if let Some(last) = self.latest.remove(&v) {
            self.hulls.insert(v, self.dead_reckoned(&last));
        }
        let in_flight: Vec<u64> = self
            .inbox
            .held()
            .iter()
            .filter(|(_, _, r)| r.id == v)
            .map(|(_, _, r)| r.tick)
            .collect();
        self.counts.dropped_injected += in_flight.len() as u64;
        self.purged.push((v, self.inbox.next_seq()));
        self.inbox.retain(|r| r.id != v);
        self.admitted.retain(|r| r.id != v);
        Some(in_flight)
    }

    /// Where the vehicle of `last` is now, as a member out of contact is dead-reckoned
    /// ([`Fleet::deliver`]): its place relative to the body kept, moved by the body's
    /// motion since the report, `r(now) − r(j)`. A lost vehicle's hull is where it was
    /// when it was lost (a restarted process comes back there), not where it last
    /// reported: over a 1 s link a moving formation is a tenth of a spacing further on.
    fn dead_reckoned(&self, last: &Report) -> Report {
        Report {
            tick: self
                .body_track
                .last_key_value()
                .map_or(last.tick, |(&k, _)| k),
            position: last.position + self.body_shift(last.tick),
            ..*last
        }
    }

    /// How far the virtual body moved since tick `j`, `r(now) − r(j)` (length unit; `now`
    /// the last tick tracked): what a vehicle that keeps its place in the body moved by.
    /// Zero when either is not tracked.
    fn body_shift(&self, j: u64) -> Vec3 {
        match (
            self.body_track.values().next_back(),
            self.body_track.get(&j),
        ) {
            (Some(now), Some(then)) => now - then,
            _ => Vec3::zeros(),
        }
    }

    /// Admits lost vehicle `v` back at this tick, at its last true state; returns that
    /// state (the restarted agent resumes from it). `None` when `v` is not lost or was
    /// never heard of.
    pub fn admit(&mut self, v: u32) -> Option<Report> {
        if !self.lost.contains(&v) {
            return None;
        }
        let restore = *self.last_truth.get(&v)?;
        self.lost.remove(&v);
        self.hulls.remove(&v);
        self.alive.insert(v);
        self.admitted.push(restore);
        Some(restore)
    }

    /// Vehicles admitted at this tick. Each is a member from this tick on, at its restore
    /// state, until its own reports are delivered ([`Fleet::deliver`]): the planner guides
    /// it back into a slot at once, wherever it is.
    pub fn admitted(&self) -> &[Report] {
        &self.admitted
    }

    /// The true reports of tick `k` (ordered by id, alive vehicles only) arrive: the link
    /// model decides when each becomes visible. Returns every fate, for the logs.
    pub fn receive(&mut self, k: u64, dt: f64, truth: &[Report]) -> Vec<(u32, Fate)> {
        self.receive_told(k, dt, truth, &[])
    }

    /// [`Fleet::receive`] where each vehicle of `told` says its own position and velocity
    /// (its belief, its water velocity): the link carries what it says, the restore state
    /// of a lost vehicle stays the truth.
    pub fn receive_told(
        &mut self,
        k: u64,
        dt: f64,
        truth: &[Report],
        told: &[Told],
    ) -> Vec<(u32, Fate)> {
        let t = k as f64 * dt;
        let mut fates = Vec::with_capacity(truth.len());
        for q in truth {
            self.last_truth.insert(q.id, self.seen(*q));
            let sent = self.seen(told.iter().find(|s| s.id == q.id).map_or(*q, |s| Report {
                position: s.position,
                velocity: s.water,
                ..*q
            }));
            let state = self.links.entry(q.id).or_default();
            let fate = self.model.fate(state, q.id, Direction::Uplink, q.tick, t);
            let fate = self
                .model
                .carry(fate, q.id, Direction::Uplink, q.tick, t, REPORT_BYTES);
            match fate {
                Fate::Deliver { at, .. } => self.inbox.push(at, sent),
                Fate::Drop(_) => self.counts.dropped_injected += 1,
            }
            fates.push((q.id, fate));
        }
        fates
    }

    /// The virtual body centre at tick `k` (call before [`Fleet::deliver`] of that tick).
    pub fn track_body(&mut self, k: u64, r: Vec3) {
        self.body_track.insert(k, r);
        // Keep what the oldest report still in use or in flight may need.
        let oldest = self
            .latest
            .values()
            .map(|r| r.tick)
            .chain(self.last_truth.values().map(|r| r.tick))
            .min()
            .unwrap_or(k);
        while self
            .body_track
            .first_key_value()
            .is_some_and(|(t, _)| *t < oldest)
        {
            self.body_track.pop_first();
        }
    }

    /// Releases the reports due at mission time `t` (tick length `dt`): returns (members, fresh) for the
    /// planner — the latest delivered report of every alive vehicle (ordered by id) and
    /// the reports delivered now (in delivery order).
    pub fn deliver(&mut self, t: f64, dt: f64) -> (Vec<Report>, Vec<Report>) {
        self.last_release = t;
        // Vehicles admitted now are members at their restore state (known exactly: it is
        // the state the agent resumes from), as of this tick.
        let k = (t / dt).round() as u64;
        for r in &self.admitted {
            if self.alive.contains(&r.id) && !self.latest.contains_key(&r.id) {
                self.latest.insert(r.id, Report { tick: k, ..*r });
            }
        }
        let fresh: Vec<Report> = self
            .inbox
            .pop_due(t)
            .into_iter()
            .filter(|r| self.alive.contains(&r.id))
            .collect();
        for r in &fresh {
            self.counts.delivered += 1;
            self.heard.insert(r.id);
            match self.latest.get(&r.id) {
                Some(old) if old.tick > r.tick => {}
                _ => {
                    self.latest.insert(r.id, *r);
                }
            }
        }
        // Members out of contact are dead-reckoned: they keep their place relative to
        // the virtual body (`Fleet::body_shift`).
        let members = self
            .alive
            .iter()
            .filter_map(|v| self.latest.get(v))
            .map(|r| Report {
                position: r.position + self.body_shift(r.tick),
                ..*r
            })
            .collect();
        (members, fresh)
    }

    /// The swarm snapshot of this tick: members (their last delivered state; those admitted
    /// now flagged [`SnapshotEntry::ADMITTED`], at their restore state; those in
    /// `rejoining` flagged rejoining, with the slot they fly to) and lost vehicles (the last
    /// state heard from each: where its hull was last known to be, never the truth),
    /// ordered by id.
    pub fn snapshot(&self, members: &[Report], rejoining: &[(u32, Vec3)]) -> Vec<SnapshotEntry> {
        let entry = |r: &Report, alive: u32| {
            let target = rejoining
                .iter()
                .find(|(id, _)| *id == r.id)
                .map(|(_, t)| *t);
            SnapshotEntry {
                id: r.id,
                alive,
                rejoining: u32::from(target.is_some()),
                incarnation: 0,
                position: from_vec3(&r.position),
                velocity: from_vec3(&r.velocity),
                target: from_vec3(&target.unwrap_or_else(Vec3::zeros)),
                ..SnapshotEntry::default()
            }
        };
        let mut rows: Vec<SnapshotEntry> = members
            .iter()
            .map(|r| {
                let alive = if self.admitted.iter().any(|a| a.id == r.id) {
                    SnapshotEntry::ADMITTED
                } else {
                    SnapshotEntry::MEMBER
                };
                entry(r, alive)
            })
            .chain(
                self.lost
                    .iter()
                    .filter_map(|v| self.hulls.get(v))
                    .map(|r| entry(r, SnapshotEntry::LOST)),
            )
            .collect();
        rows.sort_by_key(|e| e.id);
        rows
    }

    /// Where each lost vehicle was last heard of (its hull; ordered by id), length unit.
    pub fn hulls(&self) -> Vec<Vec3> {
        self.hulls.values().map(|r| r.position).collect()
    }

    /// Ends the tick (admissions become ordinary).
    pub fn end_tick(&mut self) {
        self.admitted.clear();
    }
}
