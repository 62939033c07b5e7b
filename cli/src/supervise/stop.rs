//! Ending the set: waiting for its processes to end by themselves, or SIGTERM, a grace
//! period and SIGKILL.

use std::time::Duration;

use nix::sys::signal::Signal;
use tokio::sync::mpsc;
use tracing::warn;

use super::child::signal;
use super::set::{Exit, ProcessSet};

/// Grace period between SIGTERM and SIGKILL.
pub const GRACE: Duration = Duration::from_secs(5);
/// How long a process may take to be reaped after its SIGKILL before the supervisor gives
/// up on it (a process in uninterruptible sleep does not die until it wakes).
const KILL_WAIT: Duration = Duration::from_secs(10);

/// SIGTERM to every running process, a grace period, then SIGKILL; reaps all (waiting at
/// most [`KILL_WAIT`] after the SIGKILL).
pub async fn stop_all(set: &mut ProcessSet<'_>, exits: &mut mpsc::UnboundedReceiver<Exit>) {
    set.stopping
        .store(true, std::sync::atomic::Ordering::SeqCst);
    set.signal_all(Signal::SIGTERM);
    let deadline = tokio::time::Instant::now() + GRACE;
    while set.running() > 0 {
        match tokio::time::timeout_at(deadline, exits.recv()).await {
            Ok(Some(e)) => {
                if set.procs[e.slot].generation == e.generation {
                    set.procs[e.slot].pid = None;
                }
            }
            Ok(None) => break,
            Err(_) => {
                for p in &set.procs {
                    if let Some(pid) = p.pid {
                        warn!(process = %p.role.name(), "did not stop within the grace period: SIGKILL");
                        signal(pid, Signal::SIGKILL);
                    }
                }
                // Bounded too: a process in uninterruptible sleep outlives its SIGKILL, and
                // the run must still end (and say which process it left).
                let killed = tokio::time::Instant::now() + KILL_WAIT;
                while set.running() > 0 {
                    match tokio::time::timeout_at(killed, exits.recv()).await {
                        Ok(Some(e)) if set.procs[e.slot].generation == e.generation => {
                            set.procs[e.slot].pid = None
                        }
                        Ok(Some(_)) => {}
                        Ok(None) => break,
                        Err(_) => {
                            for p in set.procs.iter().filter(|p| p.pid.is_some()) {
                                warn!(process = %p.role.name(), pid = p.pid, "still not reaped {KILL_WAIT:?} after SIGKILL: left behind");
                            }
                            break;
                        }
                    }
                }
            }
        }
    }
}

/// Waits, at most [`GRACE`], for the processes still running to end by themselves.
pub async fn await_the_rest(set: &mut ProcessSet<'_>, exits: &mut mpsc::UnboundedReceiver<Exit>) {
    await_for(set, exits, GRACE).await
}

/// Waits, at most `wait`, for the processes still running to end by themselves.
pub async fn await_for(
    set: &mut ProcessSet<'_>,
    exits: &mut mpsc::UnboundedReceiver<Exit>,
    wait: Duration,
) {
    let deadline = tokio::time::Instant::now() + wait;
    while set.running() > 0 {
        match tokio::time::timeout_at(deadline, exits.recv()).await {
            Ok(Some(e)) if set.procs[e.slot].generation == e.generation => {
                set.procs[e.slot].pid = None
            }
            Ok(Some(_)) => {}
            _ => break,
        }
    }
}
