//! `vbap-ipc`: everything the vbap processes exchange, and how.
//!
//! - [`msg`]: the zero-copy payloads (one `#[repr(C)]` type per service).
//! - [`topics`]: every iceoryx2 service name and limit; [`domain`]: is a mission's domain
//!   free on this host, cleaning what is left of it.
//! - [`ports`], [`wait`]: the ports of a process (publisher + notifier, subscriber +
//!   listener) and the one wait loop, with typed wake-up events.
//! - [`prefix`]: writing a fixed-capacity payload into shared memory, entries in use only.
//! - [`msglog`]: the per-message records, `logs/<process>.msgs.csv` (writer and parser).
//! - [`telemetry`]: the one tracing set-up of every process.
//! - [`process`]: a process's life: start-up, ending with the supervisor, exit codes, a
//!   `vbap run` child.

#[macro_use]
pub mod versioned;
pub mod domain;
pub mod msg;
pub mod msglog;
pub mod ports;
pub mod prefix;
pub mod process;
pub mod telemetry;
pub mod topics;
pub mod wait;
