//! `vbap batch MISSION --seeds K`: many seeds, a table and an aggregate.

use anyhow::Result;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct BatchArgs {
    /// The mission file.
    pub mission: std::path::PathBuf,
}

/// Runs the command; returns the exit code.
pub fn main(_args: &BatchArgs) -> Result<i32> {
    anyhow::bail!("not implemented yet")
}
