//! The compact link encoding of what crosses a vehicle's own link: the command one
//! vehicle is told ([`AgentCommand`], coordinator → vehicle) and the report it sends
//! ([`StateReport`], vehicle → coordinator), with their sizes known before they are sent
//! ([`AgentCommand::encoded_len`], [`StateReport::LEN`]).
//!
//! Inside one host the vehicles read the shared command in place (`msg`), each only its own
//! entry and its neighbour list. Between a glider and the shore there is no shared memory:
//! what would cross is the vehicle's own command, in this encoding. Its size is what the
//! message records, `vbap analyze` and the summary count.
//!
//! # Layout (version 1, little-endian, no padding)
//!
//! A command:
//!
//! | bytes | field |
//! |---|---|
//! | 1 | version, [`VERSION`] |
//! | 1 | flags: [`AgentCommand::HOLDING`], [`AgentCommand::FINISHED`], plan present (4), own entry present (8), quantised (16) |
//! | 4 | tick k (`u32`) |
//! | 8 | quantum q, length unit (quantised only) |
//! | 112 | body centre r (3 × f64), scale k, body velocity (3), inter (α, d0, d1), leader (α, h0, h1), damping K |
//! | 7 + 40 n | committed path (if present): start tick `u32`, ticks per segment `u16`, n `u8`, n × 5 f64 |
//! | 2 + n·P | leaders within reach: n `u16`, each a position P |
//! | 4 + … | own entry (if present): alive `u8`, bits `u8`, incarnation `u16`, position P, velocity V, target P (rejoining), slot P (with slot), age f64 (age ≠ +0) |
//! | 2 + … | neighbours: n `u16`, each id `u16`, alive `u8`, bits `u8`, position P, velocity V, target P (rejoining), age f64 (age ≠ +0) |
//!
//! Bits of an entry: rejoining (1), has a slot (2), age present (4). A position P and a
//! velocity V are 3 × f64 (24 bytes) exact, or 3 × `i32` (12 bytes) quantised: a position
//! as the multiple of q nearest to its offset from r, a velocity as the multiple of q per
//! second nearest to it (the decoder adds r back). A value out of `i32` range is not
//! encodable ([`EncodeError::OutOfRange`]): never clamped.
//!
//! A report is 68 bytes: version, flags, incarnation `u16`, tick `u32`, commands read
//! `u32`, position (3 × f64, what the vehicle believes), velocity through the water (3 ×
//! f64), its reading (f64).

use crate::msg::coordinator_to_agent::SnapshotEntry;

/// Version of the encoding (first byte of every message).
pub const VERSION: u8 = 1;

const PLAN: u8 = 4;
const OWN: u8 = 8;
const QUANTISED: u8 = 16;
const REJOINING: u8 = 1;
const HAS_SLOT: u8 = 2;
const HAS_AGE: u8 = 4;

/// How positions and velocities are written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Precision {
    /// As `f64`, exactly (24 bytes per vector).
    Exact,
    /// As `i32` multiples of a quantum (length unit; per second for velocities) relative to
    /// the body centre (12 bytes per vector): a resolution of q/2.
    Quantised(f64),
}

impl Precision {
    /// The precision of a quantum `q` (length unit; `links.position_quantum`): exact for 0.
    pub fn of_quantum(q: f64) -> Self {
        if q > 0.0 {
            Precision::Quantised(q)
        } else {
            Precision::Exact
        }
    }

    /// `v` as it reads back after being written with this precision relative to `origin`
    /// (positions: the body centre; velocities: zero), bit for bit what
    /// [`AgentCommand::decode`] gives; None when the quantum cannot hold it (it cannot be
    /// sent).
    pub fn round_trip(self, v: &[f64; 3], origin: &[f64; 3]) -> Option<[f64; 3]> {
        let Precision::Quantised(q) = self else {
            return Some(*v);
        };
        let mut out = [0.0; 3];
        for ((o, x), c) in out.iter_mut().zip(v).zip(origin) {
            let n = quanta(*x, *c, q)?;
            *o = c + n as f64 * q;
        }
        Some(out)
    }

    fn vector(self) -> usize {
        match self {
            Precision::Exact => 24,
            Precision::Quantised(_) => 12,
        }
    }
}

