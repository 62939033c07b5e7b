//! The bench's peer processes and private domains: this executable started again in a
//! helper role ([`Helper`], `ready` on its stdout), fresh mission names, a private iceoryx2
//! domain cleaned after use, the waits that notice a stop request.

use std::fs::OpenOptions;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use vbap_ipc::domain::clean_domain;
use vbap_ipc::topics::Domain;
use vbap_ipc::wait::{Event, Waiter, Wake};

use super::stop::StopFlag;

/// How long a measurement waits for its peer before it gives up.
pub const PEER_TIMEOUT: Duration = Duration::from_secs(10);

/// This executable, as it was when the bench started (a rebuild during the bench replaces
/// the file, and `/proc/self/exe` then names a deleted file).
pub fn exe() -> Result<PathBuf> {
    static EXE: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    if let Some(p) = EXE.get() {
        return Ok(p.clone());
    }
    let p = std::env::current_exe().context("locating the vbap executable")?;
    Ok(EXE.get_or_init(|| p).clone())
}

/// A fresh mission / domain name of this bench: `bench<pid>x<counter>` (letters, digits,
/// ≤ 32 characters).
pub fn unique_name(tag: &str) -> String {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    format!(
        "bench{}{tag}{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::SeqCst)
    )
}

/// A helper process, killed and reaped when dropped.
pub struct Helper {
    child: Child,
    stdout: Option<BufReader<ChildStdout>>,
    name: String,
}

impl Helper {
    pub fn spawn(work: &Path, name: &str, args: &[String]) -> Result<Self> {
        Self::spawn_with(work, name, args, false)
    }

    /// [`Helper::spawn`], at the lowest CPU priority (`nice -n 19`) when `niced`.
    pub fn spawn_with(work: &Path, name: &str, args: &[String], niced: bool) -> Result<Self> {
        let exe = exe()?;
        let mut command = if niced {
            let mut c = Command::new("nice");
            c.arg("-n").arg("19").arg(exe);
            c
        } else {
            Command::new(exe)
        };
        command
            .arg("bench")
            .args(args)
            .arg("--parent")
            .arg(std::process::id().to_string());
        Self::start(work, name, command)
    }

    /// Program `program ARGS` as a helper (another executable of ours: it says `ready`
    /// on its stdout, as the roles do, and ends with its parent).
    pub fn spawn_program(work: &Path, name: &str, program: &Path, args: &[String]) -> Result<Self> {
        let mut command = Command::new(program);
        command.args(args);
        Self::start(work, name, command)
    }

    /// Starts `command` with the helpers' stdio: stdout piped (its `ready` line), stderr
    /// appended to `helpers.stderr.log` in `work`.
    fn start(work: &Path, name: &str, mut command: Command) -> Result<Self> {
        let log = OpenOptions::new()
            .create(true)
            .append(true)
            .open(work.join("helpers.stderr.log"))
            .context("opening helpers.stderr.log")?;
        let mut child = command
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::from(log))
            .spawn()
            .with_context(|| format!("starting helper {name}"))?;
        let stdout = child.stdout.take().map(BufReader::new);
        Ok(Self {
            child,
            stdout,
            name: name.to_string(),
        })
    }

    /// Reads the helper's `ready ...` line; returns what follows `ready`.
    pub fn ready(&mut self) -> Result<String> {
        let mut line = String::new();
        if let Some(out) = self.stdout.as_mut() {
            out.read_line(&mut line)
                .with_context(|| format!("reading helper {}'s stdout", self.name))?;
        }
        match line.trim().strip_prefix("ready") {
            Some(rest) => Ok(rest.trim().to_string()),
            None => bail!(
                "helper {} exited before it was ready (see helpers.stderr.log)",
                self.name
            ),
        }
    }

    /// The helper's next line on stdout (after `ready`), without its newline; empty at
    /// the end of its output.
    pub fn line(&mut self) -> Result<String> {
        let mut line = String::new();
        if let Some(out) = self.stdout.as_mut() {
            out.read_line(&mut line)
                .with_context(|| format!("reading helper {}'s stdout", self.name))?;
        }
        Ok(line.trim_end().to_string())
    }

    /// Waits up to `timeout` for the helper to exit on its own, then kills it.
    pub fn reap(mut self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if !matches!(self.child.try_wait(), Ok(None)) {
                return;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Drop for Helper {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

/// Blocks until the waiter's listener has events, the timeout passes or SIGINT/SIGTERM
/// (then the bench's stop flag is set); calls `on_event` with every event received. A
/// wake-up that finds no event waits again ([`Waiter::wait_for_event`]).
pub fn wait_events(
    waiter: &Waiter<'_>,
    timeout: Duration,
    on_event: impl FnMut(Event),
) -> Result<Wake> {
    let wake = waiter.wait_for_event(timeout, on_event)?;
    if wake == Wake::Stop {
        StopFlag::set();
    }
    Ok(wake)
}

/// [`wait_events`] after polling for up to `spin` (the coordinator's way of waiting:
/// [`vbap_ipc::wait::COORDINATOR_SPIN`]); a wake-up without an event is returned as
/// [`Wake::Events`] for the caller to look and wait again.
pub fn wait_events_spinning(
    waiter: &Waiter<'_>,
    timeout: Duration,
    spin: Duration,
    on_event: impl FnMut(Event),
) -> Result<Wake> {
    let wake = waiter.spin_then_wait(timeout, spin, on_event)?;
    if wake == Wake::Stop {
        StopFlag::set();
    }
    Ok(wake)
}

/// Runs `body` in a fresh private domain, then removes the domain's files (after every
/// node of `body` is dropped and every helper reaped).
pub fn in_private_domain<T>(tag: &str, body: impl FnOnce(&Domain) -> Result<T>) -> Result<T> {
    let domain = Domain::new(&unique_name(tag))?;
    clean_domain(&domain)?;
    let result = body(&domain);
    let cleaned = clean_domain(&domain);
    let value = result?;
    cleaned.context("removing the bench's private iceoryx2 domain")?;
    Ok(value)
}

/// Tells the parent the ports exist: `ready [what]` on stdout, flushed.
pub fn say_ready(what: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "ready {what}");
    let _ = out.flush();
}
