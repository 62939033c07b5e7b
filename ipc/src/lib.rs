//! `vbap-ipc`: how the vbap processes exchange what `vbap-wire` defines.
//!
//! - [`msg`], [`versioned`], [`msglog`], [`compact`]: the payloads, their versioned names, the
//!   compact link encoding and the
//!   message records, re-exported from `vbap-wire` (where they live, free of iceoryx2's
//!   runtime, for the readers of run directories).
//! - [`topics`]: every iceoryx2 service name and limit; [`domain`]: is a mission's domain
//!   free on this host, cleaning what is left of it.
//! - [`ports`], [`wait`]: the ports of a process (publisher + notifier, subscriber +
//!   listener) and the one wait loop, with typed wake-up events.
//! - [`prefix`]: writing a fixed-capacity payload into shared memory, entries in use only.
//! - [`telemetry`]: the one tracing set-up of every process.
//! - [`process`]: a process's life: start-up, ending with the supervisor, exit codes, a
//!   `vbap run` child.

pub use vbap_wire::{compact, msg, msglog, versioned};
pub mod domain;
pub mod ports;
pub mod prefix;
pub mod process;
pub mod telemetry;
pub mod topics;
pub mod wait;
