//! `vbap run`: start the process set, supervise it, collect the run directory.
//!
//! Order of start: field server, coordinator, then the N agents, each awaited until it
//! prints `ready` (its ports exist). Children ask the kernel to die with the supervisor
//! (PR_SET_PDEATHSIG). SIGINT/SIGTERM to the supervisor: SIGTERM to every child, a grace
//! period, SIGKILL for stragglers, then the mission's iceoryx2 resources are cleaned.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::process::Stdio;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use nix::sys::signal::Signal;
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, ChildStdout, Command};
use tokio::sync::{mpsc, oneshot};
use tracing::{info, warn};
use vbap_ipc::msg::coordinator_to_agent::BodyCommand;
use vbap_ipc::msg::supervisor_to_coordinator::ProcessExit;
use vbap_ipc::msg::{wall_ns, Header};
use vbap_ipc::ports;
use vbap_ipc::topics::{Domain, Limits};
use vbap_ipc::wait::Event;
use vbap_mission::config::{Mission, RestartPolicy};
use vbap_mission::rundir::{RunDir, Summary};

use crate::progress::ProgressView;
use vbap_ipc::domain::clean_domain;
use vbap_ipc::process::bin_dir;
use vbap_report::analyze;

/// How often the supervisor reads the body service while the mission runs (to see its
/// final command; a few reads a second cost nothing).
const BODY_READ_EVERY: Duration = Duration::from_millis(20);
/// Grace period between SIGTERM and SIGKILL.
const GRACE: Duration = Duration::from_secs(5);
/// How long a process may take to be reaped after its SIGKILL before the supervisor gives
/// up on it (a process in uninterruptible sleep does not die until it wakes).
const KILL_WAIT: Duration = Duration::from_secs(10);
/// How long a watcher reads what an ended process wrote before it ended.
const OUTPUT_DRAIN: Duration = Duration::from_secs(2);
/// How long a process may take to print `ready`.
const READY_TIMEOUT: Duration = Duration::from_secs(60);

/// What a supervised process is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    FieldServer,
    Coordinator,
    Agent(u32),
    /// The Zenoh bridge of a host of a mission spread over machines ([`HostPlan`]).
    Bridge,
}

impl Role {
    fn name(self) -> String {
        match self {
            Role::FieldServer => "field_server".into(),
            Role::Coordinator => "coordinator".into(),
            Role::Agent(id) => format!("vehicle_agent_{id}"),
            Role::Bridge => "vbap_bridge".into(),
        }
    }
}

/// One supervised process slot (a process and its restarts).
struct Proc {
    role: Role,
    /// pid of the running process; None once it ended.
    pid: Option<u32>,
    /// Generation of the process in this slot (restarts increment it).
    generation: u32,
    /// Wall times of the restarts inside the policy window.
    restarts: VecDeque<Instant>,
}

impl Proc {
    /// The slot of `role`, nothing started yet.
    fn new(role: Role) -> Self {
        Self {
            role,
            pid: None,
            generation: 0,
            restarts: VecDeque::new(),
        }
    }
}

/// A process ended.
struct Exit {
    slot: usize,
    generation: u32,
    status: std::io::Result<std::process::ExitStatus>,
}

/// What the supervisor tells, or asks, the mission over iceoryx2. One thread owns those
/// ports (they are not `Send`), so a process exit is reported the moment the child is
/// reaped, whatever the supervisor's main loop is doing (a restart's backoff, say).
enum Notice {
    /// A child was reaped: tell the coordinator (`<m>/supervisor/exits`) and wake it.
    Exit(ProcessExit),
    /// Has the coordinator published the mission's final command (`FINISHED`)?
    Finished(tokio::sync::oneshot::Sender<bool>),
    /// The run is over: drop the ports and the node.
    Stop,
}

