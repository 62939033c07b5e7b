//! `vbap`: the front door and supervisor of the vbap process set.
//!
//! - [`sim`]: the in-process reference simulator (`vbap sim`).
//! - [`supervise`]: the multi-process run (`vbap run`), tokio.
//! - [`analyze`]: timing analysis from the message records (`vbap analyze`).
//! - [`progress`]: the progress bar of `vbap run`.
//! - [`replay`], [`batch`], [`bench`], [`report_plots`]: study a run, many runs, the speed.
//! - [`chaos`]: a campaign of real SIGKILLs and SIGSTOPs, judged (`vbap chaos`).
//! - [`truth_plots`]: the contact timeline and the true formation in the run's pictures.
//! - [`report`]: every picture of a run, drawn from its run directory ([`report::draw_run`]).
//! - [`cli`]: the command line.
//! - [`lock`]: one supervisor per mission name on a host.

pub mod analyze;
pub mod batch;
pub mod bench;
pub mod chaos;
pub mod cli;
pub mod lock;
pub mod progress;
pub mod replay;
pub mod report;
pub mod report_plots;
pub mod sim;
pub mod supervise;
pub mod truth_plots;
