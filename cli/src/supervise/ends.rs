//! The ends of the set's processes while the mission runs, and what each calls for: a
//! restart by its policy (with backoff), or the end of the mission.

use tracing::{info, warn};
use vbap_ipc::topics::Domain;
use vbap_mission::config::RestartPolicy;

use super::notices::Notices;
use super::role::Role;
use super::set::{Exit, ProcessSet};
use super::shutdown::Shutdown;

/// What supervising does after a process of the set ended.
pub enum AfterExit {
    /// Wait for the next end.
    GoOn,
    /// The coordinator ended with success: the mission is over.
    CoordinatorDone,
    /// The mission cannot go on (the coordinator or the field server is gone for good).
    Stop,
    /// SIGINT/SIGTERM during a restart's backoff.
    Interrupted,
}

/// One ended process of the set: a normal end, or restarted by its policy (with backoff,
/// at most `max_restarts` per window; never past the mission's final command), or the end
/// of the mission when the coordinator or the field server cannot be restarted.
pub async fn on_exit(
    set: &mut ProcessSet<'_>,
    notices: &Notices,
    domain: &Domain,
    exit: Exit,
    restarts_done: &mut u32,
    shutdown: &mut Shutdown,
) -> AfterExit {
    let slot = exit.slot;
    if set.procs[slot].generation != exit.generation {
        return AfterExit::GoOn;
    }
    set.procs[slot].pid = None;
    let role = set.procs[slot].role;
    let failed = !exit.status.as_ref().is_ok_and(|s| s.success());
    if role == Role::Coordinator && !failed {
        return AfterExit::CoordinatorDone;
    }
    if !failed && policy_is_not_always(set.policy(role)) {
        return AfterExit::GoOn; // a normal end (the mission finished)
    }
    let policy = set.policy(role);
    let restart = match policy {
        RestartPolicy::Never => false,
        RestartPolicy::OnFailure => failed,
        RestartPolicy::Always => true,
    };
    // Past the mission's final command nothing is restarted: the processes end
    // normally on it (policy `always` would otherwise start them all again).
    if restart && notices.mission_finished().await {
        info!(process = %role.name(), "ended after the mission's final command: not restarted");
        return AfterExit::GoOn;
    }
    warn!(process = %role.name(), status = ?exit.status, ?policy, restart, "process ended");
    let essential = matches!(role, Role::Coordinator | Role::FieldServer | Role::Bridge);
    if !restart {
        // Without the coordinator or the field server the mission cannot go on.
        return if essential {
            AfterExit::Stop
        } else {
            AfterExit::GoOn
        };
    }
    // Restart with backoff, at most max_restarts per window.
    let Some(backoff) = set.next_restart(slot) else {
        warn!(process = %role.name(), "restart limit reached: not restarting");
        return if essential {
            AfterExit::Stop
        } else {
            AfterExit::GoOn
        };
    };
    tokio::select! {
        _ = tokio::time::sleep(backoff) => {}
        _ = shutdown.requested() => { return AfterExit::Interrupted; }
    }
    // Clean the dead node first so the restarted process can take its services.
    domain.cleanup_dead_nodes();
    // Ctrl-C while the restarted process starts: it is watched from its spawn, so the
    // stop that follows ends it too.
    let started = tokio::select! {
        r = set.start(slot) => r,
        _ = shutdown.requested() => { return AfterExit::Interrupted; }
    };
    match started {
        Ok(()) => {
            *restarts_done += 1;
            info!(process = %role.name(), restarts_done = *restarts_done, "restarted");
        }
        Err(e) => warn!(process = %role.name(), error = %e, "restart failed"),
    }
    AfterExit::GoOn
}

fn policy_is_not_always(p: RestartPolicy) -> bool {
    p != RestartPolicy::Always
}
