//! Process plumbing shared by the binaries: ending with the supervisor (or making a child
//! end with us, a `vbap run` child), signals, exit codes and the user's error that exits 2,
//! the folder of the binaries.

use nix::sys::signal::Signal;

pub use vbap_wire::exit::{EXIT_FAILURE, EXIT_INVALID, EXIT_OK};

/// An error that is the user's input (a bad argument or mission file, named in the
/// message): exit [`EXIT_INVALID`].
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct InvalidInput(pub String);

/// Prints `PASS`, or a `FAIL: …` line per failure, on stderr; returns the exit code
/// ([`EXIT_OK`] or [`EXIT_FAILURE`]): how a study (`vbap batch`, `vbap chaos`) closes.
pub fn pass_or_fail(passed: bool, failures: &[String]) -> i32 {
    if passed {
        eprintln!("PASS");
        EXIT_OK
    } else {
        for f in failures {
            eprintln!("FAIL: {f}");
        }
        EXIT_FAILURE
    }
}

/// The directory of the vbap binaries (the one holding this executable).
pub fn bin_dir() -> std::io::Result<std::path::PathBuf> {
    let exe = std::env::current_exe()
        .map_err(|e| std::io::Error::new(e.kind(), format!("locating the vbap executable: {e}")))?;
    exe.parent()
        .map(std::path::Path::to_path_buf)
        .ok_or_else(|| std::io::Error::other("vbap executable has no parent directory"))
}

/// `exe run FILE --out RUN_DIR --quiet`, stdin closed, stdout and stderr into
/// `RUN_DIR/vbap.log` (created here), stopped with its parent ([`stop_with_parent`]): the
/// `vbap run` child of a study. Returns the command and the log's path.
pub fn vbap_run(
    exe: &std::path::Path,
    file: &std::path::Path,
    run_dir: &std::path::Path,
) -> std::io::Result<(std::process::Command, std::path::PathBuf)> {
    use std::process::Stdio;
    let log_path = run_dir.join("vbap.log");
    let log = std::fs::File::create(&log_path).map_err(|e| {
        std::io::Error::new(e.kind(), format!("creating {}: {e}", log_path.display()))
    })?;
    let mut cmd = std::process::Command::new(exe);
    cmd.arg("run")
        .arg(file)
        .arg("--out")
        .arg(run_dir)
        .arg("--quiet")
        .stdin(Stdio::null())
        .stdout(log.try_clone()?)
        .stderr(log);
    stop_with_parent(&mut cmd);
    Ok((cmd, log_path))
}

/// How long a process whose supervisor died may take to end on its own (SIGTERM: flush,
/// drop its node) before its watchdog ends it.
pub const ORPHAN_GRACE: std::time::Duration = std::time::Duration::from_secs(5);

/// The signal the kernel sends a process of a supervisor when the supervisor dies
/// (PR_SET_PDEATHSIG). Not SIGTERM itself: the kernel sends it as soon as the supervisor's
/// thread that started us exits, while the rest of a SIGKILLed supervisor is still going
/// (our parent is still the supervisor then, and a process ending at once would believe
/// it alive and leave the cleaning to it). The watchdog of [`die_with_parent`] takes it,
/// waits until the supervisor is gone, then ends the process with SIGTERM.
pub const PARENT_DEATH_SIGNAL: Signal = Signal::SIGUSR2;

