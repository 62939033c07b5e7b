//! What crosses the wire: our `#[repr(C)]` payloads as bytes, behind a header naming the
//! payload's type and version, so a peer of another build is refused, never read.
//!
//! A frame is `VBAPW1` (magic and wire version), one byte giving the length of the type
//! name, the type name (`vbap.VehicleState.v5`: the versioned iceoryx2 type name of the
//! payload), then the payload's bytes exactly as in shared memory. Both ends run on the
//! same architecture (the bytes are native-endian; a host of another byte order or
//! layout has another size or is refused by name only if the version differs: run one
//! build of vbap on every host).
//!
//! The payloads are read and written through [`Raw`] types: byte arrays with the name,
//! size and alignment of the real payload, so iceoryx2 opens the real services with them
//! and the bridge copies bytes without decoding (and without `unsafe`).

use iceoryx2::prelude::ZeroCopySend;
use vbap_ipc::msg::agent_to_coordinator::VehicleState;
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;

/// Magic and wire version of every frame.
pub const MAGIC: &[u8; 6] = b"VBAPW1";

/// A payload carried as bytes: its versioned type name and its size.
pub trait Raw: Copy + std::fmt::Debug + ZeroCopySend + 'static {
    /// The iceoryx2 type name of the payload (as in `vbap_ipc::msg`).
    const NAME: &'static str;
    /// The payload's bytes.
    fn bytes(&self) -> &[u8];
    /// A payload of bytes `b` (exactly the payload's size: checked by [`decode`]).
    fn from_bytes(b: &[u8]) -> Self;
}

macro_rules! raw {
    ($raw:ident, $real:ty, $name:literal) => {
        #[doc = concat!("The bytes of a `", stringify!($real), "` (`", $name, "`).")]
        #[derive(Clone, Copy, Debug, ZeroCopySend)]
        #[repr(C)]
        #[repr(align(8))]
        #[type_name($name)]
        pub struct $raw {
            /// The payload, exactly as in shared memory.
            pub bytes: [u8; std::mem::size_of::<$real>()],
        }

        impl Raw for $raw {
            const NAME: &'static str = $name;
            fn bytes(&self) -> &[u8] {
                &self.bytes
            }
            fn from_bytes(b: &[u8]) -> Self {
                let mut bytes = [0u8; std::mem::size_of::<$real>()];
                bytes.copy_from_slice(b);
                Self { bytes }
            }
        }

        const _: () = assert!(std::mem::align_of::<$real>() == 8);
        const _: () = assert!(std::mem::size_of::<$raw>() == std::mem::size_of::<$real>());
    };
}

raw!(RawState, VehicleState, "vbap.VehicleState.v5");
raw!(RawBody, BodyCommand, "vbap.BodyCommand.v6");
raw!(RawExit, ProcessExit, "vbap.ProcessExit.v1");

/// The frame of payload `p`.
pub fn encode<T: Raw>(p: &T) -> Vec<u8> {
    let bytes = p.bytes();
    let mut out = Vec::with_capacity(MAGIC.len() + 1 + T::NAME.len() + bytes.len());
    out.extend_from_slice(MAGIC);
    out.push(T::NAME.len() as u8);
    out.extend_from_slice(T::NAME.as_bytes());
    out.extend_from_slice(bytes);
    out
}

/// Why a frame was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Refused {
    /// Not a frame of this wire version.
    #[error("not a vbap frame of wire version 1")]
    Magic,
    /// Another payload type or version (a peer of another build).
    #[error("payload {got:?} where {want:?} was expected")]
    Type { got: String, want: &'static str },
    /// The right name but another size.
    #[error("payload of {got} bytes where {want} were expected")]
    Size { got: usize, want: usize },
}

/// The payload of frame `frame`, when it is a `T` of this build.
pub fn decode<T: Raw>(frame: &[u8]) -> Result<T, Refused> {
    let rest = frame.strip_prefix(MAGIC.as_slice()).ok_or(Refused::Magic)?;
    let (&len, rest) = rest.split_first().ok_or(Refused::Magic)?;
    let len = len as usize;
    if rest.len() < len {
        return Err(Refused::Magic);
    }
    let (name, payload) = rest.split_at(len);
    if name != T::NAME.as_bytes() {
        return Err(Refused::Type {
            got: String::from_utf8_lossy(name).into_owned(),
            want: T::NAME,
        });
    }
    let want = std::mem::size_of::<T>();
    if payload.len() != want {
        return Err(Refused::Size {
            got: payload.len(),
            want,
        });
    }
    Ok(T::from_bytes(payload))
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
    use vbap_ipc::msg::Header;
    use vbap_ipc::topics::{Domain, Limits};

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
            Err(Refused::Size { .. })
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
