//! The mission's scheduled kills and restarts (`[[faults]]` of kind `kill`), and the
//! admission of vehicles whose process came back unscheduled.

use std::time::{Duration, Instant};

use anyhow::Result;
use serde::Serialize;
use tracing::{info, warn};
use vbap_ipc::topics;
use vbap_ipc::wait::Wake;

use super::{Coordinator, Flow, GO, LOCKSTEP_TIMEOUT, STOP};
use crate::membership::{self, Loss};
use crate::plan::Plan;

/// How long a scheduled kill waits for the victim's node to be seen dead.
const KILL_TIMEOUT: Duration = Duration::from_secs(5);

impl<P: Plan + Serialize> Coordinator<'_, P> {
    /// The kills scheduled at this tick: a real SIGKILL of the agent's process, then a wait
    /// until its node is seen dead (by a complete node listing); the vehicle is lost.
    /// [`STOP`] on a termination signal.
    pub(super) fn scheduled_kills(&mut self) -> Result<Flow> {
        let k = self.k;
        for v in self.faults.kills_at(k).collect::<Vec<_>>() {
            if !self.fleet.is_alive(v) {
                continue;
            }
            let pid = self.inbox.peers[v as usize].pid;
            let killed = vbap_ipc::process::sigkill(pid);
            let name = topics::agent_node_name(v);
            let started = Instant::now();
            let domain = &self.ports.domain;
            // Seen dead: a complete listing without the node alive (a name missing from an
            // incomplete one says nothing).
            let seen_alive = || {
                let listing = domain.node_listing();
                !listing.complete || listing.states.get(&name).copied().unwrap_or(false)
            };
            while seen_alive() && started.elapsed() < KILL_TIMEOUT {
                let mut ids = Vec::new();
                if self.ports.wait(Duration::from_millis(2), &mut ids)? == Wake::Stop {
                    return Ok(STOP);
                }
                self.sensors.note_events(&ids);
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
            self.lose(v, Loss::scheduled_kill())?;
        }
        Ok(GO)
    }

    /// The restarts scheduled at this tick: waits for the restarted agent's join request,
    /// then admits it. [`STOP`] on a termination signal.
    pub(super) fn scheduled_restarts(&mut self) -> Result<Flow> {
        let k = self.k;
        for v in self.faults.restarts_at(k).collect::<Vec<_>>() {
            let started = Instant::now();
            while !self.inbox.joins.contains(&v) && started.elapsed() < LOCKSTEP_TIMEOUT {
                self.inbox.drain(&self.ports.subscribers, &self.fleet, k)?;
                if self.inbox.joins.contains(&v) {
                    break;
                }
                let mut ids = Vec::new();
                if self.ports.wait(Duration::from_millis(100), &mut ids)? == Wake::Stop {
                    return Ok(STOP);
                }
                self.sensors.note_events(&ids);
            }
            if !(self.inbox.joins.remove(&v) && self.rejoin(v)?) {
                warn!(
                    vehicle = v,
                    tick = k,
                    "scheduled restart: the vehicle did not ask to join in time"
                );
            }
        }
        Ok(GO)
    }

    /// Unscheduled returns (a process restarted after a crash) are admitted at once; a
    /// vehicle still believed alive is lost first (its process was restarted before we
    /// noticed it die).
    pub(super) fn admit_returns(&mut self) -> Result<()> {
        let k = self.k;
        self.inbox.drain(&self.ports.subscribers, &self.fleet, k)?;
        for v in self.inbox.joins.clone() {
            if self.faults.restart_pending(v, k) {
                continue;
            }
            if self.fleet.is_alive(v) {
                let peer = &mut self.inbox.peers[v as usize];
                let ms = peer.restart_gap_ms.take();
                let pid = peer.pid;
                self.lose(v, Loss::found("process restarted", "join", pid, ms))?;
            }
            self.rejoin(v)?;
        }
        Ok(())
    }

    /// Lost vehicle `v` is admitted back at this tick (the event written, the latency
    /// from its join request kept); false when it cannot be (not lost, never heard of).
    fn rejoin(&mut self, v: u32) -> Result<bool> {
        let Some((_, event)) = membership::rejoin(&mut self.fleet, self.k, self.dt, v) else {
            return Ok(false);
        };
        self.inbox.joins.remove(&v);
        if let Some(at) = self.inbox.peers[v as usize].join_request {
            self.books.rejoin_ms.push(at.elapsed().as_secs_f64() * 1e3);
        }
        self.recorder.event(event)?;
        Ok(true)
    }
}
