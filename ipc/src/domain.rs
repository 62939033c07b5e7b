//! The iceoryx2 domain of a mission on this host: is it free, and cleaning what is left of
//! it (what is left: [`Domain::files`]). Used by the supervisor and the studies.

use std::time::{Duration, Instant};

use crate::topics::Domain;

/// A start refused because processes of the mission's domain still run (`which`).
#[derive(Debug, thiserror::Error)]
#[error("mission {mission:?} is already running on this host (live processes: {which}); choose another mission.name")]
pub struct AlreadyRunning {
    /// The mission's name.
    pub mission: String,
    /// The live processes, or what still holds the domain.
    pub which: String,
}

/// Removes the stale iceoryx2 resources of `domain`: dead nodes, then every file of the
/// domain (its exact prefix `vbap_<mission>.`) left in /dev/shm and under iceoryx2's root
/// folder. Refuses when a live process of the same mission exists.
pub fn clean_domain(domain: &Domain) -> Result<usize, AlreadyRunning> {
    let alive = domain.alive_node_names();
    if !alive.is_empty() {
        return Err(already_running(domain, &alive.join(", ")));
    }
    let dead = domain.cleanup_dead_nodes();
    Ok(dead + domain.remove_files())
}

/// Waits (polling every 100 ms, at most `timeout`) until no process of `domain` is alive and
/// none holds the domain's members file (the processes of a supervisor that was killed end
/// on their own: they get SIGTERM when it dies, the last of them cleans), then cleans what
/// is left, holding the members file exclusively meanwhile: a member of the earlier run
/// still leaving finds the file locked or replaced and does not clean the new run's
/// files. Err names the processes still alive.
pub fn await_domain_free(domain: &Domain, timeout: Duration) -> Result<(), AlreadyRunning> {
    let start = Instant::now();
    loop {
        let alive = domain.alive_node_names();
        if alive.is_empty() {
            match claim_members(domain) {
                Ok(claim) => {
                    clean_domain(domain)?;
                    drop(claim);
                    return Ok(());
                }
                Err(Busy) if start.elapsed() >= timeout => {
                    return Err(already_running(domain, "members still leaving"))
                }
                Err(Busy) => {}
            }
        } else if start.elapsed() >= timeout {
            return Err(already_running(domain, &alive.join(", ")));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The error of a start refused because processes of `domain` (`which`) still run.
fn already_running(domain: &Domain, which: &str) -> AlreadyRunning {
    AlreadyRunning {
        mission: domain.mission.clone(),
        which: which.to_string(),
    }
}

/// The members file is still locked by a member of an earlier run.
struct Busy;

/// The domain's members file locked exclusively (None: there is none, or it cannot be
/// opened or locked for another reason than a member holding it: nothing to wait for).
fn claim_members(domain: &Domain) -> std::result::Result<Option<std::fs::File>, Busy> {
    let Ok(file) = std::fs::File::open(domain.members_file()) else {
        return Ok(None);
    };
    match file.try_lock() {
        Ok(()) => Ok(Some(file)),
        Err(std::fs::TryLockError::WouldBlock) => Err(Busy),
        Err(std::fs::TryLockError::Error(_)) => Ok(None),
    }
}