/// Why a message cannot be encoded.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EncodeError {
    /// A count past what its field holds.
    #[error("{what}: {count} is more than the encoding holds ({max})")]
    TooMany {
        what: &'static str,
        count: usize,
        max: usize,
    },
    /// A value that the quantum cannot represent (or not finite).
    #[error("{what}: {value} is out of range for a quantum of {quantum}")]
    OutOfRange {
        what: &'static str,
        value: f64,
        quantum: f64,
    },
    /// The quantum is not a positive finite number.
    #[error("quantum {0}: must be positive and finite")]
    Quantum(f64),
}

/// Why bytes were refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The first byte names another version.
    #[error("version {0}, expected {VERSION}")]
    Version(u8),
    /// The bytes end inside a field.
    #[error("truncated at byte {0}")]
    Truncated(usize),
    /// Bytes left after the last field.
    #[error("{0} bytes after the message")]
    Trailing(usize),
    /// A value that cannot be (a quantum that is not positive, a non-finite number).
    #[error("invalid {0}")]
    Invalid(&'static str),
}

/// The committed body path of a command (`vbap_math::schedule::BodySchedule`).
#[derive(Clone, Debug, PartialEq)]
pub struct PlanPart {
    /// First tick of the first segment.
    pub start: u64,
    /// Ticks per segment.
    pub seg_ticks: u64,
    /// The segments (velocity 3, dk/dt, ṡ).
    pub segments: Vec<[f64; 5]>,
}

/// What one vehicle is told for one step (the content `vehicle_agent::Guidance` is built
/// from), as it would cross its link.
#[derive(Clone, Debug, PartialEq)]
pub struct AgentCommand {
    /// Tick k of the command.
    pub tick: u64,
    /// [`AgentCommand::HOLDING`], [`AgentCommand::FINISHED`].
    pub flags: u8,
    /// Body centre r, length unit.
    pub r: [f64; 3],
    /// Formation scale k.
    pub scale: f64,
    /// Body velocity, length unit/s.
    pub velocity: [f64; 3],
    /// Scaled inter-vehicle potential (α, d0, d1).
    pub inter: [f64; 3],
    /// Scaled vehicle–leader potential (α, h0, h1).
    pub leader: [f64; 3],
    /// Damping K, 1/s.
    pub damping: f64,
    /// The committed path, if any.
    pub plan: Option<PlanPart>,
    /// The virtual leaders within the vehicle's reach, length unit.
    pub leaders: Vec<[f64; 3]>,
    /// The vehicle's own entry, if the snapshot has one.
    pub own: Option<SnapshotEntry>,
    /// The entries of its neighbour list (ordered by id).
    pub neighbours: Vec<SnapshotEntry>,
}

/// Bytes of the fixed part: version, flags, tick, 14 f64.
const FIXED: usize = 1 + 1 + 4 + 14 * 8;

impl AgentCommand {
    /// Flag: the body holds position.
    pub const HOLDING: u8 = 1;
    /// Flag: the mission is over.
    pub const FINISHED: u8 = 2;

    /// The size of [`AgentCommand::encode`]'s output with `precision`, bytes, from the counts
    /// alone (no encoding).
    pub fn encoded_len(&self, precision: Precision) -> usize {
        command_len(
            self.plan.as_ref().map(|p| p.segments.len()),
            self.leaders.len(),
            self.own.as_ref(),
            &self.neighbours,
            precision,
        )
    }

    /// The message's bytes.
    pub fn encode(&self, precision: Precision) -> Result<Vec<u8>, EncodeError> {
        let mut w = Writer {
            out: Vec::with_capacity(self.encoded_len(precision)),
            precision,
            origin: self.r,
        };
        if let Precision::Quantised(q) = precision {
            if !(q.is_finite() && q > 0.0) {
                return Err(EncodeError::Quantum(q));
            }
        }
        let mut flags = self.flags & (Self::HOLDING | Self::FINISHED);
        flags |= if self.plan.is_some() { PLAN } else { 0 };
        flags |= if self.own.is_some() { OWN } else { 0 };
        flags |= if matches!(precision, Precision::Quantised(_)) {
            QUANTISED
        } else {
            0
        };
        w.out.extend_from_slice(&[VERSION, flags]);
        w.u32("tick", self.tick)?;
        if let Precision::Quantised(q) = precision {
            w.f64(q);
        }
        for v in self
            .r
            .iter()
            .chain([self.scale].iter())
            .chain(&self.velocity)
            .chain(&self.inter)
            .chain(&self.leader)
            .chain([self.damping].iter())
        {
            w.f64(*v);
        }
        if let Some(p) = &self.plan {
            w.u32("plan start", p.start)?;
            w.u16("ticks per segment", p.seg_ticks as usize)?;
            if p.segments.len() > u8::MAX as usize {
                return Err(too_many(
                    "path segments",
                    p.segments.len(),
                    u8::MAX as usize,
                ));
            }
            w.out.push(p.segments.len() as u8);
            for s in &p.segments {
                s.iter().for_each(|v| w.f64(*v));
            }
        }
        w.u16("leaders", self.leaders.len())?;
        for l in &self.leaders {
            w.position("leader", l)?;
        }
        if let Some(e) = &self.own {
            w.out.extend_from_slice(&[e.alive as u8, bits(e, true)]);
            w.u16("incarnation", e.incarnation as usize)?;
            w.entry_vectors(e, true)?;
        }
        w.u16("neighbours", self.neighbours.len())?;
        for e in &self.neighbours {
            w.u16("neighbour id", e.id as usize)?;
            w.out.extend_from_slice(&[e.alive as u8, bits(e, false)]);
            w.entry_vectors(e, false)?;
        }
        debug_assert_eq!(w.out.len(), self.encoded_len(precision));
        Ok(w.out)
    }

