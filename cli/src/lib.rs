//! `vbap-cli`: the `vbap` command, front door and supervisor of the vbap process set.
//!
//! - [`supervise`]: the multi-process run (`vbap run`), tokio.
//! - [`progress`]: the progress bar of `vbap run`.
//! - [`replay`]: study a run; [`compare`]: are two run directories the same run?
//! - `vbap sim`, `batch`, `bench`, `chaos`: the crates `vbap-sim`, `vbap-batch`,
//!   `vbap-bench`, `vbap-chaos` (their arguments are theirs; [`cli`] dispatches to them).
//! - [`stress`]: a seeded random-mission stress campaign (`vbap stress`, crate `vbap-stress`).
//! - [`custom`]: a user's own vbap, over its own field and control law (`vbap_sim::Plugins`).
//! - [`cli`]: the command line ([`formation`]: `vbap formation`; [`summary_text`]: the
//!   terminal summary of a run); [`errors`]: the user's errors and the exit codes.
//! - [`ocean`]: `vbap ocean`, the synthetic ocean example file of grid missions.
//! - [`lock`]: one supervisor per mission name on a host.
//! - [`introspect`]: `vbap services` and `vbap echo`, a look inside a running mission.
//! - [`hosts`]: `vbap run --hosts FILE --host NAME`, one host's share of a mission
//!   spread over machines (with `vbap_bridge`); [`certs`]: `vbap certs`, the mission's CA
//!   and its hosts' certificates for mutual TLS between them.
//!
//! Pictures and timing analyses are `vbap-report`'s; the steps of the processes are the
//! libraries of `coordinator`, `vehicle_agent` and `field_server`.

pub mod certs;
pub mod cli;
pub mod compare;
pub mod custom;
pub mod errors;
pub mod formation;
pub mod hosts;
pub mod introspect;
pub mod lock;
pub mod ocean;
pub mod progress;
pub mod replay;
pub mod stress;
pub mod summary_text;
pub mod supervise;
