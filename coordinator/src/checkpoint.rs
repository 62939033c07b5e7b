//! The coordinator's checkpoint (DESIGN §7): everything a restarted coordinator needs to
//! resume exactly where the dead one stopped — virtual body, filter, fleet and link state,
//! running figures, counters, and the lengths of the files it had written.
//!
//! The codec (postcard: compact, exact for f64) lives here and nowhere else. Written after
//! every tick into one of two alternating files, so a restarted
//! coordinator is never more than the tick in progress behind. In lockstep that tick is
//! redone from the same inputs (the agents' states are still there, history 1), which
//! makes a run with a coordinator crash byte-identical to one without.

use std::io;

use serde::{Deserialize, Serialize};
use shared::rundir::{FileOffsets, MessageCounts, RunDir};

use crate::fleet::Fleet;
use crate::planner::Planner;
use crate::record::RecorderStats;

/// What a peer process was last known as.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PeerMark {
    pub pid: u32,
    pub last_seq: Option<u64>,
}

/// One checkpoint.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Checkpoint {
    /// The tick to process next.
    pub next_tick: u64,
    pub planner: Planner,
    pub fleet: Fleet,
    pub stats: RecorderStats,
    pub offsets: FileOffsets,
    pub counts: MessageCounts,
    pub sent: u64,
    pub late_ticks: u64,
    pub detection_ms: Vec<f64>,
    pub rejoin_ms: Vec<f64>,
    pub peers: Vec<PeerMark>,
    /// The command of the last tick, re-published on resume.
    pub body: crate::run::BodyRecord,
}

/// A checkpoint written from borrowed state (no clone of the planner or the fleet per
/// tick); it reads back as a [`Checkpoint`].
#[derive(Serialize)]
pub struct CheckpointRef<'a> {
    pub next_tick: u64,
    pub planner: &'a Planner,
    pub fleet: &'a Fleet,
    pub stats: &'a RecorderStats,
    pub offsets: FileOffsets,
    pub counts: MessageCounts,
    pub sent: u64,
    pub late_ticks: u64,
    pub detection_ms: &'a [f64],
    pub rejoin_ms: &'a [f64],
    pub peers: &'a [PeerMark],
    pub body: &'a crate::run::BodyRecord,
}

impl CheckpointRef<'_> {
    /// Writes this checkpoint with `writer`.
    pub fn save_with(&self, writer: &mut CheckpointWriter) -> io::Result<()> {
        writer.save(self)
    }
}

impl Checkpoint {
    /// The newest valid checkpoint of `dir`, if any (a torn write fails to parse and the
    /// other slot is used).
    pub fn load(dir: &RunDir) -> io::Result<Option<Self>> {
        let mut best: Option<Self> = None;
        for path in slots(dir) {
            match std::fs::read(&path) {
                Ok(bytes) => {
                    if let Ok(cp) = postcard::from_bytes::<Self>(&bytes) {
                        if best.as_ref().is_none_or(|b| cp.next_tick > b.next_tick) {
                            best = Some(cp);
                        }
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(e),
            }
        }
        Ok(best)
    }
}

/// The two checkpoint slots of a run directory.
fn slots(dir: &RunDir) -> [std::path::PathBuf; 2] {
    [
        dir.root.join("coordinator.checkpoint.a"),
        dir.root.join("coordinator.checkpoint.b"),
    ]
}

/// Writes checkpoints alternately into two files kept open: each checkpoint is one
/// positioned write and one truncation, and a crash in the middle of one leaves the
/// previous one intact in the other file.
pub struct CheckpointWriter {
    files: [std::fs::File; 2],
    turn: usize,
    buffer: Vec<u8>,
}

impl CheckpointWriter {
    /// Opens (creating) the two slots of `dir`.
    pub fn open(dir: &RunDir) -> io::Result<Self> {
        let open = |p: &std::path::Path| {
            std::fs::OpenOptions::new()
                .create(true)
                .truncate(false)
                .read(true)
                .write(true)
                .open(p)
        };
        let [a, b] = slots(dir);
        Ok(Self {
            files: [open(&a)?, open(&b)?],
            turn: 0,
            buffer: Vec::with_capacity(1 << 16),
        })
    }

    /// Writes `cp` into the older slot.
    pub fn save(&mut self, cp: &impl Serialize) -> io::Result<()> {
        use std::os::unix::fs::FileExt;
        self.buffer.clear();
        self.buffer =
            postcard::to_extend(cp, std::mem::take(&mut self.buffer)).map_err(io::Error::other)?;
        let file = &self.files[self.turn];
        file.set_len(0)?;
        file.write_all_at(&self.buffer, 0)?;
        self.turn = 1 - self.turn;
        Ok(())
    }
}
