//! `vbap`: the front door and supervisor of the vbap process set.
//!
//! - [`sim`]: the in-process reference simulator (`vbap sim`).
//! - [`supervise`]: the multi-process run (`vbap run`), tokio.
//! - [`analyze`]: timing analysis from the message records (`vbap analyze`).
//! - [`progress`]: the progress bar of `vbap run`.
//! - [`replay`], [`batch`], [`bench`], [`report_plots`]: study a run, many runs, the speed.
//! - [`chaos`]: a campaign of real SIGKILLs and SIGSTOPs, judged (`vbap chaos`).
//! - [`truth_plots`]: the contact timeline and the true formation in the run's pictures.
//! - [`cli`]: the command line ([`formation`]: `vbap formation`; [`summary_text`]: the
//!   terminal summary of a run); [`errors`]: the user's errors and the exit codes;
//!   [`rundirs`]: where runs go by default; [`domain`]: a mission's iceoryx2 domain on this
//!   host (free? leftovers, cleaning).
//! - [`lock`]: one supervisor per mission name on a host.

pub mod analyze;
pub mod batch;
pub mod bench;
pub mod chaos;
pub mod cli;
pub mod domain;
pub mod errors;
pub mod formation;
pub mod lock;
pub mod progress;
pub mod replay;
pub mod report_plots;
pub mod rundirs;
pub mod sim;
pub mod summary_text;
pub mod supervise;
pub mod truth_plots;
