//! What crosses the wire: our `#[repr(C)]` payloads as bytes, behind a header naming the
//! payload's type and version, so a peer of another build is refused, never read.
//!
//! A frame is `VBAPW3` (magic and wire version), one byte giving the length of the type
//! name, the type name (`vbap.VehicleState.v5`: the versioned iceoryx2 type name of the
//! payload), then one or more entries, each a native-endian `u32` length and the payload's
//! bytes in use ([`Raw::wire_bytes`]): a state or a process exit whole, exactly as in shared
//! memory; a body command without the entries it does not use (its fixed part, then its
//! leaders, snapshot entries, path segments and neighbour lists in use: 2.8 KB for 16
//! vehicles instead of the whole 205 KB sized for `MAX_VEHICLES`; the rest is zeros on
//! arrival). A glider
//! host's states of one pass go in one frame (one Zenoh put per host per tick, [`Batch`]);
//! a body command or a process exit is a frame of one entry. Wire versions 1 (one payload
//! per frame, no lengths) and 2 (body commands whole) are refused. Each entry is checked
//! alone: one of the wrong size, or a body command whose counts disagree with its length,
//! is refused, the others of its frame are read. Both ends run on the same architecture
//! (the bytes are native-endian; a host of another byte order or layout has another size
//! or is refused by name only if the version differs: run one build of vbap on every host).
//!
//! The payloads are read and written through their raw twins (`vbap_wire::versioned`):
//! byte arrays with the name, size and alignment of the real payload, declared with it
//! from one literal, so iceoryx2 opens the real services with them and the bridge copies
//! bytes without decoding (and without `unsafe`).

use std::borrow::Cow;
use std::mem::{offset_of, size_of};

use iceoryx2::prelude::ZeroCopySend;
pub use vbap_wire::msg::agent_to_coordinator::RawVehicleState as RawState;
pub use vbap_wire::msg::coordinator_to_agent::RawBodyCommand as RawBody;
pub use vbap_wire::msg::supervisor_to_coordinator::RawProcessExit as RawExit;
pub use vbap_wire::versioned::RawBytes;

/// Magic and wire version of every frame.
pub const MAGIC: &[u8; 6] = b"VBAPW3";

/// Bytes of an entry's length prefix.
const LEN: usize = 4;

/// A payload carried as bytes under its versioned type name ([`RawBytes::TYPE_NAME`],
/// the payload's own).
pub trait Raw: RawBytes + ZeroCopySend {
    /// The iceoryx2 type name of the payload (as in `vbap_wire::msg`).
    const NAME: &'static str = <Self as vbap_wire::versioned::Versioned>::TYPE_NAME;

    /// The bytes of this payload that go on the wire: all of them unless the payload says
    /// otherwise.
    fn wire_bytes(&self) -> Cow<'_, [u8]> {
        Cow::Borrowed(self.bytes())
    }

    /// The payload of wire bytes `b` ([`Raw::wire_bytes`] of a peer of this build).
    fn from_wire(b: &[u8]) -> Result<Self, Refused> {
        let want = size_of::<Self>();
        if b.len() == want {
            Ok(Self::from_bytes(b))
        } else {
            Err(Refused::Size { got: b.len(), want })
        }
    }
}

impl Raw for RawState {}
impl Raw for RawExit {}

/// The [`Header`] every payload starts its own fields with, read from a raw payload's bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WireHeader {
    /// [`Header::sender`].
    pub sender: u32,
    /// [`Header::flags`].
    pub flags: u32,
    /// [`Header::seq`].
    pub seq: u64,
    /// [`Header::sent_ns`].
    pub sent_ns: u64,
}

/// A raw payload whose [`Header`] sits at byte [`Headed::HEADER`] of its bytes.
pub trait Headed: Raw {
    /// Byte offset of the payload's header.
    const HEADER: usize;

    /// The payload's header fields.
    fn header(&self) -> WireHeader {
        let (b, h) = (self.bytes(), Self::HEADER);
        WireHeader {
            sender: u32_at(b, h + offset_of!(Header, sender)),
            flags: u32_at(b, h + offset_of!(Header, flags)),
            seq: u64_at(b, h + offset_of!(Header, seq)),
            sent_ns: u64_at(b, h + offset_of!(Header, sent_ns)),
        }
    }
}

