//! What crosses the wire: our `#[repr(C)]` payloads as bytes, behind a header naming the
//! payload's type and version, so a peer of another build is refused, never read.
//!
//! A frame is `VBAPW2` (magic and wire version), one byte giving the length of the type
//! name, the type name (`vbap.VehicleState.v5`: the versioned iceoryx2 type name of the
//! payload), then one or more entries, each a native-endian `u32` length and the payload's
//! bytes exactly as in shared memory. A glider host's states of one pass go in one frame
//! (one Zenoh put per host per tick, [`Batch`]); a body command or a process exit is a frame
//! of one entry. Wire version 1 (one payload per frame, no lengths) is refused. Each entry
//! is checked alone: one of the wrong size is refused, the others of its frame are read.
//! Both ends run on the same architecture (the bytes are native-endian; a host of another
//! byte order or layout has another size or is refused by name only if the version
//! differs: run one build of vbap on every host).
//!
//! The payloads are read and written through their raw twins (`vbap_wire::versioned`):
//! byte arrays with the name, size and alignment of the real payload, declared with it
//! from one literal, so iceoryx2 opens the real services with them and the bridge copies
//! bytes without decoding (and without `unsafe`).

use iceoryx2::prelude::ZeroCopySend;
pub use vbap_wire::msg::agent_to_coordinator::RawVehicleState as RawState;
pub use vbap_wire::msg::coordinator_to_agent::RawBodyCommand as RawBody;
pub use vbap_wire::msg::supervisor_to_coordinator::RawProcessExit as RawExit;
pub use vbap_wire::versioned::RawBytes;

/// Magic and wire version of every frame.
pub const MAGIC: &[u8; 6] = b"VBAPW2";

/// Bytes of an entry's length prefix.
const LEN: usize = 4;

/// A payload carried as bytes under its versioned type name ([`RawBytes::TYPE_NAME`],
/// the payload's own).
pub trait Raw: RawBytes + ZeroCopySend {
    /// The iceoryx2 type name of the payload (as in `vbap_wire::msg`).
    const NAME: &'static str = <Self as vbap_wire::versioned::Versioned>::TYPE_NAME;
}

impl<T: RawBytes + ZeroCopySend> Raw for T {}

/// A frame being filled with payloads of type `T` (the states of one glider host's pass).
pub struct Batch<T: Raw> {
    bytes: Vec<u8>,
    entries: usize,
    _t: std::marker::PhantomData<T>,
}

impl<T: Raw> Default for Batch<T> {
    fn default() -> Self {
        let mut bytes = Vec::with_capacity(MAGIC.len() + 1 + T::NAME.len() + LEN + size_of::<T>());
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
        let b = p.bytes();
        self.bytes
            .extend_from_slice(&(b.len() as u32).to_ne_bytes());
        self.bytes.extend_from_slice(b);
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
    let want = size_of::<T>();
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
        out.push(if got == want {
            Ok(T::from_bytes(payload))
        } else {
            Err(Refused::Size { got, want })
        });
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
        drop((sub, publisher, real, raw, node));
        domain.remove_files();
        assert!(domain.files().is_empty());
    }
}
