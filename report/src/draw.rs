//! The pictures of a run, drawn once from its run directory after the run is written:
//! [`draw_run`] is called by `vbap sim` and `vbap run` at their end (and `vbap analyze`
//! draws the analysis plots). It reads only the run directory's files (`mission.toml`,
//! `body.csv`, `vehicles.csv`, `events.jsonl`, the truth files, the message records of
//! `logs/`), never a process, and draws every picture with plotters ([`crate::plot`]):
//!
//! - `plot.svg` ([`crate::mission_plot`]): tracks on the field, the body path, formation snapshots;
//! - `timeseries_formation.svg`, `timeseries_estimate.svg`, `contact.svg`
//!   ([`crate::report_plots`], [`crate::truth_plots`]);
//! - `latency.svg`, `loops.svg` ([`crate::analyze::plots`]) when the run has message records.

use anyhow::{Context, Result};
use vbap_mission::config::Mission;
use vbap_mission::field::ScalarField;
use vbap_wire::rundir::RunDir;

use crate::analyze::{self, Distributions, Report};

/// Draws every picture of the run in `dir`, over the mission's own `[field]`. The analysis
/// plots are drawn when the run has message records (their failure is a warning: they are
/// not the run's result).
pub fn draw_run(dir: &RunDir) -> Result<()> {
    draw_run_with(dir, None, None)
}

/// [`draw_run`] with the analysis of the message records already computed (`vbap run`
/// computes it for `summary.json`; None: computed here when there are records) and the
/// field the run sensed when it was not the mission's `[field]` (a user's own
/// [`ScalarField`], under `plot.svg`; None: the mission's).
pub fn draw_run_with(
    dir: &RunDir,
    analysis: Option<(&Report, &Distributions)>,
    field: Option<&dyn ScalarField>,
) -> Result<()> {
    let mission = Mission::load(&dir.mission())
        .with_context(|| format!("reading {}", dir.mission().display()))?;
    crate::mission_plot::write_mission_plot(dir, &mission, field)?;
    crate::report_plots::write_run_plots(dir, &mission).context("writing the time-series plots")?;
    let computed;
    let analysis = match analysis {
        Some(a) => Some(a),
        None if dir.root.join("logs").is_dir() => match analyze::compute(dir) {
            Ok((r, d)) => {
                computed = (r, d);
                Some((&computed.0, &computed.1))
            }
            Err(e) => {
                tracing::warn!(error = %format!("{e:#}"), "analysing the message records");
                None
            }
        },
        None => None,
    };
    if let Some((report, dists)) = analysis.filter(|(r, _)| r.records > 0) {
        if let Err(e) = analyze::plots::write_plots(dir, report, dists) {
            tracing::warn!(error = %format!("{e:#}"), "writing the analysis plots");
        }
    }
    Ok(())
}
