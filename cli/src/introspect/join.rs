//! Joining a running mission: its domain, named by the mission file, and the node a tool
//! adds to it. A leaf: it uses no other module of this crate.

use std::path::Path;

use anyhow::Result;
use vbap_ipc::topics::Domain;
use vbap_mission::config::{KeySet, Mission};

/// Name of the node the tools add to a mission.
pub const TOOL_NODE: &str = "vbap_tool";

/// The mission's domain: the mission file at `path` with `sets` (its name names the domain).
pub fn domain_of(path: &Path, sets: &[KeySet]) -> Result<(Mission, Domain)> {
    let mission = Mission::load_with(path, sets)?;
    let domain = Domain::new(&mission.mission.name)?;
    Ok((mission, domain))
}