/// The supervisor's iceoryx2 side: a node of the mission's domain, the exit publisher, a
/// notifier of the coordinator's wake service, a subscriber of the body service.
struct Notices {
    tx: std::sync::mpsc::Sender<Notice>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Notices {
    /// Starts the thread (after the domain was cleaned: its node is a live node of the
    /// mission) and returns once its ports exist, before any process of the set starts:
    /// the coordinator's body publisher then connects to the body subscriber when it is
    /// created, so the mission's final command is never missed (a subscriber made later
    /// could come after a fast mission's coordinator is gone, and every agent ending on
    /// FINISHED would look like a process to restart under policy `always`). Without its
    /// ports (an error, logged) the run goes on: the coordinator finds deaths by itself,
    /// only later.
    fn start(domain: &Domain, vehicles: usize) -> Self {
        let (tx, rx) = std::sync::mpsc::channel::<Notice>();
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<()>();
        let domain = domain.clone();
        let thread = std::thread::spawn(move || {
            let ports = (|| -> Result<_> {
                let limits = Limits::for_fleet(vehicles);
                let node = domain.supervisor_node()?;
                // Process exits, each waking the coordinator with `Event::Exit`.
                let exits = ports::Sender::new(
                    ports::publisher(&domain.exits_service(&node, &limits)?)?,
                    ports::notifier(&domain.coordinator_wake(&node, &limits)?, Event::Exit)?,
                    Event::Exit,
                );
                let body = ports::subscriber(&domain.body_service(&node, &limits)?)?;
                Ok((exits, body, node))
            })();
            if let Err(e) = &ports {
                warn!(error = %e, "no process-exit reports to the coordinator");
            }
            let _ = ready_tx.send(());
            let mut finished = false;
            let mut seq = 0;
            // The body subscriber is read while the mission runs (every BODY_READ_EVERY),
            // not only when asked: a subscriber connects to a publisher when it reads, and a
            // coordinator that exits right after its final command would otherwise be gone
            // before the first read, its FINISHED never seen.
            let read_body = |body: &iceoryx2::port::subscriber::Subscriber<
                iceoryx2::prelude::ipc::Service,
                BodyCommand,
                (),
            >,
                             finished: &mut bool| {
                while let Ok(Some(sample)) = body.receive() {
                    let h = sample.header;
                    *finished |=
                        h.sender == Header::COORDINATOR && h.flags & BodyCommand::FINISHED != 0;
                }
            };
            loop {
                let notice = match rx.recv_timeout(BODY_READ_EVERY) {
                    Ok(notice) => notice,
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                        if let Ok((_, body, _)) = &ports {
                            read_body(body, &mut finished);
                        }
                        continue;
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
                };
                match (notice, &ports) {
                    (Notice::Stop, _) => break,
                    (Notice::Exit(mut e), Ok((exits, _, _))) => {
                        seq += 1;
                        e.header = e.header.resent(seq);
                        let _ = exits.publish(e);
                        let _ = exits.notify();
                    }
                    (Notice::Finished(reply), Ok((_, body, _))) => {
                        read_body(body, &mut finished);
                        let _ = reply.send(finished);
                    }
                    (Notice::Finished(reply), Err(_)) => {
                        let _ = reply.send(false);
                    }
                    (Notice::Exit(_), Err(_)) => {}
                }
            }
        });
        // The thread answers as soon as its ports exist (or failed); a thread that died
        // first drops the sender and ends the wait too.
        let _ = ready_rx.recv();
        Self {
            tx,
            thread: Some(thread),
        }
    }

    /// True when the coordinator has published the mission's final command.
    async fn mission_finished(&self) -> bool {
        let (reply, answer) = tokio::sync::oneshot::channel();
        if self.tx.send(Notice::Finished(reply)).is_err() {
            return false;
        }
        answer.await.unwrap_or(false)
    }

    /// Ends the thread (its node leaves the domain).
    fn stop(&mut self) {
        let _ = self.tx.send(Notice::Stop);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The report of the death of process `pid` in `role`, reaped at `died_ns`.
fn exit_report(
    role: Role,
    pid: u32,
    status: &std::io::Result<std::process::ExitStatus>,
    died_ns: u64,
) -> ProcessExit {
    use std::os::unix::process::ExitStatusExt;
    let (role, vehicle) = match role {
        Role::FieldServer => (ProcessExit::FIELD_SERVER, 0),
        Role::Coordinator => (ProcessExit::COORDINATOR, 0),
        Role::Agent(id) => (ProcessExit::AGENT, id),
        Role::Bridge => (u32::MAX, 0), // never reported (see `ProcessSet::watch`)
    };
    ProcessExit {
        header: Header::from_sender(Header::SUPERVISOR),
        role,
        vehicle,
        pid,
        signal: status.as_ref().ok().and_then(|s| s.signal()).unwrap_or(0) as u32,
        died_ns,
    }
}

/// A program the supervisor starts for a role, with the arguments that come first (the
/// role's own arguments follow: `--mission FILE`, `--id I`, `--rejoin`, `--run-dir DIR`,
/// `--log FILE`, `--parent PID`, as the shipped binaries take them).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Executable {
    /// The program.
    pub program: PathBuf,
    /// Its leading arguments (e.g. the role of a program that plays several).
    pub args: Vec<String>,
}

impl Executable {
    /// `program` with no leading arguments.
    pub fn at(program: impl Into<PathBuf>) -> Self {
        Self {
            program: program.into(),
            args: Vec::new(),
        }
    }
}

/// The programs of a process set: which executable plays each role.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Executables {
    /// The field server.
    pub field_server: Executable,
    /// The coordinator.
    pub coordinator: Executable,
    /// Every vehicle agent.
    pub vehicle_agent: Executable,
}

impl Executables {
    /// The shipped binaries, next to this executable ([`bin_dir`]).
    pub fn installed() -> Result<Self> {
        let bin = bin_dir()?;
        Ok(Self {
            field_server: Executable::at(bin.join("field_server")),
            coordinator: Executable::at(bin.join("coordinator")),
            vehicle_agent: Executable::at(bin.join("vehicle_agent")),
        })
    }

