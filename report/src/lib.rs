//! `vbap-report`: pictures and analyses of a run directory, made after it is written.
//!
//! One drawing stack (plotters), one style: [`draw_run`] draws every picture of a run from
//! its files, once, at the end of `vbap sim` and `vbap run`.
//!
//! - [`plot`]: the canvas, the panel charts and the shared style (palette, ticks, time
//!   labels), and the mission plot's renderer.
//! - [`mission_plot`]: `plot.svg` from the run directory.
//! - [`report_plots`], [`truth_plots`]: the time series, the contact timeline, the true formation.
//! - [`analyze`]: timing analysis from the message records (`vbap analyze`) and its plots.
//! - [`rows`]: the run directory's CSV files read by column name.
//! - [`export`]: the run as one CF-1.8 trajectory NetCDF file (`vbap export --netcdf`).

pub mod analyze;
mod draw;
pub mod export;
pub mod mission_plot;
pub mod plot;
pub mod report_plots;
pub mod rows;
pub mod truth_plots;

pub use draw::{draw_run, draw_run_with};

/// A run directory that cannot be reported on (missing or malformed files): the user's input,
/// exit code 2 in the `vbap` command.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InvalidRunDir(pub String);
