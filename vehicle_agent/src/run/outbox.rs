//! The agent's outgoing side: its state messages, numbered, and the recent ones kept for a
//! restarted coordinator.

use std::collections::VecDeque;

use anyhow::Result;
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::{from_vec3, Header};
use vbap_ipc::ports::Sender;
use vbap_ipc::topics::Limits;

use crate::Vehicle;

/// When a published state wakes the coordinator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Announce {
    /// With the state: the coordinator gathers its tick now (or next).
    Now,
    /// Once for all the states published so, by [`Outbox::announce`] before the agent next
    /// waits: states the coordinator will not need before then (a lockstep agent running
    /// ahead). It drains every state of a vehicle on its wake-up, so nothing is missed; a
    /// submerged glider costs one wake-up per run-ahead instead of one per tick.
    BeforeNextWait,
}

/// Publishes vehicle `id`'s states and wakes the coordinator with each.
pub(super) struct Outbox {
    sender: Sender<VehicleState>,
    id: u32,
    pid: u32,
    /// This process's incarnation (`VehicleState::incarnation`).
    incarnation: u32,
    /// Control period, s (a state of tick k is at t = k·dt).
    dt: f64,
    /// The sequence number of the last message sent.
    seq: u64,
    /// The states published lately: a restarted coordinator asks for them again.
    recent: VecDeque<VehicleState>,
    /// A state was published without waking the coordinator ([`Announce::BeforeNextWait`]).
    unannounced: bool,
}

impl Outbox {
    pub(super) fn new(sender: Sender<VehicleState>, id: u32, incarnation: u32, dt: f64) -> Self {
        Self {
            sender,
            id,
            pid: std::process::id(),
            incarnation,
            dt,
            seq: 0,
            recent: VecDeque::new(),
            unannounced: false,
        }
    }

    fn send(&mut self, state: VehicleState) -> Result<()> {
        self.unannounced = false;
        self.sender
            .send(state)
            .map_err(|e| anyhow::anyhow!("publishing the state: {e}"))
    }

    /// Wakes the coordinator if a state went out without ([`Announce::BeforeNextWait`]); call
    /// before every wait.
    pub(super) fn announce(&mut self) -> Result<()> {
        if std::mem::take(&mut self.unannounced) {
            self.sender
                .notify()
                .map_err(|e| anyhow::anyhow!("waking the coordinator: {e}"))?;
        }
        Ok(())
    }

    /// Publishes `vehicle`'s state (true and reported) at tick `k` with `flags`, having read
    /// `read` commands (`VehicleState::commands_read`), waking the coordinator as `announce`
    /// says; keeps it among the recent states.
    pub(super) fn publish(
        &mut self,
        vehicle: &Vehicle,
        k: u64,
        flags: u32,
        read: u64,
        announce: Announce,
    ) -> Result<()> {
        let state = self.state(vehicle, k, flags, read);
        match announce {
            Announce::Now => self.send(state)?,
            Announce::BeforeNextWait => {
                self.sender
                    .publish(state)
                    .map_err(|e| anyhow::anyhow!("publishing the state: {e}"))?;
                self.unannounced = true;
            }
        }
        self.keep(state);
        Ok(())
    }

    /// The next state message: `vehicle`'s state at tick `k`, numbered.
    fn state(&mut self, vehicle: &Vehicle, k: u64, flags: u32, read: u64) -> VehicleState {
        self.seq += 1;
        let agent = &vehicle.agent;
        let told = vehicle.reported();
        VehicleState {
            header: Header::new(self.id, k, k as f64 * self.dt, self.seq).with_flags(flags),
            pid: self.pid,
            incarnation: self.incarnation,
            position: from_vec3(&agent.position),
            velocity: from_vec3(&agent.velocity),
            commands_read: read,
            believed: from_vec3(&told.position),
            water_velocity: from_vec3(&told.water),
            current: from_vec3(&told.current),
        }
    }

    /// Keeps `state` among the recent states.
    fn keep(&mut self, state: VehicleState) {
        self.recent.push_back(state);
        while self.recent.len() > Limits::LOOKAHEAD_TICKS as usize + 2 {
            self.recent.pop_front();
        }
    }

    /// Sends the recent states of ticks after `after` again (to a restarted coordinator),
    /// renumbered, with `read` commands read. Returns their ticks.
    pub(super) fn resend_after(&mut self, after: u64, read: u64) -> Result<Vec<u64>> {
        let again: Vec<VehicleState> = self
            .recent
            .iter()
            .filter(|s| s.header.tick > after)
            .copied()
            .collect();
        let mut ticks = Vec::with_capacity(again.len());
        for last in again {
            self.seq += 1;
            self.send(VehicleState {
                header: last.header.resent(self.seq),
                commands_read: read,
                ..last
            })?;
            ticks.push(last.header.tick);
        }
        Ok(ticks)
    }

    /// Acknowledges `read` commands read while waiting: the last state again, flagged
    /// `ACK`. False when no state was published yet.
    pub(super) fn acknowledge(&mut self, read: u64) -> Result<bool> {
        let Some(last) = self.recent.back().copied() else {
            return Ok(false);
        };
        self.seq += 1;
        self.send(VehicleState {
            header: last.header.resent(self.seq).with_flags(VehicleState::ACK),
            commands_read: read,
            ..last
        })?;
        Ok(true)
    }
}