    /// This executable in every role, as `THIS role field-server|coordinator|agent ...`
    /// (what [`crate::custom::main`] answers to).
    pub fn this_exe_as_roles() -> Result<Self> {
        let exe = std::env::current_exe().context("locating this executable")?;
        let role = |name: &str| Executable {
            program: exe.clone(),
            args: vec![ROLE_COMMAND.to_string(), name.to_string()],
        };
        Ok(Self {
            field_server: role("field-server"),
            coordinator: role("coordinator"),
            vehicle_agent: role("agent"),
        })
    }
}

/// The first argument of a user's own executable started in a role by its own supervisor
/// ([`Executables::this_exe_as_roles`], `crate::custom`).
pub const ROLE_COMMAND: &str = "role";

/// Sends `sig` to a child that has not been reaped yet (its exit not seen, so its pid is
/// still its own); a pid that is no process any more is ignored.
fn signal(pid: u32, sig: Signal) {
    if let Ok(pid @ 1..) = i32::try_from(pid) {
        let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), sig);
    }
}

async fn spawn(exe: &Executable, name: &str, args: &[String], dir: &RunDir) -> Result<Child> {
    let stderr = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.root.join("logs").join(format!("{name}.stderr.log")))
        .with_context(|| format!("creating the stderr log of {name}"))?;
    Command::new(&exe.program)
        .args(&exe.args)
        .args(args)
        .arg("--log")
        .arg(dir.log(name))
        .arg("--parent")
        .arg(std::process::id().to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::from(stderr))
        .kill_on_drop(true)
        .spawn()
        .with_context(|| format!("starting {}", exe.program.display()))
}

/// A child's standard output, read line by line.
type StdoutLines = tokio::io::Lines<BufReader<tokio::process::ChildStdout>>;

/// Waits until the process whose output is `stdout` prints `ready`; returns the rest of its
/// output.
async fn await_ready(name: &str, stdout: Option<ChildStdout>) -> Result<StdoutLines> {
    let mut lines = BufReader::new(stdout.context("child stdout")?).lines();
    let line = tokio::time::timeout(READY_TIMEOUT, lines.next_line())
        .await
        .with_context(|| format!("{name} did not get ready within {READY_TIMEOUT:?}"))?
        .with_context(|| format!("reading {name}'s stdout"))?;
    match line.as_deref() {
        Some("ready") => Ok(lines),
        other => bail!("{name} exited before it was ready ({other:?}); see its logs"),
    }
}

/// Waits for `child` to end while `output` (the reading of its output) runs; returns its
/// exit status. The child is reaped as it ends, not after its output: a death is never
/// behind a read of a pipe whose write end another process may keep open. What it wrote
/// before it ended is in the pipe, and is read for at most `drain` after.
async fn reap_while_reading(
    child: &mut Child,
    output: impl std::future::Future<Output = ()>,
    drain: Duration,
) -> std::io::Result<std::process::ExitStatus> {
    tokio::pin!(output);
    tokio::select! {
        status = child.wait() => {
            let _ = tokio::time::timeout(drain, &mut output).await;
            status
        }
        () = &mut output => child.wait().await,
    }
}

