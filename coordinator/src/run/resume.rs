//! The start of a coordinator: a new run, or a restarted coordinator's resumption from its
//! checkpoint (the run files cut back to it, the last command published again, the
//! mission's wall clock kept); and the checkpoint written every tick.

use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use serde::de::DeserializeOwned;
use serde::Serialize;
use tracing::info;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::wall_ns;
use vbap_ipc::msglog::MsgLog;
use vbap_mission::config::{Mission, Pace, RestartPolicy};
use vbap_mission::faults::FaultPlan;
use vbap_mission::rundir::RunDir;

use super::inbox::Inbox;
use super::liveness::Liveness;
use super::ports::Ports;
use super::sensors::SensorReads;
use super::{Books, Coordinator, MissionClock};
use crate::checkpoint::{Checkpoint, CheckpointRef, CheckpointWriter, JournalMarks, PeerMark};
use crate::command::BodyRecord;
use crate::fleet::Fleet;
use crate::plan::Plan;
use crate::planner::PlannerError;
use crate::record::Recorder;
use std::sync::Arc;
use vbap_mission::field::ScalarField;

/// What a new or resumed coordinator starts from.
struct Start<P> {
    planner: P,
    fleet: Fleet,
    recorder: Recorder,
    next_tick: u64,
    books: Books,
    clock: MissionClock,
    /// The command of the checkpoint's tick, to publish again.
    republish: Option<BodyRecord>,
}

/// What a coordinator starts with besides its ports.
pub(super) struct Setup<F> {
    /// The message records of this process.
    pub msgs: MsgLog,
    /// The field the run is judged by (the field server's).
    pub truth: Arc<dyn ScalarField>,
    /// Makes the planner of a new run for the vehicles it is given.
    pub new_planner: F,
}

impl<'a, P: Plan + Serialize + DeserializeOwned> Coordinator<'a, P> {
    /// The coordinator of `mission` writing into `dir` through `ports`: resumed from the
    /// checkpoint of `dir` when there is one (with the command to publish again), else new
    /// (with the planner `new_planner` makes); the run is judged by the field `truth`.
    pub(super) fn start(
        mission: &'a Mission,
        dir: &'a RunDir,
        ports: &'a Ports,
        sensors: SensorReads,
        mut live: Liveness,
        setup: Setup<impl FnOnce(&[u32]) -> Result<P, PlannerError>>,
    ) -> Result<(Self, Option<BodyRecord>)> {
        let Setup {
            msgs,
            truth,
            new_planner,
        } = setup;
        let n = mission.vehicles.count;
        let dt = mission.mission.dt;
        let ids: Vec<u32> = (0..n as u32).collect();
        let mut inbox = Inbox::new(n, msgs);
        let resumed: Option<Checkpoint<P>> =
            Checkpoint::load(dir).context("reading the checkpoint")?;
        let resumed_marks = resumed.as_ref().map(|cp| cp.journal);
        let start = match resumed {
            Some(mut cp) => {
                cp.planner.restored(mission);
                resume(cp, mission, dir, &mut inbox, &mut live, truth)?
            }
            None => Start {
                planner: new_planner(&ids)?,
                fleet: Fleet::new(mission, &ids),
                recorder: Recorder::open_with(mission, dir, truth)
                    .context("opening the run directory files")?,
                next_tick: 0,
                books: Books::default(),
                clock: MissionClock::default(),
                republish: None,
            },
        };
        // A coordinator that is never restarted needs no checkpoint.
        let checkpoints = match mission.restart.coordinator {
            RestartPolicy::Never => None,
            _ => Some(
                CheckpointWriter::open(dir, resumed_marks)
                    .context("opening the checkpoint files")?,
            ),
        };
        let c = Coordinator {
            mission,
            dt,
            paced: match mission.mission.pace {
                Pace::Lockstep => None,
                Pace::Factor(f) => Some(dt / f),
            },
            ports,
            sensors,
            live,
            inbox,
            faults: FaultPlan::new(mission),
            fleet: start.fleet,
            planner: start.planner,
            recorder: start.recorder,
            books: start.books,
            clock: start.clock,
            checkpoints,
            body: Box::new(BodyCommand::empty()),
            k: start.next_tick,
        };
        Ok((c, start.republish))
    }
}

impl<P: Plan + Serialize> Coordinator<'_, P> {
    /// Writes the checkpoint of this tick, whose command is `record` (before it is
    /// published: a coordinator restarted after this point re-publishes this very command
    /// and goes on with the next tick).
    pub(super) fn checkpoint(&mut self, record: &BodyRecord) -> Result<()> {
        let Some(writer) = self.checkpoints.as_mut() else {
            return Ok(());
        };
        self.recorder.flush()?;
        let peers: Vec<PeerMark> = self
            .inbox
            .peers
            .iter()
            .map(|p| PeerMark {
                pid: p.pid,
                last_seq: p.last_seq,
                used_tick: p.used_tick,
                incarnation: p.incarnation,
                silent_ns: p.last_recv.map(silent_ns),
            })
            .collect();
        CheckpointRef {
            next_tick: self.k + 1,
            planner: &self.planner,
            fleet: &self.fleet,
            stats: self.recorder.stats(),
            offsets: self.recorder.offsets(),
            counts: self.inbox.counts,
            sent: self.books.sent + 1,
            late_ticks: self.books.late_ticks,
            detection_ms: &self.books.detection_ms,
            rejoin_ms: &self.books.rejoin_ms,
            peers: &peers,
            body: record,
            clock_start_ns: self.clock.start_ns,
            journal: JournalMarks::default(),
        }
        .save_with(writer)
        .context("writing the checkpoint")
    }
}

