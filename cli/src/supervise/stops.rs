//! Agents stopped and continued by a signal (SIGSTOP, SIGTSTP, SIGCONT), seen by their
//! parent: the kernel tells the supervisor (SIGCHLD) and `waitid(WSTOPPED | WCONTINUED)`
//! says which child changed. A stop is a fact, like a death: it is recorded
//! (`supervisor.exits.jsonl`) and reported to the coordinator
//! ([`ProcessExit::STOPPED`], [`ProcessExit::CONTINUED`]), which in lockstep then loses the
//! stopped member at once instead of waiting for a state that will not come.

use std::collections::BTreeSet;

use anyhow::{Context, Result};
use coordinator::exits::{self, Event, ExitRecord};
use nix::sys::wait::{waitid, Id, WaitPidFlag, WaitStatus};
use tokio::signal::unix::{signal, Signal, SignalKind};
use tracing::{info, warn};
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::{wall_ns, Header};

use super::notices::Notice;
use super::set::ProcessSet;

/// What a child's run state did since it was last asked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Change {
    /// Stopped by the signal.
    Stopped(i32),
    /// Runs again.
    Continued,
}

/// The stop or continuation of child `pid` not yet taken (each is told once), without
/// waiting and without reaping an exit (that stays the child's watcher's).
pub fn take_change(pid: u32) -> Option<Change> {
    let pid = nix::unistd::Pid::from_raw(i32::try_from(pid).ok()?);
    let flags = WaitPidFlag::WSTOPPED | WaitPidFlag::WCONTINUED | WaitPidFlag::WNOHANG;
    match waitid(Id::Pid(pid), flags) {
        Ok(WaitStatus::Stopped(_, sig)) => Some(Change::Stopped(sig as i32)),
        Ok(WaitStatus::Continued(_)) => Some(Change::Continued),
        _ => None,
    }
}

/// Watches the agents of the set for stops and continuations.
pub struct StopWatch {
    sigchld: Signal,
    /// Agents seen stopped and not continued (pids).
    stopped: BTreeSet<u32>,
}

impl StopWatch {
    /// Listens for SIGCHLD (sent on a child's stop and continuation as on its death).
    pub fn listen() -> Result<Self> {
        Ok(Self {
            sigchld: signal(SignalKind::child()).context("listening for SIGCHLD")?,
            stopped: BTreeSet::new(),
        })
    }

    /// Resolves at the next SIGCHLD (several may be told as one: [`StopWatch::check`]
    /// asks every agent).
    pub async fn changed(&mut self) {
        if self.sigchld.recv().await.is_none() {
            std::future::pending::<()>().await;
        }
    }

    /// Asks every running agent of `set` whether it stopped or continued; each change is
    /// recorded, then reported to the coordinator.
    pub fn check(&mut self, set: &ProcessSet<'_>) {
        for p in &set.procs {
            let (Some(pid), Some((ProcessExit::AGENT, vehicle))) = (p.pid, p.role.exit_role())
            else {
                continue;
            };
            let Some(change) = take_change(pid) else {
                continue;
            };
            let (event, role, signal) = match change {
                Change::Stopped(sig) => {
                    self.stopped.insert(pid);
                    (Event::Stopped, ProcessExit::STOPPED, sig as u32)
                }
                Change::Continued => {
                    if !self.stopped.remove(&pid) {
                        continue; // a continuation of a stop we never saw
                    }
                    (Event::Continued, ProcessExit::CONTINUED, 0)
                }
            };
            let at_ns = wall_ns();
            info!(process = %p.role.name(), pid, ?change, "agent stopped or continued");
            let rec = ExitRecord {
                event,
                role: ProcessExit::AGENT,
                vehicle,
                pid,
                incarnation: p.generation,
                signal,
                at_ns,
            };
            if let Err(e) = exits::append(&set.dir.root, &rec) {
                warn!(process = %p.role.name(), error = %e, "recording a stop");
            }
            let _ = set.notices.send(Notice::Exit(ProcessExit {
                header: Header::from_sender(Header::SUPERVISOR),
                role,
                vehicle,
                pid,
                signal,
                died_ns: at_ns,
            }));
        }
        self.stopped
            .retain(|pid| set.procs.iter().any(|p| p.pid == Some(*pid)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    /// Waits (at most 10 s) for a SIGCHLD after which `take_change(pid)` tells a change:
    /// another child of this process (other tests run beside this one) may send one too.
    async fn next_change(sigchld: &mut Signal, pid: u32) -> Option<Change> {
        let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(change) = take_change(pid) {
                return Some(change);
            }
            if tokio::time::timeout_at(deadline, sigchld.recv())
                .await
                .is_err()
            {
                return take_change(pid);
            }
        }
    }

    /// The kernel tells the parent of a child's stop and continuation (SIGCHLD), and
    /// `take_change` says which, once each, without reaping the child's exit.
    #[tokio::test]
    async fn a_childs_stop_and_continuation_are_told_once_each_and_its_exit_is_left() {
        let mut sigchld = signal(SignalKind::child()).unwrap();
        let mut child = tokio::process::Command::new("sleep")
            .arg("30")
            .kill_on_drop(true)
            .spawn()
            .expect("spawning sleep");
        let pid = child.id().unwrap();
        assert_eq!(take_change(pid), None);
        let raw = nix::unistd::Pid::from_raw(pid as i32);
        nix::sys::signal::kill(raw, nix::sys::signal::Signal::SIGSTOP).unwrap();
        assert_eq!(
            next_change(&mut sigchld, pid).await,
            Some(Change::Stopped(nix::sys::signal::Signal::SIGSTOP as i32))
        );
        assert_eq!(take_change(pid), None, "told once");
        nix::sys::signal::kill(raw, nix::sys::signal::Signal::SIGCONT).unwrap();
        assert_eq!(
            next_change(&mut sigchld, pid).await,
            Some(Change::Continued)
        );
        nix::sys::signal::kill(raw, nix::sys::signal::Signal::SIGKILL).unwrap();
        let status = tokio::time::timeout(Duration::from_secs(10), child.wait())
            .await
            .expect("the exit was not left to the child's watcher")
            .unwrap();
        assert_eq!(take_change(pid), None, "a death is no stop");
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(status.signal(), Some(9));
    }
}