/// The summary a coordinator hands over on its output (`coordinator::handover`), read
/// until the output ends (the coordinator exits).
async fn read_handover(mut lines: StdoutLines) -> Option<Summary> {
    let mut summary = None;
    while let Ok(Some(line)) = lines.next_line().await {
        match coordinator::handover::parse_summary_line(&line) {
            Some(Ok(s)) => summary = Some(s),
            Some(Err(e)) => warn!(error = %e, "the coordinator's summary does not parse"),
            None => {}
        }
    }
    summary
}

/// The process set of one run.
struct ProcessSet<'a> {
    exes: &'a Executables,
    mission: &'a Mission,
    mission_file: String,
    dir: &'a RunDir,
    procs: Vec<Proc>,
    exits: mpsc::UnboundedSender<Exit>,
    notices: std::sync::mpsc::Sender<Notice>,
    /// The summary the last coordinator handed over when it ended.
    handed: std::sync::Arc<std::sync::Mutex<Option<Summary>>>,
    /// Set when the supervisor stops the set: the processes it stops are not deaths, and
    /// the coordinator (stopping too) is not told of them.
    stopping: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// This host's share of a mission spread over machines (None: the whole set here).
    plan: Option<&'a HostPlan>,
}

/// This host's share of a mission spread over machines (`vbap run --hosts --host`, see
/// `crate::hosts`): a bridge first, then what the hosts file places here.
#[derive(Clone, Debug)]
pub struct HostPlan {
    /// The bridge program and its arguments after `--mission FILE` (`--hosts F --host N`).
    pub bridge: Executable,
    /// The coordinator and the field server run here (the shore).
    pub shore: bool,
    /// The vehicles whose agents run here.
    pub vehicles: Vec<u32>,
    /// The hosts file (copied into the run directory as `hosts.toml`).
    pub file: PathBuf,
    /// How long the shore's bridge may keep the mission's final command for glider hosts
    /// that have not acknowledged it (the hosts file's `final_wait`): the shore's bridge is
    /// given this long past [`GRACE`] to end by itself.
    pub final_wait: Duration,
}