impl Headed for RawState {
    const HEADER: usize = offset_of!(VehicleState, header);
}
impl Headed for RawBody {
    const HEADER: usize = offset_of!(BodyCommand, header);
}
impl Headed for RawExit {
    const HEADER: usize = offset_of!(ProcessExit, header);
}

/// A body command on the wire: its fixed part (header to the counts), its leaders,
/// snapshot entries and path segments in use, and the path's scalars between them, in the
/// order of the struct.
impl Raw for RawBody {
    fn wire_bytes(&self) -> Cow<'_, [u8]> {
        let b = self.bytes();
        let (n_l, n_v) = (
            (u32_at(b, N_LEADERS) as usize).min(MAX_LEADERS),
            (u32_at(b, N_VEHICLES) as usize).min(MAX_VEHICLES),
        );
        let n_p = (u32_at(b, N_PLAN) as usize).min(MAX_PLAN);
        let mut out = Vec::with_capacity(body_wire_len(n_l, n_v, n_p, MAX_NEAR_ENTRIES));
        out.extend_from_slice(&b[..LEADERS]);
        out.extend_from_slice(&b[LEADERS..LEADERS + n_l * LEADER]);
        out.extend_from_slice(&b[SNAPSHOT..SNAPSHOT + n_v * ENTRY]);
        out.extend_from_slice(&b[PLAN_START..PLAN]);
        out.extend_from_slice(&b[PLAN..PLAN + n_p * SEGMENT]);
        let n_near = (u32_at(b, N_NEAR) as usize).min(MAX_NEAR_ENTRIES);
        out.extend_from_slice(&b[N_NEAR..NEAR_START]);
        out.extend_from_slice(&b[NEAR_START..NEAR_START + (n_v + 1) * START]);
        out.extend_from_slice(&b[NEAR..NEAR + n_near * INDEX]);
        Cow::Owned(out)
    }

    fn from_wire(w: &[u8]) -> Result<Self, Refused> {
        let refused = |want: usize| Refused::Size { got: w.len(), want };
        if w.len() < LEADERS {
            return Err(refused(LEADERS));
        }
        let (n_l, n_v) = (
            u32_at(w, N_LEADERS) as usize,
            u32_at(w, N_VEHICLES) as usize,
        );
        if n_l > MAX_LEADERS || n_v > MAX_VEHICLES {
            return Err(refused(body_wire_len(
                n_l.min(MAX_LEADERS),
                n_v.min(MAX_VEHICLES),
                0,
                0,
            )));
        }
        let tail = LEADERS + n_l * LEADER + n_v * ENTRY;
        if w.len() < tail + (PLAN - PLAN_START) {
            return Err(refused(body_wire_len(n_l, n_v, 0, 0)));
        }
        let n_p = u32_at(w, tail + (N_PLAN - PLAN_START)) as usize;
        if n_p > MAX_PLAN {
            return Err(refused(body_wire_len(n_l, n_v, MAX_PLAN, 0)));
        }
        let lists = tail + (PLAN - PLAN_START) + n_p * SEGMENT;
        if w.len() < lists + (NEAR_START - N_NEAR) {
            return Err(refused(body_wire_len(n_l, n_v, n_p, 0)));
        }
        let n_near = u32_at(w, lists) as usize;
        let want = body_wire_len(n_l, n_v, n_p, n_near.min(MAX_NEAR_ENTRIES));
        if n_near > MAX_NEAR_ENTRIES || w.len() != want {
            return Err(refused(want));
        }
        let mut full = vec![0u8; size_of::<BodyCommand>()];
        let mut from = 0;
        let mut copy = |to: usize, len: usize| {
            full[to..to + len].copy_from_slice(&w[from..from + len]);
            from += len;
        };
        copy(0, LEADERS + n_l * LEADER);
        copy(SNAPSHOT, n_v * ENTRY);
        copy(PLAN_START, PLAN - PLAN_START + n_p * SEGMENT);
        copy(N_NEAR, NEAR_START - N_NEAR + (n_v + 1) * START);
        copy(NEAR, n_near * INDEX);
        Ok(Self::from_bytes(&full))
    }
}

