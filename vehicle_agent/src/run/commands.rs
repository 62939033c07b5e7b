//! The agent's incoming side: the body commands, checked and turned into guidance.

use anyhow::Result;
use tracing::warn;
use vbap_ipc::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
use vbap_ipc::msg::{to_vec3, Header};
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::ports::Receiver;
use vbap_math::potential::PairPotential;

use crate::Guidance;

/// One new command: its tick, the guidance it carries for this vehicle, and this
/// vehicle's own entry of its snapshot (how a rejoining vehicle learns it is admitted).
pub(super) type NewCommand = (u64, Guidance, Option<SnapshotEntry>);

/// What one drain of the body subscriber found.
#[derive(Default)]
pub(super) struct Drained {
    /// Every new valid command, in order.
    pub commands: Vec<NewCommand>,
    /// The coordinator published the end of the mission.
    pub finished: bool,
    /// A restarted coordinator re-sent the command of this tick: it wants our states since.
    pub resend_after: Option<u64>,
}

/// Checks vehicle `id`'s body commands: only the coordinator's, valid, never older than
/// the last one accepted.
pub(super) struct CommandFilter {
    id: u32,
    /// Nominal body speed v0 (length unit/s): the approach speed of the homing law.
    v0: f64,
    /// Sequence number of the last accepted command.
    pub last_seq: Option<u64>,
    /// Commands refused so far.
    pub rejected: u64,
}

impl CommandFilter {
    pub(super) fn new(id: u32, v0: f64) -> Self {
        Self {
            id,
            v0,
            last_seq: None,
            rejected: 0,
        }
    }

    /// Reads every command waiting at `body`, in place, up to the end of the mission.
    pub(super) fn drain(
        &mut self,
        body: &Receiver<BodyCommand>,
        msgs: &mut MsgLog,
    ) -> Result<Drained> {
        let mut out = Drained::default();
        while let Some(sample) = body
            .receive()
            .map_err(|e| anyhow::anyhow!("receiving the body: {e}"))?
        {
            let command: &BodyCommand = &sample;
            let h = command.header;
            msgs.recv_now("body", &h, self.id);
            if h.sender == Header::COORDINATOR && self.last_seq == Some(h.seq) {
                // A duplicate: a restarted coordinator re-sends its last command. Send it
                // our states since again (a new subscriber's history arrives only with
                // the publisher's next sample).
                out.resend_after = Some(h.tick);
                continue;
            }
            if !self.accept(command) {
                continue;
            }
            self.last_seq = Some(h.seq);
            if h.flags & BodyCommand::FINISHED != 0 {
                out.finished = true;
                break;
            }
            out.commands.push(self.guidance(command));
        }
        Ok(out)
    }

    /// True for a command from the coordinator, valid and not a replay; counts and logs a
    /// refusal.
    fn accept(&mut self, command: &BodyCommand) -> bool {
        let h = command.header;
        let replay = self.last_seq.is_some_and(|s| h.seq < s);
        if h.sender == Header::COORDINATOR && !replay && command.is_valid() {
            return true;
        }
        self.rejected += 1;
        warn!(
            vehicle = self.id,
            tick = h.tick,
            seq = h.seq,
            sender = h.sender,
            rejected = self.rejected,
            replay,
            "rejected a body command"
        );
        false
    }

    /// The guidance of `command` for this vehicle, and its own snapshot entry.
    fn guidance(&self, command: &BodyCommand) -> NewCommand {
        let tick = command.header.tick;
        let snapshot = &command.snapshot[..command.n_vehicles as usize];
        let pot = |p: &[f64; 3]| PairPotential {
            alpha: p[0],
            d0: p[1],
            d1: p[2],
        };
        let (guidance, own) = Guidance::of_command(
            tick,
            command.leaders[..command.n_leaders as usize]
                .iter()
                .map(to_vec3)
                .collect(),
            pot(&command.inter),
            pot(&command.leader),
            command.damping,
            to_vec3(&command.velocity),
            self.v0,
        )
        .with_neighbours_and_own(self.id, snapshot);
        let guidance = guidance.with_plan(command.schedule(), to_vec3(&command.r), command.scale);
        (tick, guidance, own)
    }
}
