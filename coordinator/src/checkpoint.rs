//! The coordinator's checkpoint (docs/ARCHITECTURE.md §8): everything a restarted coordinator needs to
//! resume exactly where the dead one stopped — virtual body, filter, fleet and link state,
//! running figures, counters, and the lengths of the files it had written.
//!
//! The codec (postcard: compact, exact for f64) lives here and nowhere else. Written after
//! every tick into one of two alternating files, so a restarted
//! coordinator is never more than the tick in progress behind.
//!
//! What grows with the mission is journaled instead of rewritten every tick: the reports
//! the link model holds (a glider's two hours under water are hundreds of reports per
//! vehicle) and the body track kept for dead reckoning. Each is appended once, when first
//! seen, to `coordinator.journal.reports` / `coordinator.journal.track` (records of a
//! little-endian u32 length and a postcard body); the checkpoint records how many bytes
//! of each it covers and the small marks that tell which journaled entries are still held
//! ([`Fleet::restore_journaled`]). A checkpoint so costs what changed in the tick, not
//! what is in flight. In lockstep that tick is
//! redone from the same inputs (the agents' states are still there, history 1), which
//! makes a run with a coordinator crash byte-identical to one without.

use std::io;

use serde::{Deserialize, Serialize};
use vbap_mission::rundir::{FileOffsets, MessageCounts, RunDir};

use crate::command::BodyRecord;
use crate::fleet::Fleet;
use crate::planner::{Planner, Report};
use crate::record::RecorderStats;

/// What a peer process was last known as.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PeerMark {
    pub pid: u32,
    pub last_seq: Option<u64>,
    /// The newest tick of this vehicle whose state a tick has used: a resumed coordinator
    /// keeps no state of it or an older tick (an agent re-sends its recent states, under
    /// new sequence numbers, to a restarted coordinator).
    #[serde(default)]
    pub used_tick: Option<u64>,
    /// Incarnation of the process `pid` (`VehicleState::incarnation`; 0: unknown).
    #[serde(default)]
    pub incarnation: u32,
    /// How long the vehicle had been silent (no message of it) at this checkpoint, ns
    /// (None: never heard). A resumed coordinator goes on counting from it, so restarts do
    /// not reset the liveness limit; the outage itself is not counted (nobody could hear
    /// the vehicle, nor command it).
    #[serde(default)]
    pub silent_ns: Option<u64>,
}

/// One checkpoint, of a coordinator with planner `P`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Checkpoint<P = Planner> {
    /// The tick to process next.
    pub next_tick: u64,
    pub planner: P,
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
    pub body: BodyRecord,
    /// Wall-clock time tick 0 of a paced mission was due, ns since the Unix epoch: a
    /// resumed coordinator keeps the mission's clock (None: lockstep, or not started).
    pub clock_start_ns: Option<u64>,
    /// What of the journals this checkpoint covers.
    pub journal: JournalMarks,
}

/// The part of the journals a checkpoint covers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JournalMarks {
    /// Bytes of `coordinator.journal.reports` covered.
    pub reports_bytes: u64,
    /// Sequence number of the next held report.
    pub reports_next: u64,
    /// Bytes of `coordinator.journal.track` covered.
    pub track_bytes: u64,
    /// First tick of the body track still kept (None: empty).
    pub track_from: Option<u64>,
    /// Last tick journaled (None: none yet).
    pub track_last: Option<u64>,
}

/// A checkpoint written from borrowed state (no clone of the planner or the fleet per
/// tick); it reads back as a [`Checkpoint`].
#[derive(Serialize)]
pub struct CheckpointRef<'a, P = Planner> {
    pub next_tick: u64,
    pub planner: &'a P,
    pub fleet: &'a Fleet,
    pub stats: &'a RecorderStats,
    pub offsets: FileOffsets,
    pub counts: MessageCounts,
    pub sent: u64,
    pub late_ticks: u64,
    pub detection_ms: &'a [f64],
    pub rejoin_ms: &'a [f64],
    pub peers: &'a [PeerMark],
    pub body: &'a BodyRecord,
    pub clock_start_ns: Option<u64>,
    /// Filled in by [`CheckpointWriter::save`].
    pub journal: JournalMarks,
}