/// Set from the [`PARENT_DEATH_SIGNAL`] until the watchdog knows whether the supervisor is
/// gone: a process ending meanwhile waits for the answer before it leaves the domain.
static PARENT_DYING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Makes this process end with its supervisor `expected_parent`, so a crashed or SIGKILLed
/// supervisor leaves no orphan: once the supervisor is gone (the kernel's
/// [`PARENT_DEATH_SIGNAL`], then our parent is no longer `expected_parent`), the process
/// gets SIGTERM and ends as on Ctrl-C (rows and records flushed, its iceoryx2 node dropped;
/// the last one out removes the domain's files, see [`leave_domain`]). A watchdog thread
/// ends the process with [`EXIT_FAILURE`] if it is still alive [`ORPHAN_GRACE`] later,
/// leaving the domain first (so a member ended by its watchdog still cleans when last). If
/// the supervisor is already gone, exits at once. Without `expected_parent` (a process
/// started by hand) the kernel sends SIGTERM when the parent dies.
///
/// Call first in `main`, before any thread starts: the signal is blocked in this thread,
/// so in every thread started after it, and taken by the watchdog alone.
pub fn die_with_parent(expected_parent: Option<u32>) {
    let Some(parent) = expected_parent else {
        let _ = nix::sys::prctl::set_pdeathsig(Signal::SIGTERM);
        return;
    };
    let death = nix::sys::signal::SigSet::from(PARENT_DEATH_SIGNAL);
    let _ = death.thread_block();
    let _ = nix::sys::prctl::set_pdeathsig(PARENT_DEATH_SIGNAL);
    if orphaned(Some(parent)) {
        std::process::exit(EXIT_FAILURE);
    }
    let _ = std::thread::Builder::new()
        .name("orphan-watchdog".into())
        .spawn(move || {
            use std::sync::atomic::Ordering;
            loop {
                // Blocks until the kernel sends the signal (the supervisor's thread that
                // started us ended): no polling while the supervisor lives.
                let _ = death.wait();
                PARENT_DYING.store(true, Ordering::SeqCst);
                if await_orphaned(parent, ORPHAN_GRACE) {
                    break;
                }
                // A thread of a live supervisor ended (we were moved to another), or the
                // signal came from elsewhere: the supervisor lives, so do we.
                PARENT_DYING.store(false, Ordering::SeqCst);
            }
            // The process-directed SIGTERM goes to iceoryx2's handler, as a Ctrl-C would.
            let _ = nix::sys::signal::kill(nix::unistd::Pid::this(), Signal::SIGTERM);
            std::thread::sleep(ORPHAN_GRACE);
            eprintln!(
                "the supervisor (pid {parent}) died and this process did not end within {ORPHAN_GRACE:?}: exiting"
            );
            leave_domain();
            std::process::exit(EXIT_FAILURE);
        });
}

