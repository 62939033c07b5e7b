//! One supervisor per mission name on a host: an exclusive `flock(2)` on
//! `<lock dir>/<mission>.lock`, held for the supervisor's life.
//!
//! The kernel releases the lock when the holder dies, however it dies (a SIGKILLed
//! supervisor blocks no later start). The file holds the holder's pid, for the message of a
//! refused start. A clean exit removes the file while still holding the lock; a start that
//! locked a file already removed (or replaced) sees its inode is no longer the path's and
//! tries again, so two starts never both hold "the" lock. The lock directory is
//! `$VBAP_LOCK_DIR`, else `/tmp/vbap-locks` (mode 1777, shared by the users of the host, as
//! /tmp is).

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};

/// Environment variable naming another lock directory (tests, sandboxes).
pub const LOCK_DIR_ENV: &str = "VBAP_LOCK_DIR";

/// The directory of the mission locks.
pub fn lock_dir() -> PathBuf {
    std::env::var_os(LOCK_DIR_ENV)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/tmp/vbap-locks"))
}

/// Why a mission could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another live supervisor holds it.
    #[error("mission {mission:?} is already running ({holder}); wait for it to end or choose another mission.name")]
    Busy {
        /// The mission name.
        mission: String,
        /// `pid N` of the holder, as it wrote it, or `pid unknown`.
        holder: String,
    },
    /// The lock file could not be created or locked.
    #[error("locking mission {mission:?} ({path}): {source}")]
    Io {
        mission: String,
        path: String,
        #[source]
        source: std::io::Error,
    },
}

/// The lock of one mission; released (and its file removed) on drop.
#[derive(Debug)]
pub struct MissionLock {
    file: File,
    path: PathBuf,
}

impl MissionLock {
    /// Takes the lock of `mission` (a validated mission name) without waiting.
    pub fn acquire(mission: &str) -> Result<MissionLock, LockError> {
        Self::acquire_in(&lock_dir(), mission)
    }

    /// [`MissionLock::acquire`] in directory `dir`.
    pub fn acquire_in(dir: &Path, mission: &str) -> Result<MissionLock, LockError> {
        let path = dir.join(format!("{mission}.lock"));
        let io = |source| LockError::Io {
            mission: mission.to_string(),
            path: path.display().to_string(),
            source,
        };
        if !dir.exists() {
            std::fs::create_dir_all(dir).map_err(io)?;
            // Shared like /tmp: any user may add a lock, only its owner remove it.
            let _ = std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o1777));
        }
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            // std's file lock is flock(2) (LOCK_EX | LOCK_NB) on Linux.
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let mut text = String::new();
                    let _ = file.read_to_string(&mut text);
                    let holder = match text.trim().parse::<u32>() {
                        Ok(pid) => format!("pid {pid}"),
                        Err(_) => "pid unknown".to_string(),
                    };
                    return Err(LockError::Busy {
                        mission: mission.to_string(),
                        holder,
                    });
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(io(e)),
            }
            // Locked; but the holder before us may have removed the file in between: only
            // the file still at `path` counts.
            let same = match (file.metadata(), std::fs::metadata(&path)) {
                (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
                _ => false,
            };
            if !same {
                continue;
            }
            file.set_len(0).map_err(io)?;
            writeln!(file, "{}", std::process::id()).map_err(io)?;
            return Ok(MissionLock { file, path });
        }
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for MissionLock {
    fn drop(&mut self) {
        // Removed while still locked; the descriptor's close then releases the lock.
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_holder_at_a_time_and_released_on_drop() {
        let tmp = tempfile::tempdir().unwrap();
        // Not there yet: acquire creates it.
        let dir = tmp.path().join("locks");
        let a = MissionLock::acquire_in(&dir, "m").unwrap();
        assert_eq!(
            std::fs::read_to_string(a.path()).unwrap().trim(),
            std::process::id().to_string()
        );
        // flock locks belong to the open file description: a second open in this process
        // is refused like another process would be.
        let err = MissionLock::acquire_in(&dir, "m").unwrap_err();
        assert!(matches!(err, LockError::Busy { .. }), "{err}");
        assert_eq!(
            err.to_string(),
            format!(
                "mission \"m\" is already running (pid {}); wait for it to end or choose another mission.name",
                std::process::id()
            )
        );
        // Another name is another lock, even a longer one with the same beginning.
        let other = MissionLock::acquire_in(&dir, "m_2").unwrap();
        drop(a);
        assert!(!dir.join("m.lock").exists());
        let again = MissionLock::acquire_in(&dir, "m").unwrap();
        drop(again);
        drop(other);
    }
}