use vbap_math::schedule::MAX_PLAN;
use vbap_wire::msg::agent_to_coordinator::VehicleState;
use vbap_wire::msg::coordinator_to_agent::{BodyCommand, SnapshotEntry};
use vbap_wire::msg::supervisor_to_coordinator::ProcessExit;
use vbap_wire::msg::Header;
use vbap_wire::msg::{MAX_LEADERS, MAX_NEAR_ENTRIES, MAX_VEHICLES};

/// Offsets and sizes within a [`BodyCommand`], bytes.
const LEADERS: usize = offset_of!(BodyCommand, leaders);
const N_LEADERS: usize = offset_of!(BodyCommand, n_leaders);
const N_VEHICLES: usize = offset_of!(BodyCommand, n_vehicles);
const SNAPSHOT: usize = offset_of!(BodyCommand, snapshot);
const PLAN_START: usize = offset_of!(BodyCommand, plan_start);
const N_PLAN: usize = offset_of!(BodyCommand, n_plan);
const PLAN: usize = offset_of!(BodyCommand, plan);
const N_NEAR: usize = offset_of!(BodyCommand, n_near);
const NEAR_START: usize = offset_of!(BodyCommand, near_start);
const NEAR: usize = offset_of!(BodyCommand, near);
const LEADER: usize = size_of::<[f64; 3]>();
const ENTRY: usize = size_of::<SnapshotEntry>();
const SEGMENT: usize = size_of::<[f64; 5]>();
const START: usize = size_of::<u32>();
const INDEX: usize = size_of::<u16>();
const _: () = assert!(LEADERS + MAX_LEADERS * LEADER == SNAPSHOT);
const _: () = assert!(SNAPSHOT + MAX_VEHICLES * ENTRY == PLAN_START);
const _: () = assert!(PLAN + MAX_PLAN * SEGMENT == N_NEAR);
const _: () = assert!(N_NEAR + START == NEAR_START);
const _: () = assert!(NEAR_START + (MAX_VEHICLES + 1) * START == NEAR);
const _: () = assert!(NEAR + MAX_NEAR_ENTRIES * INDEX == size_of::<BodyCommand>());

/// Wire bytes of a body command with `n_l` leaders, `n_v` vehicles, `n_p` segments and
/// `n_near` entries in its neighbour lists.
fn body_wire_len(n_l: usize, n_v: usize, n_p: usize, n_near: usize) -> usize {
    LEADERS
        + n_l * LEADER
        + n_v * ENTRY
        + (PLAN - PLAN_START)
        + n_p * SEGMENT
        + (NEAR_START - N_NEAR)
        + (n_v + 1) * START
        + n_near * INDEX
}

/// A frame being filled with payloads of type `T` (the states of one glider host's pass).
pub struct Batch<T: Raw> {
    bytes: Vec<u8>,
    entries: usize,
    _t: std::marker::PhantomData<T>,
}

impl<T: Raw> Default for Batch<T> {
    fn default() -> Self {
        let mut bytes = Vec::with_capacity(MAGIC.len() + 1 + T::NAME.len() + LEN);
        bytes.extend_from_slice(MAGIC);
        bytes.push(T::NAME.len() as u8);
        bytes.extend_from_slice(T::NAME.as_bytes());
        Self {
            bytes,
            entries: 0,
            _t: std::marker::PhantomData,
        }
    }
}

impl<T: Raw> Batch<T> {
    /// Appends payload `p`.
    pub fn push(&mut self, p: &T) {
        let b = p.wire_bytes();
        self.bytes
            .extend_from_slice(&(b.len() as u32).to_ne_bytes());
        self.bytes.extend_from_slice(&b);
        self.entries += 1;
    }
    /// The payloads appended so far.
    pub fn len(&self) -> usize {
        self.entries
    }
    pub fn is_empty(&self) -> bool {
        self.entries == 0
    }
    /// The frame.
    pub fn frame(&self) -> &[u8] {
        &self.bytes
    }
}

/// The frame of payload `p` alone.
pub fn encode<T: Raw>(p: &T) -> Vec<u8> {
    let mut b = Batch::<T>::default();
    b.push(p);
    b.bytes
}

