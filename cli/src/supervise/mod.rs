//! `vbap run`: start the process set, supervise it, collect the run directory.
//!
//! Order of start: field server, coordinator, then the N agents, each awaited until it
//! prints `ready` (its ports exist). Children ask the kernel to die with the supervisor
//! (PR_SET_PDEATHSIG). SIGINT/SIGTERM to the supervisor: SIGTERM to every child, a grace
//! period, SIGKILL for stragglers, then the mission's iceoryx2 resources are cleaned.

//!
//! The parts: [`programs`] (what is started for each role), [`set`] (the process set, its
//! start and its slots), [`child`] (one child: spawn, ready, reap), [`notices`] (the
//! iceoryx2 side: exits to the coordinator, the final command), [`ends`] (a process ended:
//! restart or not), [`stops`] (agents stopped and continued by a signal), [`stop`] (ending
//! the set), [`summary`] (the run's summary and pictures), [`shutdown`] (SIGINT/SIGTERM),
//! [`role`] (what a process is).

mod child;
mod ends;
mod notices;
mod programs;
mod role;
mod set;
mod shutdown;
mod stop;
mod stops;
mod summary;

use std::time::{Duration, Instant};

use anyhow::Result;
use tokio::sync::mpsc;
use tracing::info;
use vbap_ipc::domain::clean_domain;
use vbap_ipc::topics::Domain;
use vbap_mission::config::Mission;
use vbap_mission::rundir::{RunDir, Summary};

use crate::progress::ProgressView;
use ends::{on_exit, restart, until, AfterExit, PendingRestarts};
use notices::Notices;
pub use programs::{Executable, Executables, HostPlan, ROLE_COMMAND};
use role::Role;
use set::{Exit, Proc, ProcessSet};
pub use shutdown::Shutdown;
use stop::{await_for, await_the_rest, stop_all};
use stops::StopWatch;

/// How a supervised run ended.
#[derive(Debug)]
pub struct RunOutcome {
    /// The summary, when a coordinator handed one over (or wrote one).
    pub summary: Option<Summary>,
    /// True when a signal stopped the run.
    pub interrupted: bool,
    /// True when the coordinator exited with success.
    pub coordinator_ok: bool,
    /// Wall time from first spawn to every process ready, s.
    pub startup_s: f64,
}

/// Runs `mission` as a process set writing `dir`.
pub async fn run(mission: &Mission, dir: &RunDir, show_progress: bool) -> Result<RunOutcome> {
    let exes = Executables::installed()?;
    run_with(mission, dir, show_progress, &exes, None).await
}

/// [`run`] with the roles played by `exes` (e.g. a user's own agent and field server,
/// [`Executables::this_exe_as_roles`]); `field`: the field the progress display measures
/// the distance to the optimum in (None: the mission's).
pub async fn run_with(
    mission: &Mission,
    dir: &RunDir,
    show_progress: bool,
    exes: &Executables,
    field: Option<std::sync::Arc<dyn vbap_mission::field::ScalarField>>,
) -> Result<RunOutcome> {
    run_share(mission, dir, show_progress, exes, field, None).await
}

/// [`run_with`] of this host's share `plan` of a mission spread over machines (None: the
/// whole process set). A host without the coordinator ends once all its processes have.
pub async fn run_share(
    mission: &Mission,
    dir: &RunDir,
    show_progress: bool,
    exes: &Executables,
    field: Option<std::sync::Arc<dyn vbap_mission::field::ScalarField>>,
    plan: Option<&HostPlan>,
) -> Result<RunOutcome> {
    let wall = Instant::now();
    let mut shutdown = Shutdown::listen()?;
    let domain = Domain::new(&mission.mission.name)?;
    let cleaned = clean_domain(&domain)?;
    if cleaned > 0 {
        info!(
            cleaned,
            "removed stale resources of an earlier run of this mission"
        );
    }
    let (tx, mut exits) = mpsc::unbounded_channel();
    let mut notices = Notices::start(&domain, mission.vehicles.count);
    let mut set = ProcessSet {
        exes,
        mission,
        mission_file: dir.mission().to_string_lossy().to_string(),
        dir,
        procs: roles_of(mission, plan).into_iter().map(Proc::new).collect(),
        exits: tx,
        notices: notices.tx.clone(),
        handed: Default::default(),
        stopping: Default::default(),
        plan,
    };
    let mut interrupted = false;
    let started = tokio::select! {
        r = set.start_all() => r,
        _ = shutdown.requested() => { interrupted = true; Ok(()) }
    };
    let startup_s = wall.elapsed().as_secs_f64();
    if let Err(e) = started {
        stop_all(&mut set, &mut exits).await;
        notices.stop();
        let _ = clean_domain(&domain);
        return Err(e);
    }
    info!(startup_s, processes = set.procs.len(), "process set up");

    let plot_field = field.clone(); // a user's own field, for plot.svg
    let field = field.unwrap_or_else(|| std::sync::Arc::new(mission.field()));
    let mut view = ProgressView::start(mission, field, show_progress && !interrupted);
    let mut coordinator_ok = false;
    if !interrupted {
        let ends = Ends {
            notices: &notices,
            domain: &domain,
            plan,
        };
        (coordinator_ok, interrupted) = ends.supervise(&mut set, &mut exits, &mut shutdown).await;
    }
    view.finish();
    if !interrupted {
        wind_down(&mut set, &notices, &mut exits, &mut shutdown, plan).await;
    }
    stop_all(&mut set, &mut exits).await;
    notices.stop();
    let _ = clean_domain(&domain);
    let summary = summary::final_summary(&set, dir, wall, interrupted, plot_field.as_deref())?;
    Ok(RunOutcome {
        summary,
        interrupted,
        coordinator_ok,
        startup_s,
    })
}

