//! The process set of one run: its slots (a process and its restarts), starting it in
//! order, watching each process from its spawn, the restart backoff.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use coordinator::exits::{self, Event, ExitRecord};
use nix::sys::signal::Signal;
use tokio::process::Child;
use tokio::sync::{mpsc, oneshot};
use tracing::warn;
use vbap_ipc::msg::wall_ns;
use vbap_mission::config::{Mission, RestartPolicy};
use vbap_mission::rundir::{RunDir, Summary};

use super::child::{await_ready, read_handover, reap_while_reading, signal, spawn};
use super::notices::Notice;
use super::programs::{Executable, Executables, HostPlan};
use super::role::{exit_report, Role};

/// How long a watcher reads what an ended process wrote before it ended.
const OUTPUT_DRAIN: Duration = Duration::from_secs(2);

/// One supervised process slot (a process and its restarts).
pub struct Proc {
    pub role: Role,
    /// pid of the running process; None once it ended.
    pub pid: Option<u32>,
    /// Generation of the process in this slot (restarts increment it).
    pub generation: u32,
    /// Wall times of the restarts inside the policy window.
    pub restarts: VecDeque<Instant>,
}

impl Proc {
    /// The slot of `role`, nothing started yet.
    pub fn new(role: Role) -> Self {
        Self {
            role,
            pid: None,
            generation: 0,
            restarts: VecDeque::new(),
        }
    }
}

/// A process ended.
pub struct Exit {
    pub slot: usize,
    pub generation: u32,
    pub status: std::io::Result<std::process::ExitStatus>,
}

/// The process set of one run.
pub struct ProcessSet<'a> {
    pub exes: &'a Executables,
    pub mission: &'a Mission,
    pub mission_file: String,
    pub dir: &'a RunDir,
    pub procs: Vec<Proc>,
    pub exits: mpsc::UnboundedSender<Exit>,
    pub notices: std::sync::mpsc::Sender<Notice>,
    /// The summary the last coordinator handed over when it ended.
    pub handed: std::sync::Arc<std::sync::Mutex<Option<Summary>>>,
    /// Set when the supervisor stops the set: the processes it stops are not deaths, and
    /// the coordinator (stopping too) is not told of them.
    pub stopping: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// This host's share of a mission spread over machines (None: the whole set here).
    pub plan: Option<&'a HostPlan>,
}

impl<'a> ProcessSet<'a> {
    /// The program of `role` and its arguments for the process of incarnation
    /// `incarnation` in its slot (1: the first; a later agent rejoins).
    pub fn args(&self, role: Role, incarnation: u32) -> (&'a Executable, Vec<String>) {
        let mut args = vec!["--mission".to_string(), self.mission_file.clone()];
        let exe = match role {
            Role::FieldServer => &self.exes.field_server,
            Role::Coordinator => {
                args.extend([
                    "--run-dir".to_string(),
                    self.dir.root.to_string_lossy().to_string(),
                    "--summary-to-parent".to_string(),
                ]);
                &self.exes.coordinator
            }
            Role::Agent(id) => {
                args.extend([
                    "--id".to_string(),
                    id.to_string(),
                    "--incarnation".to_string(),
                    incarnation.to_string(),
                ]);
                if incarnation > 1 {
                    args.push("--rejoin".to_string());
                }
                &self.exes.vehicle_agent
            }
            Role::Bridge => match self.plan {
                Some(plan) => &plan.bridge,
                None => &self.exes.coordinator, // never: a bridge is only in a host's plan
            },
        };
        (exe, args)
    }

