//! Gathering the states of a tick: all of them (lockstep), or what is in at the tick's
//! deadline (paced). The vehicles still missing are checked for liveness on a wall clock
//! of the coordinator's own ([`super::liveness`]).

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use anyhow::Result;
use serde::Serialize;
use tracing::{debug, warn};
use vbap_ipc::topics;
use vbap_ipc::wait::Wake;

use super::liveness::SUSPECT_AFTER;
use super::{Coordinator, Flow, GO, LOCKSTEP_TIMEOUT, STOP};
use crate::membership::Loss;
use crate::plan::Plan;

/// Least wait of a lockstep gather for a member before its silence (counted across
/// coordinator restarts) may lose it: an agent answers a command within it.
const OVERDUE_GRACE: Duration = Duration::from_secs(1);

impl<P: Plan + Serialize> Coordinator<'_, P> {
    /// Gathers the states of the tick; `admitted`: the vehicles admitted at this tick (no
    /// state of theirs is waited for). [`STOP`] on a termination signal.
    pub(super) fn gather(&mut self, admitted: &BTreeSet<u32>) -> Result<Flow> {
        let k = self.k;
        let first = k == 0 || self.inbox.peers.iter().all(|p| p.last_recv.is_none());
        // A paced mission waits for every vehicle once, at its very start; a resumed
        // coordinator keeps the mission's clock instead.
        let starting = k == 0 && !self.live.resumed;
        let wait_limit = if first {
            Duration::from_secs(30)
                + Duration::from_millis(100) * self.mission.vehicles.count as u32
        } else {
            LOCKSTEP_TIMEOUT
        };
        let gather_start = Instant::now();
        // Everything was just drained: from here on, read only what wakes us.
        let mut woken: Option<Vec<usize>> = Some(Vec::new());
        loop {
            self.inbox
                .drain_some(&self.ports.subscribers, &self.fleet, k, woken.as_deref())?;
            let missing = self.missing(admitted);
            // Liveness, on a wall clock of its own: tell a dead process from a slow one.
            if self.detect(&missing, gather_start)? {
                continue;
            }
            let timeout = match self.paced {
                None => self.lockstep_wait(&missing, gather_start, wait_limit)?,
                Some(period) => {
                    if starting && !missing.is_empty() {
                        Some(
                            wait_limit
                                .saturating_sub(gather_start.elapsed())
                                .min(SUSPECT_AFTER),
                        )
                    } else {
                        self.paced_wait(period, &missing, gather_start)
                    }
                }
            };
            let Some(timeout) = timeout else {
                return Ok(GO);
            };
            let mut ids = Vec::new();
            match self.ports.wait(timeout, &mut ids)? {
                Wake::Stop => return Ok(STOP),
                // Only vehicle events: drain just those subscribers; anything else (a
                // timeout, another event): drain all.
                Wake::Events
                    if !ids.is_empty() && ids.iter().all(|e| *e >= topics::EVENT_VEHICLE_BASE) =>
                {
                    woken = Some(ids)
                }
                _ => {
                    self.sensors.note_events(&ids);
                    woken = None
                }
            }
        }
    }

    /// Lockstep, before the mission's last message: waits until every alive agent has
    /// room for it in its command buffer (has acknowledged reading all but
    /// `Limits::body_buffer` − 1 commands). An agent that ran ahead to the end and still
    /// had a full buffer would otherwise lose its oldest unread command to the buffer's
    /// overflow, and with it that command's link fate and its receive record. Bounded by
    /// [`LOCKSTEP_TIMEOUT`] (a dead agent needs no room); [`STOP`] on a termination signal.
    pub(super) fn await_room_for_the_end(&mut self) -> Result<Flow> {
        if self.paced.is_some() {
            return Ok(GO);
        }
        let k = self.k;
        let start = Instant::now();
        loop {
            self.inbox
                .drain_some(&self.ports.subscribers, &self.fleet, k, None)?;
            let behind: Vec<u32> = self
                .fleet
                .alive()
                .filter(|&v| self.inbox.behind(v, k))
                .collect();
            if behind.is_empty() {
                return Ok(GO);
            }
            let left = LOCKSTEP_TIMEOUT.saturating_sub(start.elapsed());
            if left.is_zero() {
                warn!(
                    tick = k,
                    ?behind,
                    "the end of the mission: agents still behind, ending anyway"
                );
                return Ok(GO);
            }
            let mut ids = Vec::new();
            if let Wake::Stop = self.ports.wait(left.min(SUSPECT_AFTER), &mut ids)? {
                return Ok(STOP);
            }
        }
    }

    /// The alive vehicles whose state of the tick is not in yet, and in lockstep those
    /// whose agent could not take command `k` without overflowing its buffer.
    fn missing(&self, admitted: &BTreeSet<u32>) -> Vec<u32> {
        let k = self.k;
        let lockstep = self.paced.is_none();
        self.fleet
            .alive()
            .filter(|v| !admitted.contains(v))
            .filter(|&v| {
                (lockstep && self.inbox.behind(v, k))
                    || self
                        .inbox
                        .state(v, k, !lockstep)
                        .is_none_or(|s| s.header.tick < k)
            })
            .collect()
    }

    /// How long a lockstep gather waits next; None when it is over: every state is in, or
    /// the vehicles still missing were silent past `wait_limit` (those heard from before
    /// are lost as `silent`, and readmitted when they speak again).
    fn lockstep_wait(
        &mut self,
        missing: &[u32],
        gather_start: Instant,
        wait_limit: Duration,
    ) -> Result<Option<Duration>> {
        if missing.is_empty() {
            return Ok(None);
        }
        // A vehicle heard before and silent past the limit is lost, however recent this
        // gather (or this coordinator process, resumed with the silence it inherited) once
        // the gather has waited OVERDUE_GRACE for it: a coordinator that was itself held
        // up (a field server's outage) gives every agent that long to answer its command.
        let overdue: Vec<u32> = missing
            .iter()
            .copied()
            .filter(|&v| {
                gather_start.elapsed() >= OVERDUE_GRACE
                    && self.inbox.peers[v as usize]
                        .last_recv
                        .is_some_and(|t| t.elapsed() >= LOCKSTEP_TIMEOUT)
            })
            .collect();
        if !overdue.is_empty() {
            self.lose_silent(&overdue)?;
            return Ok(Some(Duration::ZERO));
        }
        let left = wait_limit.saturating_sub(gather_start.elapsed());
        if !left.is_zero() {
            return Ok(Some(left.min(SUSPECT_AFTER)));
        }
        warn!(
            tick = self.k,
            ?missing,
            "lockstep timeout: going on without the silent vehicles"
        );
        self.lose_silent(missing)?;
        Ok(None)
    }

    /// Loses the vehicles of `missing` heard from before as `silent` (their next word is a
    /// join request); a vehicle never heard from is still starting up.
    fn lose_silent(&mut self, missing: &[u32]) -> Result<()> {
        for &v in missing {
            let peer = &mut self.inbox.peers[v as usize];
            let Some(last) = peer.last_recv else {
                continue; // never heard: still starting up
            };
            let pid = std::mem::take(&mut peer.pid);
            let silent_ms = last.elapsed().as_secs_f64() * 1e3;
            self.lose(v, Loss::found("silent", "silence", pid, Some(silent_ms)))?;
        }
        Ok(())
    }

    /// How long a paced gather waits next; None at the tick's deadline (the tick is late
    /// when not every state was in, or when the coordinator itself came to the tick a
    /// period or more after it: an outage being caught up, an overload).
    fn paced_wait(
        &mut self,
        period: f64,
        missing: &[u32],
        gather_start: Instant,
    ) -> Option<Duration> {
        let k = self.k;
        let deadline = self.clock.start() + Duration::from_secs_f64(period * k as f64);
        let now = Instant::now();
        if now < deadline {
            return Some((deadline - now).min(SUSPECT_AFTER));
        }
        let behind = gather_start >= deadline + Duration::from_secs_f64(period);
        if !missing.is_empty() || behind {
            self.books.late_ticks += 1;
            debug!(
                tick = k,
                ?missing,
                behind,
                "late tick: not every state was in at the deadline"
            );
        }
        None
    }
}
