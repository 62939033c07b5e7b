//! The coordinator: gradient estimation, virtual-body motion and formation design.
//!
//! [`planner::Planner::step`] is the whole decision of a tick (least squares + Kalman
//! filter, speed law (IV.4), direction ±∇T_est, resolution adaptation dk/ds, formation
//! redesign when the fleet changes) and never sees iceoryx2. [`record::Recorder`] turns
//! ticks into the run-directory files and the summary, with ground truth the planner
//! never sees. [`tick::plan_tick`] is one tick of both, as the simulator and the
//! coordinator process run it, with any planner of the trait [`plan::Plan`].
//! [`membership`] (losses and rejoins) and [`tally`] (message counts) are the bookkeeping
//! both share. [`run`] wires the ports; [`handover`] passes the summary to `vbap run`; [`exits`] is the
//! supervisor's durable record of deaths and restarts a resumed coordinator reads.

pub mod checkpoint;
pub mod cli;
pub mod command;
pub mod exits;
pub mod fleet;
pub mod handover;
pub mod membership;
pub mod near;
pub mod plan;
pub mod planner;
pub mod record;
pub mod run;
pub mod slots;
pub mod tally;
pub mod tick;
pub mod truth;