    /// A command from its bytes (quantised values come back as the multiples of the
    /// quantum they were written as).
    pub fn decode(b: &[u8]) -> Result<Self, DecodeError> {
        let (mut r, flags) = Reader::open(b)?;
        let tick = r.u32()? as u64;
        if flags & QUANTISED != 0 {
            let q = r.f64()?;
            if !(q.is_finite() && q > 0.0) {
                return Err(DecodeError::Invalid("quantum"));
            }
            r.q = Some(q);
        }
        let mut f = [0.0; 14];
        for v in &mut f {
            *v = r.f64()?;
        }
        let origin = [f[0], f[1], f[2]];
        let plan = if flags & PLAN != 0 {
            let start = r.u32()? as u64;
            let seg_ticks = r.u16()? as u64;
            let n = r.u8()? as usize;
            let mut segments = Vec::with_capacity(n);
            for _ in 0..n {
                let mut s = [0.0; 5];
                for v in &mut s {
                    *v = r.f64()?;
                }
                segments.push(s);
            }
            Some(PlanPart {
                start,
                seg_ticks,
                segments,
            })
        } else {
            None
        };
        let n_l = r.u16()? as usize;
        let mut leaders = Vec::with_capacity(n_l.min(b.len()));
        for _ in 0..n_l {
            leaders.push(r.position(&origin)?);
        }
        let own = if flags & OWN != 0 {
            let alive = r.u8()? as u32;
            let bits = r.u8()?;
            let incarnation = r.u16()? as u32;
            let mut e = SnapshotEntry {
                alive,
                incarnation,
                ..SnapshotEntry::default()
            };
            r.entry_vectors(&mut e, bits, true, &origin)?;
            Some(e)
        } else {
            None
        };
        let n = r.u16()? as usize;
        let mut neighbours = Vec::with_capacity(n.min(b.len()));
        for _ in 0..n {
            let id = r.u16()? as u32;
            let alive = r.u8()? as u32;
            let bits = r.u8()?;
            let mut e = SnapshotEntry {
                id,
                alive,
                ..SnapshotEntry::default()
            };
            r.entry_vectors(&mut e, bits, false, &origin)?;
            neighbours.push(e);
        }
        if r.at != b.len() {
            return Err(DecodeError::Trailing(b.len() - r.at));
        }
        let is_finite = f.iter().all(|v| v.is_finite())
            && plan
                .as_ref()
                .is_none_or(|p| p.segments.iter().flatten().all(|v| v.is_finite()));
        if !is_finite {
            return Err(DecodeError::Invalid("number"));
        }
        Ok(Self {
            tick,
            flags: flags & (Self::HOLDING | Self::FINISHED),
            r: origin,
            scale: f[3],
            velocity: [f[4], f[5], f[6]],
            inter: [f[7], f[8], f[9]],
            leader: [f[10], f[11], f[12]],
            damping: f[13],
            plan,
            leaders,
            own,
            neighbours,
        })
    }
}