impl<P: Serialize> CheckpointRef<'_, P> {
    /// Writes this checkpoint with `writer` (journal first, then the checkpoint).
    pub fn save_with(mut self, writer: &mut CheckpointWriter) -> io::Result<()> {
        self.journal = writer.journal(self.fleet)?;
        writer.save(&self)
    }
}

impl<P: for<'de> Deserialize<'de>> Checkpoint<P> {
    /// The newest valid checkpoint of `dir`, if any (a torn write fails to parse and the
    /// other slot is used).
    pub fn load(dir: &RunDir) -> io::Result<Option<Self>> {
        let mut best: Option<Self> = None;
        for path in slots(dir) {
            match std::fs::read(&path) {
                Ok(bytes) => {
                    let Some(body) = framed(&bytes) else {
                        continue; // torn or never written
                    };
                    if let Ok(cp) = postcard::from_bytes::<Self>(body) {
                        if best.as_ref().is_none_or(|b| cp.next_tick > b.next_tick) {
                            best = Some(cp);
                        }
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(e),
            }
        }
        let Some(mut cp) = best else {
            return Ok(None);
        };
        let [reports, track] = journals(dir);
        let held: Vec<(f64, u64, Report)> = read_journal(&reports, cp.journal.reports_bytes)?;
        let kept: Vec<(u64, vbap_math::Vec3)> = read_journal(&track, cp.journal.track_bytes)?;
        cp.fleet
            .restore_journaled(cp.journal.reports_next, held, kept, cp.journal.track_from);
        Ok(Some(cp))
    }
}

/// CRC-32 (IEEE, `crc32fast`: SIMD where the CPU has it) of a checkpoint's body, widened
/// to 64 bits: tells a torn checkpoint from a whole one. A byte-at-a-time FNV-1a of the
/// ~5 KB body of a glider mission cost ~5 µs a tick, 4 % of a `vbap run`'s samples.
fn body_hash(bytes: &[u8]) -> u64 {
    u64::from(crc32fast::hash(bytes))
}

/// The body of a checkpoint slot — a little-endian u64 length, the u64 hash ([`body_hash`]) of the
/// body, the body — when it is whole (a slot is rewritten in place, never truncated).
fn framed(bytes: &[u8]) -> Option<&[u8]> {
    let len = u64::from_le_bytes(bytes.get(..8)?.try_into().ok()?) as usize;
    let hash = u64::from_le_bytes(bytes.get(8..16)?.try_into().ok()?);
    let body = bytes.get(16..16usize.checked_add(len)?)?;
    (body_hash(body) == hash).then_some(body)
}

/// The two journals of a run directory: held reports, body track.
fn journals(dir: &RunDir) -> [std::path::PathBuf; 2] {
    [
        dir.root.join("coordinator.journal.reports"),
        dir.root.join("coordinator.journal.track"),
    ]
}

/// The records of the first `len` bytes of journal `path` (absent: none).
fn read_journal<T: for<'de> Deserialize<'de>>(
    path: &std::path::Path,
    len: u64,
) -> io::Result<Vec<T>> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == io::ErrorKind::NotFound && len == 0 => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let bad = |what: &str| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("{}: {what}", path.display()),
        )
    };
    let mut rest = bytes
        .get(..len as usize)
        .ok_or_else(|| bad("shorter than its checkpoint says"))?;
    let mut out = Vec::new();
    while !rest.is_empty() {
        let (head, tail) = rest.split_at_checked(4).ok_or_else(|| bad("torn record"))?;
        let n = u32::from_le_bytes(head.try_into().expect("4 bytes")) as usize;
        let (body, tail) = tail.split_at_checked(n).ok_or_else(|| bad("torn record"))?;
        out.push(postcard::from_bytes(body).map_err(|e| bad(&e.to_string()))?);
        rest = tail;
    }
    Ok(out)
}

