//! Where runs go by default: `runs/<label>-<UTC timestamp>`. A leaf: it uses no other
//! module of this crate.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// `runs/<label>-<UTC timestamp>`: the default place of a run (label: the mission name), a
/// batch (`<name>-batch`) or a chaos campaign (`<name>-chaos`).
pub fn default_run_dir(label: &str) -> Result<PathBuf> {
    let now = time::OffsetDateTime::now_utc();
    let stamp = now
        .format(&time::format_description::parse_borrowed::<2>(
            "[year][month][day]T[hour][minute][second]Z",
        )?)
        .context("formatting the timestamp")?;
    Ok(Path::new("runs").join(format!("{label}-{stamp}")))
}