    /// Starts the whole set: (bridge,) field server, then coordinator, each ready before the
    /// next; then every agent at once (they start in parallel), each awaited.
    pub async fn start_all(&mut self) -> Result<()> {
        let agent = |r: Role| matches!(r, Role::Agent(_));
        for slot in 0..self.procs.len() {
            if !agent(self.procs[slot].role) {
                self.start(slot).await?;
            }
        }
        let mut launched = Vec::new();
        for slot in 0..self.procs.len() {
            if agent(self.procs[slot].role) {
                launched.push(self.launch(slot).await?);
            }
        }
        let mut first_error = None;
        for ready in launched {
            if let Err(e) = ready.await.context("a watcher ended")? {
                first_error.get_or_insert(e);
            }
        }
        match first_error {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// The backoff before the next restart of `slot` (`RestartSection::backoff_after` of the
    /// restarts inside the policy window), the restart counted; None past
    /// `restart.max_restarts`.
    pub fn next_restart(&mut self, slot: usize) -> Option<Duration> {
        let r = &self.mission.restart;
        let window = Duration::from_secs_f64(r.window);
        let p = &mut self.procs[slot];
        while p.restarts.front().is_some_and(|t| t.elapsed() > window) {
            p.restarts.pop_front();
        }
        if p.restarts.len() >= r.max_restarts as usize {
            return None;
        }
        let backoff = Duration::from_secs_f64(r.backoff_after(p.restarts.len()));
        p.restarts.push_back(Instant::now());
        Some(backoff)
    }

    /// Starts the process of `slot` (first start or restart) and waits until it is ready.
    pub async fn start(&mut self, slot: usize) -> Result<()> {
        self.launch(slot).await?.await.context("a watcher ended")?
    }

    /// Spawns the process of `slot` and hands it to its watcher at once; the answer says
    /// whether it got ready. Watched from its spawn, a process is reaped and reported even
    /// when its start is abandoned (Ctrl-C while the set starts), so stopping the set
    /// never waits for a process nobody watches.
    pub async fn launch(&mut self, slot: usize) -> Result<oneshot::Receiver<Result<()>>> {
        let role = self.procs[slot].role;
        let (exe, args) = self.args(role, self.procs[slot].generation + 1);
        let child = spawn(exe, &role.name(), &args, self.dir).await?;
        self.procs[slot].pid = child.id();
        self.procs[slot].generation += 1;
        let incarnation = self.procs[slot].generation;
        if let (true, Some(pid), Some(kind)) = (incarnation > 1, child.id(), role.exit_role()) {
            let rec = ExitRecord {
                event: Event::Restarted,
                role: kind.0,
                vehicle: kind.1,
                pid,
                incarnation,
                signal: 0,
                at_ns: wall_ns(),
            };
            if let Err(e) = exits::append(&self.dir.root, &rec) {
                warn!(process = %role.name(), error = %e, "recording a restart");
            }
        }
        Ok(self.watch(slot, child))
    }

    /// Watches `child` (the process of `slot`): tells whether it printed `ready`, reads a
    /// coordinator's further output until it ends (for the summary it hands over; any other
    /// child's output is closed), and reports the child's end on the exit channel.
    pub fn watch(&self, slot: usize, mut child: Child) -> oneshot::Receiver<Result<()>> {
        let generation = self.procs[slot].generation;
        let role = self.procs[slot].role;
        let exits = self.exits.clone();
        let notices = self.notices.clone();
        let handed = self.handed.clone();
        let stopping = self.stopping.clone();
        let root = self.dir.root.clone();
        let (ready_tx, ready_rx) = oneshot::channel();
        tokio::spawn(async move {
            let pid = child.id();
            let stdout = child.stdout.take();
            let mut ready_tx = Some(ready_tx);
            let output = async {
                match await_ready(&role.name(), stdout).await {
                    Ok(lines) => {
                        if let Some(tx) = ready_tx.take() {
                            let _ = tx.send(Ok(()));
                        }
                        if role == Role::Coordinator {
                            if let Some(summary) = read_handover(lines).await {
                                *handed.lock().unwrap_or_else(|e| e.into_inner()) = Some(summary);
                            }
                        }
                    }
                    Err(e) => {
                        if let Some(tx) = ready_tx.take() {
                            let _ = tx.send(Err(e));
                        }
                    }
                }
            };
            let status = reap_while_reading(&mut child, output, OUTPUT_DRAIN).await;
            if let Some(tx) = ready_tx.take() {
                let _ = tx.send(Err(anyhow::anyhow!(
                    "{} exited before it was ready; see its logs",
                    role.name()
                )));
            }
            // Told at once: the coordinator acts on a death before any restart of it (not
            // while the supervisor stops everyone: an agent that exits on the stop before
            // the coordinator does would be recorded as lost).
            let stopped = stopping.load(std::sync::atomic::Ordering::SeqCst);
            // (A bridge's end is no process of the coordinator's: not reported.)
            if let (Some(pid), false, false) = (pid, stopped, role == Role::Bridge) {
                let report = exit_report(role, pid, &status, wall_ns());
                // Recorded before anyone acts on it: a coordinator down at this moment
                // learns of it from the record when it resumes.
                let rec = ExitRecord::died(&report, generation);
                if let Err(e) = exits::append(&root, &rec) {
                    warn!(process = %role.name(), error = %e, "recording a death");
                }
                let _ = notices.send(Notice::Exit(report));
            }
            let _ = exits.send(Exit {
                slot,
                generation,
                status,
            });
        });
        ready_rx
    }

    /// Sends `sig` to every running process.
    pub fn signal_all(&self, sig: Signal) {
        for p in &self.procs {
            if let Some(pid) = p.pid {
                signal(pid, sig);
            }
        }
    }

    /// Processes of the set running now.
    pub fn running(&self) -> usize {
        self.procs.iter().filter(|p| p.pid.is_some()).count()
    }

    /// The restart policy of `role`.
    pub fn policy(&self, role: Role) -> RestartPolicy {
        let r = &self.mission.restart;
        match role {
            Role::FieldServer => r.field_server,
            Role::Coordinator => r.coordinator,
            Role::Agent(_) => r.vehicles,
            Role::Bridge => RestartPolicy::OnFailure,
        }
    }
}