/// Appends length-prefixed postcard records to a journal buffer.
fn append_record(buf: &mut Vec<u8>, value: &impl Serialize) -> io::Result<()> {
    let at = buf.len();
    buf.extend_from_slice(&[0; 4]);
    let mut taken = postcard::to_extend(value, std::mem::take(buf)).map_err(io::Error::other)?;
    let n = (taken.len() - at - 4) as u32;
    taken[at..at + 4].copy_from_slice(&n.to_le_bytes());
    *buf = taken;
    Ok(())
}

/// The two checkpoint slots of a run directory.
fn slots(dir: &RunDir) -> [std::path::PathBuf; 2] {
    [
        dir.root.join("coordinator.checkpoint.a"),
        dir.root.join("coordinator.checkpoint.b"),
    ]
}

/// Writes checkpoints alternately into two files kept open: each checkpoint is one
/// positioned write of a framed body (length, hash, body), and a crash in the middle of
/// one leaves the previous one intact in the other file.
pub struct CheckpointWriter {
    files: [std::fs::File; 2],
    turn: usize,
    buffer: Vec<u8>,
    /// Journals of held reports and of the body track, appended to.
    journals: [std::fs::File; 2],
    marks: JournalMarks,
}

impl CheckpointWriter {
    /// Opens (creating) the two slots and the journals of `dir`; `resumed`: the marks of
    /// the checkpoint a restarted coordinator resumes from (the journals are cut back to
    /// them), None for a new run (empty journals).
    pub fn open(dir: &RunDir, resumed: Option<JournalMarks>) -> io::Result<Self> {
        let open = |p: &std::path::Path| {
            std::fs::OpenOptions::new()
                .create(true)
                .truncate(false)
                .read(true)
                .write(true)
                .open(p)
        };
        let [a, b] = slots(dir);
        let marks = resumed.unwrap_or_default();
        let [reports, track] = journals(dir);
        let (reports, track) = (open(&reports)?, open(&track)?);
        reports.set_len(marks.reports_bytes)?;
        track.set_len(marks.track_bytes)?;
        Ok(Self {
            files: [open(&a)?, open(&b)?],
            turn: 0,
            buffer: Vec::with_capacity(1 << 16),
            journals: [reports, track],
            marks,
        })
    }

    /// Appends to the journals what `fleet` holds that they do not have yet; returns the
    /// marks of the journals as they now are.
    fn journal(&mut self, fleet: &Fleet) -> io::Result<JournalMarks> {
        use std::os::unix::fs::FileExt;
        let (held, next) = fleet.held_reports();
        self.buffer.clear();
        for entry in held.iter().filter(|e| e.1 >= self.marks.reports_next) {
            append_record(&mut self.buffer, entry)?;
        }
        self.journals[0].write_all_at(&self.buffer, self.marks.reports_bytes)?;
        self.marks.reports_bytes += self.buffer.len() as u64;
        self.marks.reports_next = next;
        let track = fleet.body_track();
        self.buffer.clear();
        let after = self.marks.track_last;
        for (k, r) in track.range(after.map_or(0, |l| l + 1)..) {
            append_record(&mut self.buffer, &(*k, *r))?;
            self.marks.track_last = Some(*k);
        }
        self.journals[1].write_all_at(&self.buffer, self.marks.track_bytes)?;
        self.marks.track_bytes += self.buffer.len() as u64;
        self.marks.track_from = track.keys().next().copied();
        Ok(self.marks)
    }

