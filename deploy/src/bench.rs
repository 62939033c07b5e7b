//! `vbap bench`: benchmarks with ratios against baselines measured in the same run.

use anyhow::Result;

/// Arguments.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Quick run (fewer samples).
    #[arg(long)]
    pub quick: bool,
}

/// Runs the command; returns the exit code.
pub fn main(_args: &BenchArgs) -> Result<i32> {
    anyhow::bail!("not implemented yet")
}
