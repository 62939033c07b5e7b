//! `vbap run MISSION --hosts FILE --host NAME`: this host's share of a mission spread over
//! machines (the hosts file: `vbap_mission::hosts`). Every host runs its own supervisor
//! and its own iceoryx2 domain (each machine has its own /dev/shm), with a bridge
//! (`vbap_bridge`, crate `vbap-bridge`) first; the shore writes the run's files as a
//! one-host run does, the other hosts their processes' logs.

use std::path::{Path, PathBuf};

use anyhow::Result;
use vbap_mission::config::Mission;
use vbap_mission::hosts::Hosts;

use crate::errors::InvalidInput;
use crate::supervise::{Executable, HostPlan};
use vbap_ipc::process::bin_dir;

/// The plan of host `host` of hosts file `file` for `mission` (both flags or neither);
/// errors are the user's (exit 2).
pub fn plan(
    file: Option<&Path>,
    host: Option<&str>,
    mission: &Mission,
) -> Result<Option<HostPlan>> {
    let (file, host) = match (file, host) {
        (None, None) => return Ok(None),
        (Some(f), Some(h)) => (f, h),
        _ => {
            return Err(InvalidInput("--hosts and --host go together".into()).into());
        }
    };
    let hosts = Hosts::load(file, mission.vehicles.count).map_err(InvalidInput)?;
    if mission.acoustic.is_some() {
        return Err(InvalidInput(format!(
            "{}: [acoustic]: acoustic frames are not carried between hosts (the bridge relays \
             the vehicle <-> shore services only): run an acoustic mission on one host",
            mission.origin
        ))
        .into());
    }
    let me = hosts.host(host).map_err(InvalidInput)?;
    if hosts.tls.is_none() {
        eprintln!(
            "vbap: warning: {}: insecure = true: plain tcp/ between hosts, unauthenticated and unencrypted (anyone who reaches a host's port is in the mission); `vbap certs` makes what mutual TLS needs",
            file.display()
        );
    }
    let file: PathBuf = std::fs::canonicalize(file)
        .map_err(|e| InvalidInput(format!("{}: {e}", file.display())))?;
    Ok(Some(HostPlan {
        bridge: Executable {
            program: bin_dir()?.join("vbap_bridge"),
            args: vec![
                "--hosts".into(),
                file.to_string_lossy().into_owned(),
                "--host".into(),
                host.to_string(),
            ],
        },
        shore: hosts.is_shore(host),
        vehicles: me.vehicles.clone(),
        file,
        final_wait: std::time::Duration::from_secs_f64(hosts.final_wait),
    }))
}

/// Records the placement in the run directory `dir` (`hosts.toml`: `vbap analyze` tells
/// the hops that crossed hosts by it).
pub fn record(plan: &HostPlan, dir: &vbap_mission::rundir::RunDir) -> Result<()> {
    std::fs::copy(&plan.file, dir.root.join("hosts.toml")).map_err(|e| {
        anyhow::anyhow!(
            "copying {} into the run directory: {e}",
            plan.file.display()
        )
    })?;
    Ok(())
}
