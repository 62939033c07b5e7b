//! The iceoryx2 domain of a mission on this host: is it free, what of it is left, and
//! cleaning it. A leaf: it uses no other module of this crate.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Result};
use vbap_ipc::topics::Domain;

/// Removes the stale iceoryx2 resources of `domain`: dead nodes, then every file of the
/// domain (its exact prefix `vbap_<mission>.`) left in /dev/shm and under iceoryx2's root
/// folder. Refuses when a live process of the same mission exists.
pub fn clean_domain(domain: &Domain) -> Result<usize> {
    let alive = domain.alive_node_names();
    if !alive.is_empty() {
        bail!(
            "mission {:?} is already running on this host (live processes: {}); choose another mission.name",
            domain.mission,
            alive.join(", ")
        );
    }
    let dead = domain.cleanup_dead_nodes();
    Ok(dead + domain.remove_files())
}

/// Waits (polling every 100 ms, at most `timeout`) until no process of `domain` is alive: the
/// processes of a supervisor that was killed end on their own (they get SIGTERM when it
/// dies). Err names the ones still alive.
pub fn await_domain_free(domain: &Domain, timeout: Duration) -> Result<()> {
    let start = Instant::now();
    loop {
        let alive = domain.alive_node_names();
        if alive.is_empty() {
            return Ok(());
        }
        if start.elapsed() >= timeout {
            bail!(
                "mission {:?} is already running on this host (live processes: {}); choose another mission.name",
                domain.mission,
                alive.join(", ")
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Files of the domain still present (for checks and tests).
pub fn leftover_files(domain: &Domain) -> Vec<PathBuf> {
    domain.files()
}