/// A restarted coordinator's start from checkpoint `cp`: the run files of `dir` cut back
/// to it, the peers and counts of `inbox` restored, `live` told it resumed, the run judged
/// by `truth`.
fn resume<P>(
    cp: Checkpoint<P>,
    mission: &Mission,
    dir: &RunDir,
    inbox: &mut Inbox,
    live: &mut Liveness,
    truth: Arc<dyn ScalarField>,
) -> Result<Start<P>> {
    dir.truncate_to(&cp.offsets)
        .context("cutting the run files back to the checkpoint")?;
    let now = Instant::now();
    for (peer, mark) in inbox.peers.iter_mut().zip(&cp.peers) {
        peer.pid = mark.pid;
        peer.last_seq = mark.last_seq;
        peer.used_tick = mark.used_tick;
        peer.incarnation = mark.incarnation;
        // Silence goes on counting from what the dead coordinator had counted.
        peer.last_recv = mark.silent_ns.map(|ns| heard_before(ns, now));
    }
    live.inherited_until = Some(now);
    inbox.counts = cp.counts;
    info!(
        tick = cp.next_tick,
        "resumed from the checkpoint: re-publishing the last command"
    );
    live.resumed = true;
    // Deaths the supervisor recorded while no coordinator listened (and older ones, of
    // processes no longer ours: ignored as such).
    live.recorded = crate::exits::agent_deaths(&dir.root);
    // Agents stopped and not continued: a lockstep tick does not wait for them.
    live.recorded_stops = crate::exits::agents_stopped_by(&dir.root, wall_ns());
    // The mission's wall clock goes on: the ticks missed while no coordinator ran are due
    // already (caught up, late), not postponed by the outage.
    let mut clock = MissionClock::default();
    if let Some(ns) = cp.clock_start_ns {
        let ago = Duration::from_nanos(wall_ns().saturating_sub(ns));
        clock.start = Some(Instant::now().checked_sub(ago).unwrap_or_else(Instant::now));
        clock.start_ns = Some(ns);
    }
    // The mission was commanded long before: silence is not counted from our first command.
    live.commanded = Some(clock.start.unwrap_or(live.since));
    let recorder = Recorder::resume_with(mission, dir, cp.stats, truth)
        .context("opening the run directory files")?;
    Ok(Start {
        planner: cp.planner,
        fleet: cp.fleet,
        recorder,
        next_tick: cp.next_tick,
        books: Books {
            detection_ms: cp.detection_ms,
            rejoin_ms: cp.rejoin_ms,
            late_ticks: cp.late_ticks,
            sent: cp.sent,
        },
        clock,
        republish: Some(cp.body),
    })
}

/// Silence since instant `heard`, ns (what a checkpoint keeps of a vehicle's last message).
fn silent_ns(heard: Instant) -> u64 {
    heard.elapsed().as_nanos().min(u64::MAX as u128) as u64
}

/// The instant `silent` ns before `now` (the last message of a vehicle silent that long; the
/// earliest instant the monotonic clock can name when that is before its origin).
fn heard_before(silent: u64, now: Instant) -> Instant {
    let mut ago = Duration::from_nanos(silent);
    loop {
        if let Some(t) = now.checked_sub(ago) {
            return t;
        }
        ago /= 2;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vehicle silent 8 s at the last checkpoint of a coordinator is silent 8 s for the
    /// coordinator resumed from it (not 0), however long the outage between them: restarts
    /// neither reset nor advance the liveness limit.
    #[test]
    fn silence_survives_a_restart_through_the_checkpoint() {
        let now = Instant::now();
        let start = Instant::now();
        let Some(heard) = now.checked_sub(Duration::from_secs(8)) else {
            return; // a monotonic clock younger than 8 s: nothing to check
        };
        let kept = silent_ns(heard);
        assert!(kept >= 8_000_000_000, "{kept}");
        let resumed = Instant::now() + Duration::from_secs(3); // after a 3 s outage
        let restored = heard_before(kept, resumed);
        let silence = resumed.duration_since(restored);
        assert!(silence >= Duration::from_secs(8), "{silence:?}");
        // Only the time this test took is added.
        assert!(
            silence <= Duration::from_secs(8) + start.elapsed(),
            "{silence:?}"
        );
        // Never heard stays never heard; a silence longer than the clock is the clock's origin.
        assert_eq!(heard_before(0, resumed), resumed);
        assert!(heard_before(u64::MAX, resumed) <= resumed);
    }
}