impl<'a> ProcessSet<'a> {
    fn args(&self, role: Role, restart: bool) -> (&'a Executable, Vec<String>) {
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
                args.extend(["--id".to_string(), id.to_string()]);
                if restart {
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
    async fn start_all(&mut self) -> Result<()> {
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

    /// The backoff before the next restart of `slot` (`restart.backoff` doubled per restart
    /// inside the policy window), the restart counted; None past `restart.max_restarts`.
    fn next_restart(&mut self, slot: usize) -> Option<Duration> {
        let r = &self.mission.restart;
        let window = Duration::from_secs_f64(r.window);
        let p = &mut self.procs[slot];
        while p.restarts.front().is_some_and(|t| t.elapsed() > window) {
            p.restarts.pop_front();
        }
        if p.restarts.len() >= r.max_restarts as usize {
            return None;
        }
        let backoff = Duration::from_secs_f64(r.backoff * 2f64.powi(p.restarts.len() as i32));
        p.restarts.push_back(Instant::now());
        Some(backoff)
    }

    /// Starts the process of `slot` (first start or restart) and waits until it is ready.
    async fn start(&mut self, slot: usize) -> Result<()> {
        self.launch(slot).await?.await.context("a watcher ended")?
    }

    /// Spawns the process of `slot` and hands it to its watcher at once; the answer says
    /// whether it got ready. Watched from its spawn, a process is reaped and reported even
    /// when its start is abandoned (Ctrl-C while the set starts), so stopping the set
    /// never waits for a process nobody watches.
    async fn launch(&mut self, slot: usize) -> Result<oneshot::Receiver<Result<()>>> {
        let role = self.procs[slot].role;
        let (exe, args) = self.args(role, self.procs[slot].generation > 0);
        let child = spawn(exe, &role.name(), &args, self.dir).await?;
        self.procs[slot].pid = child.id();
        self.procs[slot].generation += 1;
        Ok(self.watch(slot, child))
    }

    /// Watches `child` (the process of `slot`): tells whether it printed `ready`, reads a
    /// coordinator's further output until it ends (for the summary it hands over; any other
    /// child's output is closed), and reports the child's end on the exit channel.
    fn watch(&self, slot: usize, mut child: Child) -> oneshot::Receiver<Result<()>> {
        let generation = self.procs[slot].generation;
        let role = self.procs[slot].role;
        let exits = self.exits.clone();
        let notices = self.notices.clone();
        let handed = self.handed.clone();
        let stopping = self.stopping.clone();
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
    fn signal_all(&self, sig: Signal) {
        for p in &self.procs {
            if let Some(pid) = p.pid {
                signal(pid, sig);
            }
        }
    }

    fn running(&self) -> usize {
        self.procs.iter().filter(|p| p.pid.is_some()).count()
    }

    fn policy(&self, role: Role) -> RestartPolicy {
        let r = &self.mission.restart;
        match role {
            Role::FieldServer => r.field_server,
            Role::Coordinator => r.coordinator,
            Role::Agent(_) => r.vehicles,
            Role::Bridge => RestartPolicy::OnFailure,
        }
    }
}

/// SIGTERM to every running process, a grace period, then SIGKILL; reaps all (waiting at
/// most [`KILL_WAIT`] after the SIGKILL).
async fn stop_all(set: &mut ProcessSet<'_>, exits: &mut mpsc::UnboundedReceiver<Exit>) {
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
    let roles = match plan {
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
    };
    let mut set = ProcessSet {
        exes,
        mission,
        mission_file: dir.mission().to_string_lossy().to_string(),
        dir,
        procs: roles.into_iter().map(Proc::new).collect(),
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
    let mut restarts_done = 0u32;
    while !interrupted {
        let exit = tokio::select! {
            e = exits.recv() => e,
            _ = shutdown.requested() => { interrupted = true; None }
        };
        let Some(exit) = exit else { break };
        match on_exit(
            &mut set,
            &notices,
            &domain,
            exit,
            &mut restarts_done,
            &mut shutdown,
        )
        .await
        {
            AfterExit::GoOn => {}
            AfterExit::CoordinatorDone => {
                coordinator_ok = true;
                break;
            }
            AfterExit::Stop => break,
            AfterExit::Interrupted => {
                interrupted = true;
                break;
            }
        }
        // A host without the coordinator: its share is done when all its processes are,
        // and done well when the mission's final command reached it.
        if plan.is_some_and(|p| !p.shore) && set.running() == 0 {
            coordinator_ok = notices.mission_finished().await;
            break;
        }
    }
    view.finish();
    if !interrupted {
        // The mission is over: the others end on FINISHED; stragglers get SIGTERM.
        await_the_rest(&mut set, &mut exits).await;
        // The shore's bridge delivers the final command to every glider host, at most
        // `final_wait` (it says so when that runs out); without a final command it has
        // nothing to deliver and is stopped with the rest.
        let wait = plan.filter(|p| p.shore).map(|p| p.final_wait);
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
                    _ = await_for(&mut set, &mut exits, wait) => {}
                    _ = shutdown.requested() => {}
                }
            }
        }
    }
    stop_all(&mut set, &mut exits).await;
    notices.stop();
    let _ = clean_domain(&domain);
    let summary = final_summary(&set, dir, wall, interrupted, plot_field.as_deref())?;
    Ok(RunOutcome {
        summary,
        interrupted,
        coordinator_ok,
        startup_s,
    })
}

/// What supervising does after a process of the set ended.
enum AfterExit {
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
async fn on_exit(
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

/// Waits, at most [`GRACE`], for the processes still running to end by themselves.
async fn await_the_rest(set: &mut ProcessSet<'_>, exits: &mut mpsc::UnboundedReceiver<Exit>) {
    await_for(set, exits, GRACE).await
}

/// Waits, at most `wait`, for the processes still running to end by themselves.
async fn await_for(
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

/// The coordinator's summary (handed over; read back if it had to write it itself),
/// completed with what only the supervisor knows and written once; None without one.
/// `field`: a user's own field, drawn under `plot.svg` (None: the mission's).
fn final_summary(
    set: &ProcessSet<'_>,
    dir: &RunDir,
    wall: Instant,
    interrupted: bool,
    field: Option<&dyn vbap_mission::field::ScalarField>,
) -> Result<Option<Summary>> {
    let handed = set.handed.lock().unwrap_or_else(|e| e.into_inner()).take();
    let mut summary = handed.or_else(|| Summary::read(dir).ok());
    if let Some(s) = summary.as_mut() {
        complete_summary(s, dir, wall.elapsed().as_secs_f64(), interrupted, field)?;
    }
    Ok(summary)
}

/// Completes the coordinator's summary `s` with what the supervisor knows once every
/// process has ended (`wall_s`, the analysis of the message records, the agents'
/// rejections, whether a signal stopped the run), writes `summary.json`, then draws every
/// picture of the run (`field`: a user's own field under `plot.svg`; None: the mission's).
fn complete_summary(
    s: &mut Summary,
    dir: &RunDir,
    wall_s: f64,
    interrupted: bool,
    field: Option<&dyn vbap_mission::field::ScalarField>,
) -> Result<()> {
    s.wall_time_s = wall_s;
    let analysis = analyze::compute(dir).ok();
    if let Some((report, _)) = &analysis {
        report.fill_summary(s);
    }
    s.agent_rejected = count_agent_rejections(dir);
    if interrupted && s.verdict != "interrupted" {
        s.verdict = "interrupted".into();
        s.converged = false;
        s.reasons.insert(
            0,
            "the run was stopped by a signal (Ctrl-C / SIGTERM)".into(),
        );
    }
    s.write(dir).context("writing summary.json")?;
    // Every picture, once, from the written run directory (the analysis already computed).
    let analysis = analysis.as_ref().map(|(r, d)| (r, d));
    if let Err(e) = vbap_report::draw_run_with(dir, analysis, field) {
        warn!(error = %format!("{e:#}"), "drawing the run's pictures failed");
    }
    Ok(())
}

fn policy_is_not_always(p: RestartPolicy) -> bool {
    p != RestartPolicy::Always
}

/// Body commands rejected by the agents, counted from their logs.
fn count_agent_rejections(dir: &RunDir) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir.root.join("logs")) else {
        return 0;
    };
    let mut n = 0;
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if name.starts_with("vehicle_agent") && name.ends_with(".jsonl") {
            if let Ok(text) = std::fs::read_to_string(e.path()) {
                n += text
                    .lines()
                    .filter(|l| l.contains("rejected a body command"))
                    .count() as u64;
            }
        }
    }
    n
}

/// SIGINT and SIGTERM, listened to from [`Shutdown::listen`] for as long as it lives.
///
/// One listener for the whole run, never one per wait: tokio drops a signal that arrives
/// while nobody listens to it (its handler is installed, so the process does not die
/// either), and a Ctrl-C between two waits, or while a restarted process starts, was lost.
pub struct Shutdown {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
    /// A signal came: every later [`Shutdown::requested`] resolves at once.
    seen: bool,
}

impl Shutdown {
    /// Installs the handlers and starts listening (inside a tokio runtime).
    pub fn listen() -> Result<Self> {
        use tokio::signal::unix::{signal, SignalKind};
        Ok(Self {
            term: signal(SignalKind::terminate()).context("installing the SIGTERM handler")?,
            int: signal(SignalKind::interrupt()).context("installing the SIGINT handler")?,
            seen: false,
        })
    }

    /// Resolves once SIGINT or SIGTERM has arrived since [`Shutdown::listen`] (at once when
    /// one already did). Cancel-safe: a signal is never lost to a wait that lost a race.
    pub async fn requested(&mut self) {
        if !self.seen {
            tokio::select! {
                _ = self.term.recv() => {},
                _ = self.int.recv() => {},
            }
            self.seen = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn a_process_is_reaped_as_it_ends_though_another_keeps_its_output_open() {
        // The shell prints its background sleep's pid and exits 3; the sleep keeps the
        // write end of the shell's stdout open for a minute.
        let mut child = Command::new("sh")
            .args(["-c", "sleep 60 & echo $!; exit 3"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .expect("spawning sh");
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let mut printed = Vec::new();
        let output = async {
            while let Ok(Some(line)) = lines.next_line().await {
                printed.push(line);
            }
        };
        let status = tokio::time::timeout(
            Duration::from_secs(30),
            reap_while_reading(&mut child, output, Duration::from_millis(200)),
        )
        .await;
        let holder: Option<i32> = printed.first().and_then(|l| l.trim().parse().ok());
        if let Some(pid) = holder {
            signal(pid as u32, Signal::SIGKILL);
        }
        let status = status
            .expect("the exit waited for the output's end (a minute away)")
            .expect("waiting for sh");
        assert_eq!(status.code(), Some(3));
        // What it wrote before it ended was read.
        assert!(holder.is_some(), "{printed:?}");
    }
}