    /// Writes `cp` into the older slot.
    pub fn save(&mut self, cp: &impl Serialize) -> io::Result<()> {
        use std::os::unix::fs::FileExt;
        self.buffer.clear();
        self.buffer.extend_from_slice(&[0; 16]);
        self.buffer =
            postcard::to_extend(cp, std::mem::take(&mut self.buffer)).map_err(io::Error::other)?;
        let len = (self.buffer.len() - 16) as u64;
        let hash = body_hash(&self.buffer[16..]);
        self.buffer[..8].copy_from_slice(&len.to_le_bytes());
        self.buffer[8..16].copy_from_slice(&hash.to_le_bytes());
        self.files[self.turn].write_all_at(&self.buffer, 0)?;
        self.turn = 1 - self.turn;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planner::PlannerParams;
    use vbap_math::Vec3;
    use vbap_mission::config::Mission;

    #[test]
    fn a_torn_slot_is_told_from_a_whole_one() {
        let body = b"a checkpoint body".to_vec();
        let mut slot = (body.len() as u64).to_le_bytes().to_vec();
        slot.extend_from_slice(&body_hash(&body).to_le_bytes());
        slot.extend_from_slice(&body);
        assert_eq!(framed(&slot), Some(&body[..]));
        // Old bytes after the body (the slot is never truncated) do not matter.
        let mut longer = slot.clone();
        longer.extend_from_slice(b"old tail");
        assert_eq!(framed(&longer), Some(&body[..]));
        // Cut short, or a byte of an older checkpoint left in the middle: refused.
        assert_eq!(framed(&slot[..slot.len() - 1]), None);
        let mut torn = slot.clone();
        torn[20] ^= 0x40;
        assert_eq!(framed(&torn), None);
        assert_eq!(framed(&[]), None);
    }

    /// Saves after every tick of a fleet whose links hold reports for a while, then reads
    /// each checkpoint back: the journaled parts come back exactly.
    #[test]
    fn journals_restore_held_reports_and_body_track() {
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[links]\ndelay = 0.3\njitter = 0.2\nloss = 0.1\n\
             surfacing_period = 4.0\nsurfacing_window = 1.0\n",
            "<test>",
        )
        .unwrap();
        let root = std::env::temp_dir().join(format!("vbap-cp-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = RunDir::create(&root).unwrap();
        let ids = [0, 1, 2, 3];
        let mut fleet = Fleet::new(&m, &ids);
        let planner = Planner::new(PlannerParams::from_mission(&m), m.start_vec(), &ids).unwrap();
        let stats = RecorderStats::default();
        let body = BodyRecord::default();
        let dt = 0.05;
        let mut writer = CheckpointWriter::open(&dir, None).unwrap();
        let mut held_at_some_point = 0;
        for k in 0..400u64 {
            if k == 150 {
                fleet.lose(2);
            }
            let truth: Vec<Report> = fleet
                .alive()
                .map(|id| Report {
                    id,
                    tick: k,
                    position: Vec3::new(k as f64, id as f64, 0.0),
                    velocity: Vec3::new(1.0, 0.0, 0.0),
                    measurement: 0.5 * k as f64,
                })
                .collect();
            fleet.receive(k, dt, &truth);
            fleet.track_body(k, Vec3::new(0.1 * k as f64, 0.0, 0.0));
            fleet.deliver(k as f64 * dt, dt);
            fleet.end_tick();
            held_at_some_point = held_at_some_point.max(fleet.held_reports().0.len());
            CheckpointRef {
                next_tick: k + 1,
                planner: &planner,
                fleet: &fleet,
                stats: &stats,
                offsets: FileOffsets::default(),
                counts: MessageCounts::default(),
                sent: k,
                late_ticks: 0,
                detection_ms: &[],
                rejoin_ms: &[],
                peers: &[],
                body: &body,
                clock_start_ns: None,
                journal: JournalMarks::default(),
            }
            .save_with(&mut writer)
            .unwrap();
            let back = Checkpoint::<Planner>::load(&dir).unwrap().unwrap();
            assert_eq!(back.next_tick, k + 1);
            assert_eq!(back.fleet.held_reports(), fleet.held_reports(), "tick {k}");
            assert_eq!(back.fleet.body_track(), fleet.body_track(), "tick {k}");
        }
        assert!(held_at_some_point > 20, "the links held reports");
        // A restarted writer continues the journals where its checkpoint left them.
        let marks = Checkpoint::<Planner>::load(&dir).unwrap().unwrap().journal;
        let again = CheckpointWriter::open(&dir, Some(marks)).unwrap();
        assert_eq!(again.marks, marks);
        let _ = std::fs::remove_dir_all(&root);
    }

    /// A robust planner's committed body path survives a checkpoint: the resumed planner
    /// steps on exactly as the one that wrote it, and the re-sent command carries the plan.
    #[test]
    fn a_resumed_planner_keeps_its_committed_path() {
        let m = Mission::from_toml_str(
            "[mission]\nname = \"t\"\ndt = 0.1\n[field]\ncenter = [20.0, 10.0]\namplitude = 10.0\nwidth = 15.0\n[vehicles]\ncount = 4\n[links]\ndelay = 0.5\nloss = 0.1\n[control]\nlaw = \"robust\"\n",
            "<test>",
        )
        .unwrap();
        let root = std::env::temp_dir().join(format!("vbap-cp-plan-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&root);
        let dir = RunDir::create(&root).unwrap();
        let ids = [0, 1, 2, 3];
        let fleet = Fleet::new(&m, &ids);
        let mut planner =
            Planner::new(PlannerParams::from_mission(&m), m.start_vec(), &ids).unwrap();
        let reports = |k: u64, r: Vec3| -> Vec<Report> {
            ids.iter()
                .map(|&id| Report {
                    id,
                    tick: k.saturating_sub(5),
                    position: r + Vec3::new(f64::from(id).cos(), f64::from(id).sin(), 0.0),
                    velocity: Vec3::new(0.2, 0.1, 0.0),
                    measurement: 1.0 + 0.3 * f64::from(id) + 0.02 * k as f64,
                })
                .collect()
        };
        let mut last = None;
        for k in 0..60 {
            let q = reports(k, planner.body().r);
            last = Some(planner.step(k, &q, &q, &[], 0.1).unwrap());
        }
        let command = last.unwrap();
        let body = BodyRecord::from_command(59, 0.1, &command, Vec::new());
        assert!(
            !body.plan.is_empty() && body.plan_ticks > 0,
            "the record carries the plan"
        );
        // The members' slot assignment, held at their slots, survives as well: after the
        // restart, two members thrown towards each other's slot keep theirs as they would
        // have (assigned afresh they would swap).
        let at_slots: Vec<Report> = planner
            .member_slots(&command, &reports(59, planner.body().r))
            .iter()
            .map(|&(id, slot)| Report {
                position: slot,
                ..reports(59, slot)[id as usize]
            })
            .collect();
        planner.member_slots(&command, &at_slots);
        let mut thrown = at_slots.clone();
        let (s0, s1) = (at_slots[0].position, at_slots[1].position);
        thrown[0].position += 0.6 * (s1 - s0);
        thrown[1].position += 0.6 * (s0 - s1);
        let fresh = crate::slots::member_slots(
            planner.design(),
            &mut Default::default(),
            &command,
            &thrown,
        );
        assert_eq!((fresh[0].1, fresh[1].1), (s1, s0), "swapped afresh");
        let mut writer = CheckpointWriter::open(&dir, None).unwrap();
        CheckpointRef {
            next_tick: 60,
            planner: &planner,
            fleet: &fleet,
            stats: &RecorderStats::default(),
            offsets: FileOffsets::default(),
            counts: MessageCounts::default(),
            sent: 60,
            late_ticks: 0,
            detection_ms: &[],
            rejoin_ms: &[],
            peers: &[],
            body: &body,
            clock_start_ns: None,
            journal: JournalMarks::default(),
        }
        .save_with(&mut writer)
        .unwrap();
        let back = Checkpoint::<Planner>::load(&dir).unwrap().unwrap();
        assert_eq!(back.body, body);
        let mut resumed = back.planner;
        let kept = planner.member_slots(&command, &thrown);
        assert_eq!((kept[0].1, kept[1].1), (s0, s1), "kept");
        assert_eq!(resumed.member_slots(&command, &thrown), kept);
        for k in 60..120 {
            let q = reports(k, planner.body().r);
            let a = planner.step(k, &q, &q, &[], 0.1).unwrap();
            let b = resumed.step(k, &q, &q, &[], 0.1).unwrap();
            assert_eq!(a, b, "tick {k}");
            assert!(a.schedule.is_some());
        }
        let _ = std::fs::remove_dir_all(&root);
    }
}
