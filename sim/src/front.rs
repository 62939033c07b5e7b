//! What every front door of the simulator does before it runs (the `vbap` command line
//! and the Python package alike, so both write the same run directory): the warnings of a
//! valid mission, and the run directory with its resolved `mission.toml`.

use std::path::Path;

use anyhow::{Context, Result};
use vbap_mission::config::Mission;
use vbap_mission::rundir::RunDir;

/// A run directory the user chose that cannot be used (it holds a run already, or cannot
/// be created): the user's input, exit code 2 in the `vbap` command.
#[derive(Debug)]
pub struct RunDirRefused(pub String);

impl std::fmt::Display for RunDirRefused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for RunDirRefused {}

/// The warnings of a valid mission that `check`, `run` and `sim` print: a time step stiff
/// for the formation, a ring that trails its body, a start above `body.v_u`.
pub fn mission_warnings(mission: &Mission) -> Vec<String> {
    [
        mission.stiffness_warning(),
        mission.trail_warning(),
        vehicle_agent::initial_lyapunov_warning(mission),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// Creates the run directory `root` of `mission` (absent: `runs/<mission>-<UTC time>/`)
/// and writes the resolved `mission.toml` into it. A directory that holds a run already
/// is refused ([`RunDirRefused`]), and nothing in it is touched.
pub fn create_run_dir(root: Option<&Path>, mission: &Mission) -> Result<RunDir> {
    let root = match root {
        Some(p) => p.to_path_buf(),
        None => vbap_mission::rundir::default_run_dir(&mission.mission.name)?,
    };
    let dir = RunDir::create(&root)
        .map_err(|e| RunDirRefused(format!("--out {}: {e}", root.display())))?;
    for existing in [dir.vehicles(), dir.body(), dir.summary()] {
        if existing.exists() {
            return Err(RunDirRefused(format!(
                "--out {}: already holds a run ({} exists); choose an empty directory",
                root.display(),
                existing.display()
            ))
            .into());
        }
    }
    std::fs::write(dir.mission(), mission.to_toml_string()).context("writing mission.toml")?;
    Ok(dir)
}