/// The size of a command (bytes) with a path of `plan` segments (None: no path),
/// `leaders` leaders, the vehicle's entry `own` and the entries `neighbours`, written with
/// `precision`: [`AgentCommand::encoded_len`] without building the command.
pub fn command_len(
    plan: Option<usize>,
    leaders: usize,
    own: Option<&SnapshotEntry>,
    neighbours: &[SnapshotEntry],
    precision: Precision,
) -> usize {
    let p = precision.vector();
    let quantum = if matches!(precision, Precision::Quantised(_)) {
        8
    } else {
        0
    };
    let vectors = |e: &SnapshotEntry, own: bool| {
        let b = bits(e, own);
        2 * p
            + if b & REJOINING != 0 { p } else { 0 }
            + if b & HAS_SLOT != 0 { p } else { 0 }
            + if b & HAS_AGE != 0 { 8 } else { 0 }
    };
    FIXED
        + quantum
        + plan.map_or(0, |n| 7 + 40 * n)
        + 2
        + leaders * p
        + own.map_or(0, |e| 4 + vectors(e, true))
        + 2
        + neighbours
            .iter()
            .map(|e| 4 + vectors(e, false))
            .sum::<usize>()
}

/// The size of one acoustic state frame (`[acoustic]`), bytes: the sender's id (`u16`), its
/// state's tick (`u32`, wrapping), then its position and velocity at `precision`
/// (absolute: 2 × 12 bytes quantised, 2 × 24 exact). 30 bytes fit the 32-byte frame of an
/// FH-FSK acoustic modem.
pub fn acoustic_frame_len(precision: Precision) -> usize {
    2 + 4 + 2 * precision.vector()
}

/// The entry bits of `e`: rejoining, has a slot (own entry only), age present.
fn bits(e: &SnapshotEntry, own: bool) -> u8 {
    let mut b = 0;
    if e.rejoining != 0 {
        b |= REJOINING;
    }
    if own && e.has_slot != 0 {
        b |= HAS_SLOT;
    }
    if e.age.to_bits() != 0 {
        b |= HAS_AGE;
    }
    b
}

/// The multiple of `q` nearest to `x − origin`, if an `i32` holds it.
fn quanta(x: f64, origin: f64, q: f64) -> Option<i32> {
    let n = ((x - origin) / q).round();
    (n.is_finite() && n.abs() <= i32::MAX as f64).then_some(n as i32)
}

fn too_many(what: &'static str, count: usize, max: usize) -> EncodeError {
    EncodeError::TooMany { what, count, max }
}

struct Writer {
    out: Vec<u8>,
    precision: Precision,
    origin: [f64; 3],
}

impl Writer {
    fn f64(&mut self, v: f64) {
        self.out.extend_from_slice(&v.to_le_bytes());
    }
    fn u16(&mut self, what: &'static str, v: usize) -> Result<(), EncodeError> {
        let v = u16::try_from(v).map_err(|_| too_many(what, v, u16::MAX as usize))?;
        self.out.extend_from_slice(&v.to_le_bytes());
        Ok(())
    }
    fn u32(&mut self, what: &'static str, v: u64) -> Result<(), EncodeError> {
        let v = u32::try_from(v).map_err(|_| too_many(what, v as usize, u32::MAX as usize))?;
        self.out.extend_from_slice(&v.to_le_bytes());
        Ok(())
    }
    /// A vector, relative to `origin` when quantised (zeros for a velocity).
    fn vector(
        &mut self,
        what: &'static str,
        v: &[f64; 3],
        origin: [f64; 3],
    ) -> Result<(), EncodeError> {
        match self.precision {
            Precision::Exact => v.iter().for_each(|x| self.f64(*x)),
            Precision::Quantised(q) => {
                for (x, o) in v.iter().zip(origin) {
                    let n = quanta(*x, o, q).ok_or(EncodeError::OutOfRange {
                        what,
                        value: *x,
                        quantum: q,
                    })?;
                    self.out.extend_from_slice(&n.to_le_bytes());
                }
            }
        }
        Ok(())
    }
    fn position(&mut self, what: &'static str, v: &[f64; 3]) -> Result<(), EncodeError> {
        self.vector(what, v, self.origin)
    }
    fn entry_vectors(&mut self, e: &SnapshotEntry, own: bool) -> Result<(), EncodeError> {
        let b = bits(e, own);
        self.position("position", &e.position)?;
        self.vector("velocity", &e.velocity, [0.0; 3])?;
        if b & REJOINING != 0 {
            self.position("target", &e.target)?;
        }
        if b & HAS_SLOT != 0 {
            self.position("slot", &e.slot)?;
        }
        if b & HAS_AGE != 0 {
            self.f64(e.age);
        }
        Ok(())
    }
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
    q: Option<f64>,
}

