//! `vbap-ipc`: everything the vbap processes exchange, and how.
//!
//! - [`msg`]: the zero-copy payloads (one `#[repr(C)]` type per service).
//! - [`topics`]: every iceoryx2 service name and limit, and the wait for a wake-up.
//! - [`msglog`]: the per-message records, `logs/<process>.msgs.csv` (writer and parser).
//! - [`telemetry`]: the one tracing set-up of every process.
//! - [`process`]: a process's life: start-up, ending with the supervisor, exit codes.

pub mod msg;
pub mod msglog;
pub mod process;
pub mod telemetry;
pub mod topics;
