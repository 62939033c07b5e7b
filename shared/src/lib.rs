//! `shared`: everything the vbap processes have in common and nothing that is a process.
//!
//! - [`math`]: the paper's mathematics, pure (no IPC, clock, logging or files).
//! - [`field`]: the sensed environments, with ground truth, and the keyed sensor noise.
//! - [`config`]: the mission file (TOML), parsed and validated; `Mission::field` builds
//!   its environment (in `mission_field.rs`, so `config` does not depend on `field`).
//! - [`faults`], [`link`]: the scheduled faults and the emulated link model.
//! - [`rng`]: random streams keyed by (seed, stream, id, tick).
//! - [`msg`], [`topics`]: zero-copy payloads and every service name and limit.
//! - [`telemetry`]: the one tracing setup of every process.
//! - [`process`]: ending with the supervisor, exit codes.
//! - [`msglog`]: the per-message records, `logs/<process>.msgs.csv` (writer and parser).
//! - [`rundir`]: the run-directory files (CSV, JSON lines, summary).
//! - [`plot`]: the mission plot.

pub mod config;
pub mod faults;
pub mod field;
pub mod link;
pub mod math;
mod mission_field;
pub mod msg;
pub mod msglog;
pub mod plot;
pub mod process;
pub mod rng;
pub mod rundir;
pub mod telemetry;
pub mod topics;
