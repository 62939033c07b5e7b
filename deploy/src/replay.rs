//! `vbap replay RUN_DIR`: re-run the planner offline on recorded inputs.

use anyhow::Result;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct ReplayArgs {
    /// The run directory.
    pub run_dir: std::path::PathBuf,
}

/// Runs the command; returns the exit code.
pub fn main(_args: &ReplayArgs) -> Result<i32> {
    anyhow::bail!("not implemented yet")
}