/// Waits (at most `timeout`) until `parent` is no longer this process's parent: a dying
/// supervisor's last thread is gone within milliseconds, and that has no event a thread
/// can block on, so look every 5 ms. True when it is gone.
fn await_orphaned(parent: u32, timeout: std::time::Duration) -> bool {
    let deadline = std::time::Instant::now() + timeout;
    while !orphaned(Some(parent)) {
        if std::time::Instant::now() >= deadline {
            return false;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    true
}

/// True when `expected_parent` is given and is no longer this process's parent (the
/// supervisor died).
pub fn orphaned(expected_parent: Option<u32>) -> bool {
    let ppid = std::os::unix::process::parent_id();
    expected_parent.is_some_and(|p| p != ppid)
}

/// This process's membership of its mission's domain (see [`join_domain`]).
struct Membership {
    /// The members file, under a shared lock while a member; None when it could not be
    /// opened or locked (then [`leave_domain`] falls back to a scan of live nodes).
    file: Option<std::fs::File>,
    /// The mission's name.
    mission: String,
    /// The supervisor's pid, as given to [`die_with_parent`].
    expected_parent: Option<u32>,
}

/// The membership of this process, taken by [`leave_domain`] (from the main thread or the
/// orphan watchdog, whichever comes first; the other then finds it gone).
static MEMBERSHIP: std::sync::Mutex<Option<Membership>> = std::sync::Mutex::new(None);

/// How long the last member out of an orphaned mission waits for the nodes of the members
/// that left before it (their processes are exiting) to go, before it cleans the domain.
const LAST_OUT_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// Makes this process a member of mission `mission`'s domain: a shared `flock(2)` on the
/// domain's members file ([`crate::topics::Domain::members_file`]), held until
/// [`leave_domain`] or the process's death (the kernel releases it however the process
/// dies). When the supervisor `expected_parent` was killed, the member that leaves last
/// is the one that can lock the file exclusively: it alone cleans the domain, and no
/// interleaving of exits, SIGKILLs and watchdog exits leaves the domain's files behind.
/// Call once, after loading the mission and before creating nodes; a file system that
/// refuses the file costs nothing but that guarantee (logged).
pub fn join_domain(mission: &str, expected_parent: Option<u32>) {
    let file = match crate::topics::Domain::new(mission) {
        Ok(domain) => lock_members(&domain.members_file())
            .map_err(|e| tracing::warn!(error = %e, "cannot join the domain's members file"))
            .ok(),
        Err(_) => None,
    };
    let mut slot = MEMBERSHIP
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    *slot = Some(Membership {
        file,
        mission: mission.to_string(),
        expected_parent,
    });
}

/// Opens `path` (created if absent) and locks it shared, the file the path names when the
/// lock is granted (a last member may remove the path between our open and our lock).
fn lock_members(path: &std::path::Path) -> std::io::Result<std::fs::File> {
    loop {
        use std::os::unix::fs::OpenOptionsExt;
        // Owner-only, as every file of the domain (`Domain::restrict_to_owner`).
        let file = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .mode(0o600)
            .open(path)?;
        file.lock_shared()?;
        if names_file(path, &file) {
            return Ok(file);
        }
    }
}

/// True when `path` names the open `file` (same device and inode).
fn names_file(path: &std::path::Path, file: &std::fs::File) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(path), file.metadata()) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// Leaves the domain joined by [`join_domain`]: called by a process once its nodes are
/// dropped, or by its orphan watchdog just before it ends the process. With a live
/// supervisor it only releases the membership (the supervisor cleans up at the end of
/// the run). When the supervisor is gone (so nobody else will), the last member out
/// removes the domain's leftovers: the resources of dead nodes, then every file of its
/// prefix, even those of a sibling that was itself SIGKILLed.
///
/// The last member is the one whose exclusive lock of the members file is granted after
/// it gave up its shared one: granted only when no other member holds it, refused to all
/// but one of members leaving together. It waits (at most [`LAST_OUT_WAIT`]) for the
/// nodes of the others, whose processes are exiting, to go; a node still alive then (a
/// `vbap services` watching, say) leaves the domain as it is. If a new run of the mission
/// already cleaned the domain (the path names another file), it does nothing.
pub fn leave_domain() {
    let mut slot = MEMBERSHIP
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(member) = slot.take() else {
        return;
    };
    let dying = PARENT_DYING.load(std::sync::atomic::Ordering::SeqCst);
    let gone = match member.expected_parent {
        Some(parent) => orphaned(Some(parent)) || (dying && await_orphaned(parent, ORPHAN_GRACE)),
        None => false,
    };
    if !gone {
        return;
    }
    let Ok(domain) = crate::topics::Domain::new(&member.mission) else {
        return;
    };
    if let Some(file) = &member.file {
        let _ = file.unlock();
        if file.try_lock().is_err() || !names_file(&domain.members_file(), file) {
            return;
        }
    }
    let deadline = std::time::Instant::now() + LAST_OUT_WAIT;
    loop {
        let alive = domain.alive_node_names_of_others();
        if alive.is_empty() {
            break;
        }
        if std::time::Instant::now() >= deadline {
            tracing::info!(
                ?alive,
                "orphaned mission: live nodes remain, domain left as is"
            );
            return;
        }
        // The nodes of exiting processes go without an event to wait on: look again.
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let dead = domain.cleanup_dead_nodes();
    let files = domain.remove_files();
    tracing::info!(
        dead,
        files,
        "last process of an orphaned mission: domain cleaned"
    );
    // `member` goes here: its exclusive lock is released after the files are gone.
}

/// The state letter of process `pid` (`R`, `S`, `T`, `Z`, ...: `/proc/<pid>/stat`, the
/// field after the last ')'), None when there is no such process.
pub fn process_state(pid: u32) -> Option<char> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    let (_, rest) = stat.rsplit_once(')')?;
    rest.trim_start().chars().next()
}

/// True when process `pid` exists and is not a zombie (exited, not yet reaped).
pub fn process_alive(pid: u32) -> bool {
    process_state(pid).is_some_and(|state| state != 'Z' && state != 'X')
}

/// Sends SIGKILL to process `pid`; false when it does not exist (any more).
pub fn sigkill(pid: u32) -> bool {
    match i32::try_from(pid) {
        Ok(pid) if pid > 0 => {
            nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), Signal::SIGKILL).is_ok()
        }
        _ => false,
    }
}

