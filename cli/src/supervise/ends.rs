//! The ends of the set's processes while the mission runs, and what each calls for: a
//! restart by its policy (with backoff), or the end of the mission.

use std::time::{Duration, Instant};

use tracing::{info, warn};
use vbap_ipc::topics::Domain;
use vbap_mission::config::RestartPolicy;

use super::notices::Notices;
use super::role::Role;
use super::set::{Exit, ProcessSet};

/// What supervising does after a process of the set ended.
#[derive(Debug, PartialEq)]
pub enum AfterExit {
    /// Wait for the next end.
    GoOn,
    /// Start the process of `slot` again once `backoff` has passed (scheduled, not
    /// awaited: see [`PendingRestarts`]).
    Restart { slot: usize, backoff: Duration },
    /// The coordinator ended with success: the mission is over.
    CoordinatorDone,
    /// The mission cannot go on (the coordinator or the field server is gone for good).
    Stop,
}

/// What one ended process of the set calls for: nothing (a normal end), a restart by its
/// policy (after a backoff, at most `max_restarts` per window; never past the mission's
/// final command), or the end of the mission when the coordinator or the field server
/// cannot be restarted. Decides only: the restart is the caller's, once its backoff is
/// over, so one process's backoff and start-up never hold another's restart.
pub async fn on_exit(set: &mut ProcessSet<'_>, notices: &Notices, exit: Exit) -> AfterExit {
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
    // Restart with backoff, at most max_restarts per window.
    let backoff = restart.then(|| set.next_restart(slot)).flatten();
    match backoff {
        Some(backoff) => AfterExit::Restart { slot, backoff },
        None => {
            if restart {
                warn!(process = %role.name(), "restart limit reached: not restarting");
            }
            // Without the coordinator or the field server the mission cannot go on.
            if essential {
                AfterExit::Stop
            } else {
                AfterExit::GoOn
            }
        }
    }
}

/// Starts the process of `slot` again (its backoff is over): the dead nodes cleaned first
/// so that it can take its services, then spawned and watched; whether it got ready is
/// logged when it is known, not awaited, so the supervisor goes on acting on other ends
/// meanwhile. Not past the mission's final command.
pub async fn restart(
    set: &mut ProcessSet<'_>,
    notices: &Notices,
    domain: &Domain,
    slot: usize,
    restarts_done: &mut u32,
) {
    let role = set.procs[slot].role;
    if set.procs[slot].pid.is_some() {
        return; // never: a slot is restarted only once its process ended
    }
    if notices.mission_finished().await {
        info!(process = %role.name(), "the mission ended during the restart's backoff: not restarted");
        return;
    }
    domain.cleanup_dead_nodes();
    match set.launch(slot).await {
        Ok(ready) => {
            *restarts_done += 1;
            let done = *restarts_done;
            tokio::spawn(async move {
                match ready.await {
                    Ok(Ok(())) => info!(process = %role.name(), restarts_done = done, "restarted"),
                    Ok(Err(e)) => warn!(process = %role.name(), error = %e, "restart failed"),
                    Err(_) => {}
                }
            });
        }
        Err(e) => warn!(process = %role.name(), error = %e, "restart failed"),
    }
}

/// Restarts waiting for their backoff, each of its own slot: the next one due is started
/// when it is due, whatever the others' backoffs or start-ups are doing. Before, restarts
/// ran one after the other, so an agent killed during a coordinator's restart waited for
/// that restart's backoff and start-up before its own backoff began.
#[derive(Debug, Default)]
pub struct PendingRestarts(Vec<(Instant, usize)>);

impl PendingRestarts {
    /// Starts `slot` again at `due`.
    pub fn schedule(&mut self, slot: usize, due: Instant) {
        self.0.push((due, slot));
    }

    /// When the next restart is due (None: none is waiting).
    pub fn next_due(&self) -> Option<Instant> {
        self.0.iter().map(|(due, _)| *due).min()
    }

    /// The slots due by `now`, earliest first, no longer waiting.
    pub fn take_due(&mut self, now: Instant) -> Vec<usize> {
        let mut due: Vec<(Instant, usize)> = Vec::new();
        self.0.retain(|&(at, slot)| {
            let ready = at <= now;
            if ready {
                due.push((at, slot));
            }
            !ready
        });
        due.sort();
        due.into_iter().map(|(_, slot)| slot).collect()
    }
}

/// Resolves at `due`, never when None.
pub async fn until(due: Option<Instant>) {
    match due {
        Some(at) => tokio::time::sleep_until(tokio::time::Instant::from_std(at)).await,
        None => std::future::pending().await,
    }
}

fn policy_is_not_always(p: RestartPolicy) -> bool {
    p != RestartPolicy::Always
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each slot's restart is due at its own time: a later-scheduled slot with a shorter
    /// backoff is started first, and a long backoff (a coordinator restarted for the third
    /// time in its window) holds no other slot.
    #[test]
    fn restarts_are_started_at_their_own_due_times_not_one_after_another() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        let mut p = PendingRestarts::default();
        assert_eq!(p.next_due(), None);
        assert!(p.take_due(t0 + ms(10_000)).is_empty());
        p.schedule(1, t0 + ms(800)); // the coordinator, third restart: 0.8 s
        p.schedule(4, t0 + ms(230)); // an agent killed 30 ms later: 0.2 s
        p.schedule(0, t0 + ms(200)); // the field server, 0.2 s
        assert_eq!(p.next_due(), Some(t0 + ms(200)));
        assert!(p.take_due(t0 + ms(199)).is_empty());
        assert_eq!(p.take_due(t0 + ms(230)), vec![0, 4]);
        assert_eq!(p.next_due(), Some(t0 + ms(800)));
        assert_eq!(p.take_due(t0 + ms(500)), Vec::<usize>::new());
        assert_eq!(p.take_due(t0 + ms(800)), vec![1]);
        assert_eq!(p.next_due(), None);
    }
}
