//! `vbap-report`: pictures and analyses of a run directory, made after it is written.
//!
//! - [`plot`]: the mission plot (`plot.svg`) and the shared style of every picture.
//! - [`report_plots`], [`truth_plots`]: the time-series, timing, contact and formation figures.
//! - [`analyze`]: timing analysis from the message records (`vbap analyze`).

pub mod analyze;
pub mod plot;
pub mod report_plots;
pub mod truth_plots;

/// A run directory that cannot be reported on (missing or malformed files): the user's input,
/// exit code 2 in the `vbap` command.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InvalidRunDir(pub String);