/// The roles of the process set: the whole set, or this host's share `plan` (its bridge
/// first).
fn roles_of(mission: &Mission, plan: Option<&HostPlan>) -> Vec<Role> {
    match plan {
        None => {
            let mut roles = vec![Role::FieldServer, Role::Coordinator];
            roles.extend((0..mission.vehicles.count as u32).map(Role::Agent));
            roles
        }
        Some(p) => {
            let mut roles = vec![Role::Bridge];
            if p.shore {
                roles.extend([Role::FieldServer, Role::Coordinator]);
            }
            roles.extend(p.vehicles.iter().copied().map(Role::Agent));
            roles
        }
    }
}

/// What watching the set's ends needs besides the set.
struct Ends<'a> {
    notices: &'a Notices,
    domain: &'a Domain,
    plan: Option<&'a HostPlan>,
}

impl Ends<'_> {
    /// Watches the set until the mission is over, acting on every process that ends
    /// ([`on_exit`]) and starting each restart when its own backoff is over
    /// ([`PendingRestarts`]); returns (the coordinator ended with success, a signal
    /// stopped the run).
    async fn supervise(
        &self,
        set: &mut ProcessSet<'_>,
        exits: &mut mpsc::UnboundedReceiver<Exit>,
        shutdown: &mut Shutdown,
    ) -> (bool, bool) {
        let mut restarts_done = 0u32;
        let mut pending = PendingRestarts::default();
        let mut stops = StopWatch::listen().ok();
        loop {
            let exit = tokio::select! {
                e = exits.recv() => e,
                () = async { match stops.as_mut() {
                    Some(s) => s.changed().await,
                    None => std::future::pending().await,
                } } => {
                    if let Some(s) = stops.as_mut() {
                        s.check(set);
                    }
                    continue;
                }
                _ = until(pending.next_due()) => {
                    for slot in pending.take_due(Instant::now()) {
                        restart(set, self.notices, self.domain, slot, &mut restarts_done).await;
                    }
                    continue;
                }
                _ = shutdown.requested() => return (false, true),
            };
            let Some(exit) = exit else {
                return (false, false);
            };
            match on_exit(set, self.notices, exit).await {
                AfterExit::GoOn => {}
                AfterExit::Restart { slot, backoff } => {
                    pending.schedule(slot, Instant::now() + backoff)
                }
                AfterExit::CoordinatorDone => return (true, false),
                AfterExit::Stop => return (false, false),
            }
            // A host without the coordinator: its share is done when all its processes
            // are, and done well when the mission's final command reached it.
            if self.plan.is_some_and(|p| !p.shore)
                && pending.next_due().is_none()
                && set.running() == 0
            {
                return (self.notices.mission_finished().await, false);
            }
        }
    }
}

/// The mission is over: the others end on FINISHED (stragglers get SIGTERM after). The
/// shore's bridge delivers the final command to every glider host, at most `final_wait`
/// (it says so when that runs out); without a final command it has nothing to deliver and
/// is stopped with the rest.
async fn wind_down(
    set: &mut ProcessSet<'_>,
    notices: &Notices,
    exits: &mut mpsc::UnboundedReceiver<Exit>,
    shutdown: &mut Shutdown,
    plan: Option<&HostPlan>,
) {
    await_the_rest(set, exits).await;
    let wait: Option<Duration> = plan.filter(|p| p.shore).map(|p| p.final_wait);
    if let (Some(wait), true) = (wait, notices.mission_finished().await) {
        let bridge_only = set
            .procs
            .iter()
            .all(|p| p.pid.is_none() || p.role == Role::Bridge);
        if set.running() > 0 && bridge_only {
            info!(
                final_wait_s = wait.as_secs_f64(),
                "waiting for the bridge to deliver the final command to every host"
            );
            tokio::select! {
                _ = await_for(set, exits, wait) => {}
                _ = shutdown.requested() => {}
            }
        }
    }
}