/// Asks the kernel to send SIGTERM to the child `cmd` starts when the thread that started
/// it dies (its parent was killed), so a `vbap run` never outlives the batch or campaign
/// that started it; SIGTERM lets it stop its process set cleanly.
#[allow(unsafe_code)]
pub fn stop_with_parent(cmd: &mut std::process::Command) {
    use std::os::unix::process::CommandExt;
    // SAFETY: the closure runs in the child between fork and exec and only calls prctl(2),
    // which is async-signal-safe and touches no memory of ours.
    unsafe {
        cmd.pre_exec(|| {
            let _ = nix::sys::prctl::set_pdeathsig(Signal::SIGTERM);
            Ok(())
        });
    }
}

/// The input a process was given (its mission file, say:
/// `valid_or_exit("coordinator", Mission::load(path))`), or, when it is invalid, an exit
/// with [`EXIT_INVALID`] naming what is wrong.
pub fn valid_or_exit<T, E: std::fmt::Display>(process: &str, input: Result<T, E>) -> T {
    match input {
        Ok(v) => v,
        Err(e) => {
            eprintln!("{process}: {e}");
            std::process::exit(EXIT_INVALID);
        }
    }
}

/// Tells the supervisor this process is ready: the line `ready` on stdout.
pub fn announce_ready() {
    use std::io::Write;
    println!("ready");
    let _ = std::io::stdout().flush();
}

/// Ends a process: logs a failure (`error`: the message with its causes), flushes the
/// log, exits with [`EXIT_OK`] or [`EXIT_FAILURE`].
pub fn finish(
    process: &str,
    error: Option<String>,
    log: std::io::Result<crate::telemetry::LogGuard>,
) -> ! {
    let code = match error {
        None => EXIT_OK,
        Some(e) => {
            tracing::error!(process, error = %e, "failed");
            eprintln!("{process}: {e}");
            EXIT_FAILURE
        }
    };
    if let Ok(g) = &log {
        g.flush();
    }
    drop(log);
    std::process::exit(code);
}

/// The message-record log beside a process's tracing log (`logs/<process>.msgs.csv`);
/// disabled, with a warning, when it cannot be opened (records are for analysis, never a
/// reason to stop a mission). Call after the tracing setup.
pub fn message_log(log_file: Option<&std::path::Path>) -> crate::msglog::MsgLog {
    crate::msglog::MsgLog::beside(log_file).unwrap_or_else(|e| {
        tracing::warn!(error = %e, "cannot open the message-record file: records are off");
        crate::msglog::MsgLog::disabled()
    })
}

#[cfg(test)]
mod alive_tests {
    use super::{process_alive, process_state};

    /// This process runs; a child that exited and is not yet reaped (a zombie) does not, nor
    /// does it once reaped.
    #[test]
    fn a_zombie_or_reaped_process_does_not_run() {
        assert!(process_alive(std::process::id()));
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        while process_state(pid) != Some('Z') {
            std::thread::yield_now();
        }
        assert!(!process_alive(pid));
        child.wait().unwrap();
        assert!(!process_alive(pid));
    }
}
