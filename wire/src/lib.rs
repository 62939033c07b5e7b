//! `vbap-wire`: what the vbap processes exchange and leave behind, apart from any IPC
//! runtime (no iceoryx2 node, port or wait loop here: those are `vbap-ipc`'s).
//!
//! - [`msg`]: the zero-copy payloads (one `#[repr(C)]` type per service), their conversions.
//! - [`versioned`]: the versioned type name of a payload and its raw twin for the bridge.
//! - [`compact`]: the compact link encoding of one vehicle's command and report, sizes known before sending.
//! - [`exit`]: the exit codes of the processes.
//! - [`msglog`]: the per-message records, `logs/<process>.msgs.csv` (writer and parser).
//! - [`rundir`]: the run directory's files (CSV, JSON lines, summary): written by the
//!   coordinator's recorder and `vbap`, read by the reports and the viewer.
//!
//! The payloads derive iceoryx2's `ZeroCopySend` marker from its two dependency-free crates
//! (`iceoryx2-bb-elementary-traits`, `iceoryx2-bb-derive-macros`), so a reader of run
//! directories (`vbap-report`, `vbap-view`) links no iceoryx2 runtime.

#[macro_use]
pub mod versioned;
pub mod compact;
pub mod csv_line;
pub mod exit;
pub mod msg;
pub mod msglog;
pub mod rundir;
