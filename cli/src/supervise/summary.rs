//! The run's summary, once every process has ended: the coordinator's, completed with what
//! only the supervisor knows, written once; then every picture.

use std::time::Instant;

use anyhow::{Context, Result};
use tracing::warn;
use vbap_mission::rundir::{RunDir, Summary};
use vbap_report::analyze;

use super::set::ProcessSet;

/// The coordinator's summary (handed over; read back if it had to write it itself),
/// completed with what only the supervisor knows and written once; None without one.
/// `field`: a user's own field, drawn under `plot.svg` (None: the mission's).
pub fn final_summary(
    set: &ProcessSet<'_>,
    dir: &RunDir,
    wall: Instant,
    interrupted: bool,
    field: Option<&dyn vbap_mission::field::ScalarField>,
) -> Result<Option<Summary>> {
    let handed = set.handed.lock().unwrap_or_else(|e| e.into_inner()).take();
    let mut summary = handed.or_else(|| Summary::read(dir).ok());
    if let Some(s) = summary.as_mut() {
        complete_summary(s, dir, wall.elapsed().as_secs_f64(), interrupted, field)?;
    }
    Ok(summary)
}

/// Completes the coordinator's summary `s` with what the supervisor knows once every
/// process has ended (`wall_s`, the analysis of the message records, the agents'
/// rejections, whether a signal stopped the run), writes `summary.json`, then draws every
/// picture of the run (`field`: a user's own field under `plot.svg`; None: the mission's).
fn complete_summary(
    s: &mut Summary,
    dir: &RunDir,
    wall_s: f64,
    interrupted: bool,
    field: Option<&dyn vbap_mission::field::ScalarField>,
) -> Result<()> {
    s.wall_time_s = wall_s;
    let analysis = analyze::compute(dir).ok();
    if let Some((report, _)) = &analysis {
        report.fill_summary(s);
    }
    s.agent_rejected = count_agent_rejections(dir);
    if interrupted && s.verdict != "interrupted" {
        s.verdict = "interrupted".into();
        s.converged = false;
        s.reasons.insert(
            0,
            "the run was stopped by a signal (Ctrl-C / SIGTERM)".into(),
        );
    }
    s.write(dir).context("writing summary.json")?;
    // Every picture, once, from the written run directory (the analysis already computed).
    let analysis = analysis.as_ref().map(|(r, d)| (r, d));
    if let Err(e) = vbap_report::draw_run_with(dir, analysis, field) {
        warn!(error = %format!("{e:#}"), "drawing the run's pictures failed");
    }
    Ok(())
}

/// Body commands rejected by the agents, counted from their logs.
fn count_agent_rejections(dir: &RunDir) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir.root.join("logs")) else {
        return 0;
    };
    let mut n = 0;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if name.starts_with("vehicle_agent") && name.ends_with(".jsonl") {
            if let Ok(text) = std::fs::read_to_string(e.path()) {
                n += text
                    .lines()
                    .filter(|l| l.contains("rejected a body command"))
                    .count() as u64;
            }
        }
    }
    n
}
