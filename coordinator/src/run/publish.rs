//! The planner's step of a tick and the body command it publishes; the mission's last
//! command and the summary at the end.

use anyhow::Result;
use serde::Serialize;
use tracing::info;
use vbap_ipc::msg::Header;
use vbap_mission::link::Fate;
use vbap_mission::rundir::Summary;

use super::Coordinator;
use crate::command::{fill_finished, BodyRecord};
use crate::plan::Plan;
use crate::planner::{Report, Told};
use crate::tally::process_counts;
use crate::tick::{plan_tick, TickOutcome};

impl<P: Plan + Serialize> Coordinator<'_, P> {
    /// The planner's step on the true reports `truth` of the tick (link model, rows of the
    /// run directory: [`plan_tick`], shared with the simulator); the link model's holds
    /// and drops go to the message records. Returns the command to publish.
    /// `told`: what each vehicle says of itself (its belief).
    pub(super) fn plan(&mut self, truth: &[Report], told: &[Told]) -> Result<BodyRecord> {
        let k = self.k;
        let TickOutcome {
            fates,
            command,
            mut snapshot,
            near,
        } = plan_tick(
            k,
            self.dt,
            truth,
            told,
            &mut self.fleet,
            &mut self.planner,
            &mut self.recorder,
        )?;
        let msgs = &mut self.inbox.msgs;
        for (v, fate) in &fates {
            match fate {
                Fate::Deliver { injected, .. } if *injected > 0.0 => {
                    msgs.held("state", *v, Header::COORDINATOR, k, *injected)
                }
                Fate::Drop(reason) => {
                    msgs.drop("state", *v, Header::COORDINATOR, k, reason.as_str())
                }
                _ => {}
            }
        }
        // Each entry names the process it is about: an admission is that process's only.
        for e in &mut snapshot {
            e.incarnation = self.inbox.incarnation(e.id);
        }
        Ok(BodyRecord::from_command(k, self.dt, &command, snapshot).with_near(near))
    }

    /// Publishes the command `record` (zero copy into the subscribers' shared memory) and
    /// wakes the agents: every one in a paced run; in lockstep those that may need it now
    /// ([`super::inbox::Inbox::needs_wake`]: not an agent running ahead with room left in
    /// its command buffer).
    pub(super) fn publish(&mut self, record: &BodyRecord) -> Result<()> {
        record.fill(&mut self.body);
        self.ports.publish(&mut self.body)?;
        self.live
            .commanded
            .get_or_insert_with(std::time::Instant::now);
        if self.paced.is_some() {
            self.ports.wake_agents();
        } else {
            let (inbox, k) = (&self.inbox, record.tick);
            self.ports.wake_agents_where(|v| inbox.needs_wake(v, k));
        }
        Ok(())
    }

    /// Ends the mission: tells everyone it is over (the last command, best effort), flushes
    /// the files and returns the summary (for the caller to hand over or write: see
    /// [`crate::handover`]). `stopped`: ended by a termination signal.
    pub(super) fn finish(mut self, stopped: bool) -> Result<Summary> {
        let k = self.k;
        fill_finished(&mut self.body, k, self.dt);
        let _ = self.ports.publish(&mut self.body);
        self.ports.wake_agents();
        let _ = self.sensors.notify_field();
        self.inbox.msgs.flush();

        self.recorder.flush()?;
        let mut summary = self.recorder.summary(&self.planner, "multi-process");
        summary.messages = process_counts(self.inbox.counts, self.books.sent, &self.fleet);
        summary.late_ticks = self.books.late_ticks;
        summary.detection_latency_ms = self.books.detection_ms;
        summary.rejoin_latency_ms = self.books.rejoin_ms;
        info!(
            ticks = k,
            stopped,
            delivered = self.inbox.counts.delivered,
            rejected = self.inbox.counts.rejected,
            late_ticks = self.books.late_ticks,
            "coordinator done"
        );
        Ok(summary)
    }
}
