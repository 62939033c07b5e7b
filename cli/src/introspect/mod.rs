//! Looking inside a running mission with iceoryx2: `vbap services MISSION` lists the
//! mission's live nodes and services with their message rates, `vbap echo MISSION SERVICE`
//! prints one service's messages decoded as JSON, and [`write_config`] puts the mission's
//! iceoryx2 configuration (its domain prefix) into the run directory as `iox2.toml`, so that
//! iceoryx2's own `iox2` CLI sees the mission: `iox2 service list --config RUN/iox2.toml`.
//!
//! Both commands add one node (`vbap_tool`) and, per sampled publish-subscribe service, one
//! subscriber to the running mission: a vehicle's state service has room for two besides the
//! coordinator's, so two tools may look at a vehicle at once. They never create a service:
//! only the services listed as existing are opened.

mod decode;
mod echo;
mod join;
mod services;
mod sub;

use std::path::PathBuf;

use anyhow::{Context, Result};
use vbap_ipc::topics::Domain;
use vbap_mission::rundir::RunDir;

pub use echo::{echo, EchoArgs};
pub use join::TOOL_NODE;
pub use services::{services, ServicesArgs};

/// The file of the mission's iceoryx2 configuration in its run directory.
pub const IOX2_CONFIG: &str = "iox2.toml";

/// Writes the iceoryx2 configuration of `domain` (its prefix `vbap_<mission>.` included)
/// to `RUN/iox2.toml`; returns its path.
pub fn write_config(dir: &RunDir, domain: &Domain) -> Result<PathBuf> {
    let path = dir.root.join(IOX2_CONFIG);
    let text = toml::to_string(domain.config()).context("writing the iceoryx2 config as TOML")?;
    let head = format!(
        "# iceoryx2 configuration of mission {:?} (domain prefix {:?}), written by vbap run:\n\
         # iox2 service list --config {}\n",
        domain.mission,
        domain.shm_prefix(),
        path.display()
    );
    std::fs::write(&path, head + &text).with_context(|| format!("writing {}", path.display()))?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_written_config_reads_back_with_the_mission_prefix() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = RunDir {
            root: tmp.path().to_path_buf(),
        };
        let domain = Domain::new("cfgtest").unwrap();
        let path = write_config(&dir, &domain).unwrap();
        use iceoryx2::prelude::SemanticString as _;
        let file = iceoryx2::prelude::FilePath::new(path.to_str().unwrap().as_bytes()).unwrap();
        let back = iceoryx2::config::Config::from_file(&file).unwrap();
        assert_eq!(&back, domain.config());
        assert_eq!(back.global.prefix.to_string(), "vbap_cfgtest.");
    }
}
