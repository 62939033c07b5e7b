//! The versioned type name of a payload that crosses hosts, written once.
//!
//! The bridge between hosts (`vbap-bridge`) copies payloads as bytes through *raw* types:
//! byte arrays of the payload's size and alignment under the payload's own iceoryx2 type
//! name, so iceoryx2 opens the real services with them. The raw type's name must be the
//! payload's; writing it twice by hand once let a raw `v4` meet a `v5` payload. Here the
//! [`versioned!`] macro declares the payload and its raw twin from one literal, and
//! [`Versioned::TYPE_NAME`] tells both.

/// A payload (or its raw twin) with its versioned iceoryx2 type name.
pub trait Versioned {
    /// The versioned type name, e.g. `vbap.VehicleState.v5`.
    const TYPE_NAME: &'static str;
}

/// The bytes of a payload under the payload's own type name (see the module doc).
pub trait RawBytes: Versioned + Copy + std::fmt::Debug + 'static {
    /// The payload these are the bytes of.
    type Payload: Versioned;
    /// The bytes, exactly as in shared memory.
    fn bytes(&self) -> &[u8];
    /// The raw payload of bytes `b` (exactly the payload's size; panics otherwise).
    fn from_bytes(b: &[u8]) -> Self;
}

/// `versioned! { "vbap.T.vN", RawT; <attributes> pub struct T { .. } }`: declares payload
/// `T` with iceoryx2 type name `"vbap.T.vN"` (no `#[type_name]` of its own), its raw twin
/// `RawT` (a `[u8; size_of::<T>()]` of `T`'s alignment, 8, under the same name) and
/// [`Versioned`] for both.
macro_rules! versioned {
    ($name:literal, $raw:ident; $(#[$m:meta])* $vis:vis struct $t:ident { $($body:tt)* }) => {
        $(#[$m])*
        #[type_name($name)]
        $vis struct $t { $($body)* }

        impl $crate::versioned::Versioned for $t {
            const TYPE_NAME: &'static str = $name;
        }

        #[doc = concat!("The bytes of a [`", stringify!($t), "`], under its type name `", $name, "` (for the bridge between hosts).")]
        #[derive(Clone, Copy, Debug, ZeroCopySend)]
        #[repr(C)]
        #[repr(align(8))]
        #[type_name($name)]
        pub struct $raw {
            /// The payload, exactly as in shared memory.
            pub bytes: [u8; std::mem::size_of::<$t>()],
        }

        impl $crate::versioned::Versioned for $raw {
            const TYPE_NAME: &'static str = $name;
        }

        impl $crate::versioned::RawBytes for $raw {
            type Payload = $t;
            fn bytes(&self) -> &[u8] {
                &self.bytes
            }
            fn from_bytes(b: &[u8]) -> Self {
                let mut bytes = [0u8; std::mem::size_of::<$t>()];
                bytes.copy_from_slice(b);
                Self { bytes }
            }
        }

        const _: () = assert!(std::mem::align_of::<$t>() == std::mem::align_of::<$raw>());
        const _: () = assert!(std::mem::size_of::<$t>() == std::mem::size_of::<$raw>());
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::agent_to_coordinator::{RawVehicleState, VehicleState};
    use crate::msg::coordinator_to_agent::{BodyCommand, RawBodyCommand};
    use crate::msg::supervisor_to_coordinator::{ProcessExit, RawProcessExit};

    #[test]
    fn each_raw_twin_has_its_payloads_versioned_name_and_size() {
        assert_eq!(RawVehicleState::TYPE_NAME, VehicleState::TYPE_NAME);
        assert_eq!(RawBodyCommand::TYPE_NAME, BodyCommand::TYPE_NAME);
        assert_eq!(RawProcessExit::TYPE_NAME, ProcessExit::TYPE_NAME);
        // The names are versioned: `vbap.<Type>.v<N>`.
        for name in [
            VehicleState::TYPE_NAME,
            BodyCommand::TYPE_NAME,
            ProcessExit::TYPE_NAME,
        ] {
            let (ty, version) = name.rsplit_once(".v").unwrap();
            assert!(
                ty.starts_with("vbap.") && version.parse::<u32>().is_ok(),
                "{name}"
            );
        }
        assert_eq!(
            RawBodyCommand::from_bytes(&[3u8; std::mem::size_of::<BodyCommand>()]).bytes()[7],
            3
        );
    }
}
