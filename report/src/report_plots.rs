//! Time-series plots of a run directory.
//!
//! [`write_run_plots`] reads `body.csv`, `events.jsonl` and the resolved `mission.toml`
//! (and, when the run has them, the truth files `formation.csv` and `truth.csv`, through
//! [`crate::truth_plots`]) and writes two figures, each a stack of panels on one time axis
//! in s, min, h or days by the run's length, with the events of `events.jsonl` (vehicle
//! lost, rejoined, formation reconfigured or broken, faults, holding, stalls, near
//! collisions, converged) drawn as coloured dashed vertical lines, and the contact timeline:
//! - `timeseries_formation.svg`: V/V_U (Theorem 4.1; true and as the coordinator sees it
//!   when `truth.csv` is there), the body speed ṡ against v₀, the formation scale k, each
//!   vehicle's distance from its slot and the nearest pair ÷ spacing (truth files only),
//!   the vehicles in the formation (members, alive, truly in formation);
//! - `timeseries_estimate.svg`: the gradient-estimate error ‖∇T_est − ∇T‖ against the true
//!   ‖∇T‖, the trace of the Kalman covariance P, the distance of the body centre to the
//!   optimum against the tolerance (log axes);
//! - `contact.svg` ([`crate::truth_plots::render_contact_svg`]), from `formation.csv` only.
//!
//! Long runs are decimated while streaming (minimum and maximum of each of ~1500 buckets,
//! so spikes survive), so the files stay small whatever the number of ticks. The figures are
//! drawn by [`crate::plot::chart`] (plotters).

mod figures;
mod series;

use crate::plot::chart;
use crate::plot::style::TimeUnit;
pub use crate::plot::style::PALETTE;
use anyhow::{Context, Result};
use vbap_mission::config::Mission;
use vbap_wire::rundir::RunDir;

use crate::truth_plots;
use series::RunSeries;

/// File name of the formation time series.
pub const FORMATION_SVG: &str = "timeseries_formation.svg";
/// File name of the estimator time series.
pub const ESTIMATE_SVG: &str = "timeseries_estimate.svg";
pub use crate::plot::decimate::MAX_POINTS;

/// Writes the time-series plots and the contact timeline of `dir` (from body.csv,
/// events.jsonl, the truth files and `mission`, its resolved mission.toml); nothing when
/// body.csv has no rows.
pub fn write_run_plots(dir: &RunDir, mission: &Mission) -> Result<()> {
    let data = RunSeries::read(dir, mission)?;
    if data.rows == 0 {
        // A run stopped before its first tick: nothing to plot.
        return Ok(());
    }
    let events = crate::plot::read_events(&dir.events())
        .with_context(|| format!("reading {}", dir.events().display()))?;
    let unit = TimeUnit::for_span(data.last_t);
    // The files of the truth metrics (absent in older runs: their panels are left out).
    let t_range = (data.first_t, data.last_t + mission.mission.dt);
    let formation_data = truth_plots::read_formation_or_warn(dir, mission, t_range);
    let truth = truth_plots::read_truth_or_warn(dir, mission);
    let inputs = figures::Inputs {
        mission,
        s: &data,
        events: &events,
        formation: formation_data.as_ref(),
        truth: truth.as_ref(),
    };
    chart::write_svg(
        &figures::formation_figure(&inputs),
        &dir.root.join(FORMATION_SVG),
    )?;
    chart::write_svg(
        &figures::estimate_figure(&inputs),
        &dir.root.join(ESTIMATE_SVG),
    )?;
    let contact = dir.root.join(truth_plots::CONTACT_SVG);
    match formation_data {
        Some(f) => {
            let svg = truth_plots::render_contact_svg(mission, &f, &events, unit)?;
            std::fs::write(&contact, svg)
                .with_context(|| format!("writing {}", contact.display()))?;
        }
        // An older run: no contact states recorded; no stale picture of another run either.
        None => {
            let _ = std::fs::remove_file(&contact);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
