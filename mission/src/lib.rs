//! `vbap-mission`: what a mission is, apart from any process.
//!
//! - [`config`]: the mission file (TOML), parsed and validated; `Mission::field` builds
//!   its environment (in `mission_field.rs`, so `config` does not depend on `field`).
//! - [`field`]: the sensed environments, with ground truth, and the keyed sensor noise.
//! - [`link`], [`faults`]: the emulated glider link and the scheduled faults.
//! - [`grid`]: gridded fields from files (read by `vbap-formats`: NetCDF, NumPy), interpolated.
//! - [`horizon`]: the plan horizon of the robust law, from the link model.
//! - [`current`], [`land`]: the water that carries the vehicles and the land they keep
//!   out of (beyond the paper).
//! - [`hosts`]: the hosts file of a mission spread over machines.
//! - [`rundir`]: the run directory a mission writes (CSV, JSON lines, summary), defined in
//!   `vbap-wire` (its writers and readers meet there) and re-exported here for its many users.

pub mod acoustic;
pub mod config;
pub mod current;
pub mod faults;
pub mod field;
pub mod grid;
pub mod horizon;
pub mod hosts;
pub mod land;
pub mod link;
pub mod loaded;
mod mission_field;
pub use vbap_wire::rundir;
