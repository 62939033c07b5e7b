//! `vbap-stress`: seeded random-mission stress campaigns (`vbap stress`, docs/STRESS.md).
//!
//! A control law tuned on the shipped missions must hold over a declared SPACE of missions,
//! as property-based tests and fuzzers check properties over a space of inputs:
//!
//! - [`space`]: the declared space ([`Space`]), printed by `vbap stress --space`;
//! - [`draw`]: mission i of campaign seed S, a pure function of (S, i) drawn from keyed
//!   ChaCha8 streams ([`Draw`]), written as a mission file;
//! - [`campaign`]: every draw parsed and validated by the real mission parser (an invalid
//!   draw is redrawn, counted by the validator's key), flown on worker threads by an
//!   injected flyer (the in-process simulator lives in `vbap-cli`), resumable;
//! - [`results`]: what a campaign records (plan, dimensions, each flight's result);
//! - [`judge`]: pass or fail by the truth (`summary.json`, `truth.csv`), naming the criterion;
//! - [`shrink`]: a failure simplified one step at a time while it still fails the same way;
//! - [`table`]: pass rates overall, by law and by each dimension of the space;
//! - [`grid`]: the campaign's small synthetic grid file for `field.kind = "grid"`.
//!
//! Pure of IPC: no inter-process transport, and no process is started here (`.ci/run` checks).

pub mod campaign;
pub mod draw;
pub mod grid;
pub mod judge;
pub mod results;
pub mod shrink;
pub mod space;
pub mod table;

#[cfg(test)]
mod tests;

pub use campaign::{run, BadInput, Config, Flyer, Outcome};
pub use draw::Draw;
pub use judge::{judge, Judgement};
pub use results::FlightResult;
pub use space::Space;
pub use table::Table;