/// Why a frame, or one entry of it, was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// Not a frame of this wire version.
    #[error("not a vbap frame of wire version 2")]
    Magic,
    /// Another payload type or version (a peer of another build).
    #[error("payload {got:?} where {want:?} was expected")]
    Type { got: String, want: &'static str },
    /// The right name but another size.
    #[error("payload of {got} bytes where {want} were expected")]
    Size { got: usize, want: usize },
    /// An entry's length runs past the frame's end (the rest of the frame is unreadable).
    #[error("an entry of {got} bytes where {left} are left in the frame")]
    Truncated { got: usize, left: usize },
    /// Not one entry where one was expected.
    #[error("{got} entries where one was expected")]
    Count { got: usize },
}

/// The entries of frame `frame`, each a `T` of this build or the reason it is refused;
/// Err when the frame as a whole is not one of `T`s.
pub fn decode_all<T: Raw>(frame: &[u8]) -> Result<Vec<Result<T, Refused>>, Refused> {
    let rest = frame.strip_prefix(MAGIC.as_slice()).ok_or(Refused::Magic)?;
    let (&len, rest) = rest.split_first().ok_or(Refused::Magic)?;
    let len = len as usize;
    if rest.len() < len {
        return Err(Refused::Magic);
    }
    let (name, mut rest) = rest.split_at(len);
    if name != T::NAME.as_bytes() {
        return Err(Refused::Type {
            got: String::from_utf8_lossy(name).into_owned(),
            want: T::NAME,
        });
    }
    let mut out = Vec::new();
    while !rest.is_empty() {
        if rest.len() < LEN {
            out.push(Err(Refused::Truncated {
                got: LEN,
                left: rest.len(),
            }));
            break;
        }
        let got = u32_at(rest, 0) as usize;
        rest = &rest[LEN..];
        if got > rest.len() {
            out.push(Err(Refused::Truncated {
                got,
                left: rest.len(),
            }));
            break;
        }
        let (payload, after) = rest.split_at(got);
        rest = after;
        out.push(T::from_wire(payload));
    }
    Ok(out)
}

/// The payload of frame `frame` of one entry, when it is a `T` of this build.
pub fn decode<T: Raw>(frame: &[u8]) -> Result<T, Refused> {
    let mut all = decode_all::<T>(frame)?;
    match all.len() {
        1 => all.remove(0),
        got => Err(Refused::Count { got }),
    }
}

/// Reads a native-endian u32 at `offset` of `bytes`.
pub fn u32_at(bytes: &[u8], offset: usize) -> u32 {
    let mut b = [0u8; 4];
    b.copy_from_slice(&bytes[offset..offset + 4]);
    u32::from_ne_bytes(b)
}

