//! The agent's incoming side: the body commands, checked and turned into guidance.

use anyhow::Result;
use tracing::warn;
use vbap_ipc::compact::Precision;
use vbap_ipc::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
use vbap_ipc::msg::{to_vec3, wall_ns, Header};
use vbap_ipc::msglog::MsgLog;
use vbap_ipc::ports::Receiver;
use vbap_math::potential::PairPotential;

use crate::{Guidance, Telling};

/// One new command: its tick, the guidance it carries for this vehicle, this vehicle's
/// own entry of its snapshot (how a rejoining vehicle learns it is admitted), and its size
/// as the vehicle's link carries it, bytes.
pub(super) type NewCommand = (u64, Guidance, Option<SnapshotEntry>, u64);

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
    /// The longest this vehicle may fly on one command, s
    /// (`vbap_mission::horizon::plan_horizon` of the links): the reach of its leaders.
    horizon: f64,
    /// The precision of what it is told (`links.position_quantum`).
    precision: Precision,
    /// Sequence number of the last accepted command.
    pub last_seq: Option<u64>,
    /// Commands refused so far.
    pub rejected: u64,
}

impl CommandFilter {
    pub(super) fn new(id: u32, v0: f64, horizon: f64, precision: Precision) -> Self {
        Self {
            id,
            v0,
            horizon,
            precision,
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
            // Recorded once its size is known (the command this vehicle is told).
            let (stamps, id) = ((h.seq, h.sent_ns, wall_ns()), self.id);
            let record = |msgs: &mut MsgLog, bytes: Option<u64>| {
                msgs.recv_sized("body", h.sender, id, h.tick, stamps, bytes)
            };
            if h.sender == Header::COORDINATOR && self.last_seq == Some(h.seq) {
                record(msgs, None);
                // A duplicate: a restarted coordinator re-sends its last command. Send it
                // our states since again (a new subscriber's history arrives only with
                // the publisher's next sample).
                out.resend_after = Some(h.tick);
                continue;
            }
            if !self.accept(command) {
                record(msgs, None);
                continue;
            }
            self.last_seq = Some(h.seq);
            if h.flags & BodyCommand::FINISHED != 0 {
                record(msgs, None);
                out.finished = true;
                break;
            }
            let new = self.guidance(command);
            record(msgs, Some(new.3));
            out.commands.push(new);
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

    /// The guidance of `command` for this vehicle, and its own snapshot entry: read from its
    /// own entry and its neighbour list only (O(its neighbours), whatever the fleet); and
    /// the size of what it was told in the compact link encoding (`vbap_ipc::compact`), bytes.
    fn guidance(&self, command: &BodyCommand) -> NewCommand {
        let tick = command.header.tick;
        let snapshot = command.snapshot_entries();
        let own = command.own_index(self.id);
        let near = own.map_or(&[][..], |i| command.near_of(i));
        let pot = |p: &[f64; 3]| PairPotential {
            alpha: p[0],
            d0: p[1],
            d1: p[2],
        };
        let schedule = command.schedule();
        let told = Guidance::of_command(
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
        .tell(
            self.id,
            snapshot,
            own,
            near.iter().map(|&j| j as usize),
            &Telling {
                horizon: self.horizon,
                precision: self.precision,
                origin: to_vec3(&command.r),
            },
            schedule.as_ref().map(|s| s.segments.len()),
        );
        let guidance = told
            .guidance
            .with_plan(schedule, to_vec3(&command.r), command.scale);
        // Its own entry exactly as the coordinator wrote it: a restarted process resumes
        // from that state, as the in-process simulator's does (the vehicle itself did not
        // move with its process; read through a quantised link, a glider's 0.004 m/s
        // became 0 and the run left the simulator at the first tick after a restart).
        let exact_own = own.and_then(|i| snapshot.get(i)).copied();
        debug_assert_eq!(exact_own.map(|e| e.id), told.own.map(|e| e.id));
        (tick, guidance, exact_own, told.bytes)
    }
}
