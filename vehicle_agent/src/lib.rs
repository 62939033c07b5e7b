//! The vehicle agent: one process per vehicle (`vehicle_agent --id I`).
//!
//! [`Agent::step`] is the whole decision of a tick and never sees iceoryx2: it computes
//! u_i from (II.1) with the latest virtual leaders and neighbour states the agent has
//! received, and integrates the double integrator ẍ_i = u_i. The in-process simulator
//! calls exactly this function, which is why the multi-process system can reproduce it
//! bit for bit. [`run`] wires the ports.
//!
//! Files by concern: `agent` (the double integrator and its inputs), `start` (what a
//! mission file says a vehicle starts with and flies), `guidance` (what a body command
//! tells one vehicle; `guidance/snapshot` reads it from the payload), `vehicle` (one
//! vehicle with its side of the link, the per-tick logic), `motion` (beyond the ideal
//! vehicle); `run` and `run/` are the process (ports, the wait loop), `cli` its command line.

mod agent;
pub mod cli;
mod guidance;
pub mod motion;
pub mod run;
mod start;
#[cfg(test)]
mod tests;
mod vehicle;

pub use agent::{Agent, AgentInputs};
pub use guidance::{Guidance, Telling, ToldCommand};
pub use start::{
    initial_agent, initial_design, initial_lyapunov, initial_lyapunov_warning, mission_law,
};
pub use vbap_math::law::{ControlInputs, ControlLaw, PaperLaw, RobustLaw};
pub use vehicle::{DownlinkCounts, Reported, Vehicle};
