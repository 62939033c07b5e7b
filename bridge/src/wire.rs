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
//! The payloads are read and written through their raw twins (`vbap_ipc::versioned`):
//! byte arrays with the name, size and alignment of the real payload, declared with it
//! from one literal, so iceoryx2 opens the real services with them and the bridge copies
//! bytes without decoding (and without `unsafe`).

use iceoryx2::prelude::ZeroCopySend;
pub use vbap_ipc::msg::agent_to_coordinator::RawVehicleState as RawState;
pub use vbap_ipc::msg::coordinator_to_agent::RawBodyCommand as RawBody;
pub use vbap_ipc::msg::supervisor_to_coordinator::RawProcessExit as RawExit;
pub use vbap_ipc::versioned::RawBytes;

/// Magic and wire version of every frame.
pub const MAGIC: &[u8; 6] = b"VBAPW1";

/// A payload carried as bytes under its versioned type name ([`RawBytes::TYPE_NAME`],
/// the payload's own).
pub trait Raw: RawBytes + ZeroCopySend {
    /// The iceoryx2 type name of the payload (as in `vbap_ipc::msg`).
    const NAME: &'static str = <Self as vbap_ipc::versioned::Versioned>::TYPE_NAME;
}

impl<T: RawBytes + ZeroCopySend> Raw for T {}

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
    use vbap_ipc::msg::agent_to_coordinator::VehicleState;
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