impl<'a> Reader<'a> {
    /// A reader of the message `b` after its version (checked) and flags, and the flags.
    fn open(b: &'a [u8]) -> Result<(Self, u8), DecodeError> {
        let mut r = Reader { b, at: 0, q: None };
        let version = r.u8()?;
        if version != VERSION {
            return Err(DecodeError::Version(version));
        }
        let flags = r.u8()?;
        Ok((r, flags))
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], DecodeError> {
        let bytes = self
            .b
            .get(self.at..self.at + N)
            .ok_or(DecodeError::Truncated(self.b.len()))?;
        self.at += N;
        Ok(bytes.try_into().expect("N bytes"))
    }
    fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, DecodeError> {
        Ok(u16::from_le_bytes(self.take()?))
    }
    fn u32(&mut self) -> Result<u32, DecodeError> {
        Ok(u32::from_le_bytes(self.take()?))
    }
    fn f64(&mut self) -> Result<f64, DecodeError> {
        Ok(f64::from_le_bytes(self.take()?))
    }
    fn vector(&mut self, origin: [f64; 3]) -> Result<[f64; 3], DecodeError> {
        let mut v = [0.0; 3];
        for (x, o) in v.iter_mut().zip(origin) {
            *x = match self.q {
                None => self.f64()?,
                Some(q) => o + i32::from_le_bytes(self.take()?) as f64 * q,
            };
            if !x.is_finite() {
                return Err(DecodeError::Invalid("number"));
            }
        }
        Ok(v)
    }
    fn position(&mut self, origin: &[f64; 3]) -> Result<[f64; 3], DecodeError> {
        self.vector(*origin)
    }
    fn entry_vectors(
        &mut self,
        e: &mut SnapshotEntry,
        bits: u8,
        own: bool,
        origin: &[f64; 3],
    ) -> Result<(), DecodeError> {
        e.position = self.position(origin)?;
        e.velocity = self.vector([0.0; 3])?;
        if bits & REJOINING != 0 {
            e.rejoining = 1;
            e.target = self.position(origin)?;
        }
        if own && bits & HAS_SLOT != 0 {
            e.has_slot = 1;
            e.slot = self.position(origin)?;
        }
        if bits & HAS_AGE != 0 {
            e.age = self.f64()?;
            if !e.age.is_finite() {
                return Err(DecodeError::Invalid("age"));
            }
        }
        Ok(())
    }
}

/// What a vehicle reports of one tick, as it would cross its link.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StateReport {
    /// [`crate::msg::agent_to_coordinator::VehicleState`]'s flags.
    pub flags: u8,
    /// Incarnation of the vehicle's process.
    pub incarnation: u16,
    /// Tick k.
    pub tick: u64,
    /// Commands read so far.
    pub commands_read: u64,
    /// Where the vehicle believes it is, length unit.
    pub position: [f64; 3],
    /// Its velocity through the water, length unit/s.
    pub velocity: [f64; 3],
    /// Its sensor reading, field unit.
    pub reading: f64,
}

impl StateReport {
    /// Bytes of every report.
    pub const LEN: usize = 1 + 1 + 2 + 4 + 4 + 7 * 8;

    /// The report's bytes (a tick or count past `u32` cannot be sent).
    pub fn encode(&self) -> Result<[u8; Self::LEN], EncodeError> {
        let mut w = Writer {
            out: Vec::with_capacity(Self::LEN),
            precision: Precision::Exact,
            origin: [0.0; 3],
        };
        w.out.extend_from_slice(&[VERSION, self.flags]);
        w.out.extend_from_slice(&self.incarnation.to_le_bytes());
        w.u32("tick", self.tick)?;
        w.u32("commands read", self.commands_read)?;
        for v in self
            .position
            .iter()
            .chain(&self.velocity)
            .chain([self.reading].iter())
        {
            w.f64(*v);
        }
        Ok(w.out.try_into().expect("a report is LEN bytes"))
    }

    /// A report from its bytes.
    pub fn decode(b: &[u8]) -> Result<Self, DecodeError> {
        let (mut r, flags) = Reader::open(b)?;
        let incarnation = r.u16()?;
        let tick = r.u32()? as u64;
        let commands_read = r.u32()? as u64;
        let position = r.vector([0.0; 3])?;
        let velocity = r.vector([0.0; 3])?;
        let reading = r.f64()?;
        if r.at != b.len() {
            return Err(DecodeError::Trailing(b.len() - r.at));
        }
        Ok(Self {
            flags,
            incarnation,
            tick,
            commands_read,
            position,
            velocity,
            reading,
        })
    }
}

#[cfg(test)]
mod tests;