/// Reads a native-endian u64 at `offset` of `bytes`.
pub fn u64_at(bytes: &[u8], offset: usize) -> u64 {
    let mut b = [0u8; 8];
    b.copy_from_slice(&bytes[offset..offset + 8]);
    u64::from_ne_bytes(b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use vbap_ipc::topics::{Domain, Limits};
    use vbap_wire::msg::agent_to_coordinator::VehicleState;
    use vbap_wire::msg::Header;

    #[test]
    fn a_frame_reads_back_and_another_type_or_size_is_refused() {
        let state = RawState::from_bytes(&[7u8; std::mem::size_of::<VehicleState>()]);
        let frame = encode(&state);
        assert_eq!(decode::<RawState>(&frame).unwrap().bytes(), state.bytes());
        assert!(matches!(
            decode::<RawBody>(&frame),
            Err(Refused::Type { .. })
        ));
        let short = &frame[..frame.len() - 1];
        assert!(matches!(
            decode::<RawState>(short),
            Err(Refused::Truncated { .. })
        ));
        let old = String::from_utf8_lossy(&frame)
            .replace("v5", "v4")
            .into_bytes();
        assert!(matches!(
            decode::<RawState>(&old),
            Err(Refused::Type { .. })
        ));
        assert!(matches!(
            decode::<RawState>(b"nonsense"),
            Err(Refused::Magic)
        ));
    }

    #[test]
    fn a_batch_reads_back_entry_by_entry_and_a_bad_entry_is_refused_alone() {
        let size = std::mem::size_of::<VehicleState>();
        let mut batch = Batch::<RawState>::default();
        assert!(batch.is_empty());
        for k in 1..=3u8 {
            batch.push(&RawState::from_bytes(&vec![k; size]));
        }
        assert_eq!(batch.len(), 3);
        let got = decode_all::<RawState>(batch.frame()).unwrap();
        assert_eq!(got.len(), 3);
        for (k, g) in got.iter().enumerate() {
            assert_eq!(
                g.as_ref().unwrap().bytes(),
                vec![k as u8 + 1; size].as_slice()
            );
        }
        // A frame of more than one entry is not a single payload.
        assert!(matches!(
            decode::<RawState>(batch.frame()),
            Err(Refused::Count { got: 3 })
        ));
        // The second entry one byte short (its length says so): refused alone.
        let mut frame = encode(&RawState::from_bytes(&vec![1u8; size]));
        frame.extend_from_slice(&((size - 1) as u32).to_ne_bytes());
        frame.extend_from_slice(&vec![2u8; size - 1]);
        frame.extend_from_slice(&(size as u32).to_ne_bytes());
        frame.extend_from_slice(&vec![3u8; size]);
        let got = decode_all::<RawState>(&frame).unwrap();
        assert!(got[0].is_ok() && got[2].is_ok(), "{got:?}");
        assert!(matches!(got[1], Err(Refused::Size { .. })));
        // A length past the end: the rest is refused, what came before is read.
        let mut cut = encode(&RawState::from_bytes(&vec![1u8; size]));
        cut.extend_from_slice(&(size as u32).to_ne_bytes());
        cut.extend_from_slice(&[0u8; 10]);
        let got = decode_all::<RawState>(&cut).unwrap();
        assert!(got[0].is_ok());
        assert!(matches!(got[1], Err(Refused::Truncated { .. })));
        // Wire version 1 is refused as a whole.
        let mut v1 = batch.frame().to_vec();
        v1[5] = b'1';
        assert_eq!(decode_all::<RawState>(&v1).unwrap_err(), Refused::Magic);
    }

    #[test]
    fn a_body_command_travels_its_entries_in_use_only_and_reads_back_the_same() {
        use vbap_wire::msg::coordinator_to_agent::BodyCommand;
        let n = 16;
        let mut sent = Box::new(BodyCommand::empty());
        sent.header = Header::new(Header::COORDINATOR, 7, 0.35, 8);
        sent.s = 1.5;
        sent.r = [1.0, 2.0, 3.0];
        sent.n_leaders = 1;
        sent.leaders[0] = [4.0, 5.0, 6.0];
        sent.n_vehicles = n as u32;
        for (i, e) in sent.snapshot.iter_mut().take(n).enumerate() {
            e.id = i as u32;
            e.alive = 1;
            e.position = [i as f64, -(i as f64), 0.5];
            e.age = 0.25;
        }
        sent.plan_start = 7;
        sent.plan_ticks = 20;
        sent.n_plan = 2;
        sent.plan[1] = [0.1, 0.2, 0.3, 0.4, 0.5];
        // Each hears of the one before and the one after it.
        let mut near = Vec::new();
        for i in 0..n {
            sent.near_start[i] = near.len() as u32;
            near.extend((i.saturating_sub(1)..(i + 2).min(n)).filter(|&j| j != i));
        }
        sent.near_start[n] = near.len() as u32;
        sent.n_near = near.len() as u32;
        for (d, &j) in sent.near.iter_mut().zip(&near) {
            *d = j as u16;
        }
        // Through shared memory as the coordinator writes it (entries in use only), read as
        // the bridge reads it (raw), over the wire, published raw as the far bridge does,
        // read as an agent reads it.
        let limits = Limits::for_fleet(n);
        let here = Domain::new(&format!("wire_a_{}", std::process::id())).unwrap();
        let node = here.node("wire_test").unwrap();
        let raw_sub =
            vbap_ipc::ports::subscriber(&here.body_service_as::<RawBody>(&node, &limits).unwrap())
                .unwrap();
        let p = vbap_ipc::ports::publisher(&here.body_service(&node, &limits).unwrap()).unwrap();
        vbap_ipc::prefix::publish(&p, &*sent).unwrap();
        let raw = *raw_sub.receive().unwrap().expect("the bridge's raw read");
        drop((raw_sub, p, node));
        here.remove_files();
        let frame = encode(&raw);
        assert!(
            frame.len() < 4096,
            "a body of {n} vehicles: {} bytes",
            frame.len()
        );
        let arrived = decode::<RawBody>(&frame).unwrap();
        let there = Domain::new(&format!("wire_b_{}", std::process::id())).unwrap();
        let node = there.node("wire_test").unwrap();
        let sub =
            vbap_ipc::ports::subscriber(&there.body_service(&node, &limits).unwrap()).unwrap();
        let p =
            vbap_ipc::ports::publisher(&there.body_service_as::<RawBody>(&node, &limits).unwrap())
                .unwrap();
        p.send_copy(arrived).unwrap();
        let got = Box::new(*sub.receive().unwrap().expect("the agent's read"));
        drop((sub, p, node));
        there.remove_files();
        assert_eq!(got.header, sent.header);
        assert_eq!((got.s, got.r), (sent.s, sent.r));
        assert_eq!(got.leader_positions(), sent.leader_positions());
        assert_eq!(got.snapshot_entries(), sent.snapshot_entries());
        assert_eq!(got.schedule(), sent.schedule());
        for i in 0..n {
            assert_eq!(got.near_of(i), sent.near_of(i), "list {i}");
        }
        assert_eq!(got.near_of(5), &[4, 6]);
        assert!(got.is_valid());
        // The tail arrives as zeros, whatever shared memory held beyond the counts.
        assert!(arrived.bytes()[SNAPSHOT + n * ENTRY..PLAN_START]
            .iter()
            .all(|&b| b == 0));
        // One byte short, one too many, or counts past their capacity: refused.
        let wire = arrived.wire_bytes().into_owned();
        assert!(matches!(
            RawBody::from_wire(&wire[..wire.len() - 1]),
            Err(Refused::Size { .. })
        ));
        let mut long = wire.clone();
        long.push(0);
        assert!(matches!(
            RawBody::from_wire(&long),
            Err(Refused::Size { .. })
        ));
        let mut lying = wire.clone();
        lying[N_VEHICLES..N_VEHICLES + 4].copy_from_slice(&(MAX_VEHICLES as u32 + 1).to_ne_bytes());
        assert!(matches!(
            RawBody::from_wire(&lying),
            Err(Refused::Size { .. })
        ));
        assert!(matches!(
            RawBody::from_wire(&wire[..10]),
            Err(Refused::Size { .. })
        ));
    }

    #[test]
    fn the_raw_types_open_the_real_services_and_carry_their_bytes() {
        let name = format!("wire_{}", std::process::id());
        let domain = Domain::new(&name).unwrap();
        let limits = Limits::for_fleet(2);
        let node = domain.node("wire_test").unwrap();
        let real = domain.state_service(&node, 1, &limits).unwrap();
        let raw = domain
            .state_like_service_as::<RawState>(&node, "vehicle/1/state", &limits)
            .unwrap();
        let sub = vbap_ipc::ports::subscriber(&raw).unwrap();
        let publisher = vbap_ipc::ports::publisher(&real).unwrap();
        let sent = VehicleState {
            header: Header::new(1, 5, 0.25, 9),
            pid: 1234,
            ..VehicleState::default()
        };
        publisher.send_copy(sent).unwrap();
        let got = *sub
            .receive()
            .unwrap()
            .expect("the raw subscriber reads the state");
        let at = std::mem::offset_of!(VehicleState, pid);
        assert_eq!(u32_at(got.bytes(), at), 1234);
        assert_eq!(u64_at(got.bytes(), std::mem::offset_of!(Header, tick)), 5);
        let h = got.header();
        assert_eq!((h.sender, h.flags, h.seq), (1, 0, 9));
        assert_eq!(h.sent_ns, sent.header.sent_ns);
        drop((sub, publisher, real, raw, node));
        domain.remove_files();
        assert!(domain.files().is_empty());
    }
}
