//! Process plumbing shared by the three binaries: ending with the supervisor, exit codes.

/// Exit code: success.
pub const EXIT_OK: i32 = 0;
/// Exit code: runtime failure.
pub const EXIT_FAILURE: i32 = 1;
/// Exit code: invalid input (config, arguments).
pub const EXIT_INVALID: i32 = 2;

/// How long a process whose supervisor died may take to end on its own (SIGTERM: flush,
/// drop its node) before its watchdog ends it.
pub const ORPHAN_GRACE: std::time::Duration = std::time::Duration::from_secs(5);

/// Asks the kernel to send this process SIGTERM when its parent dies (PR_SET_PDEATHSIG), so
/// a crashed or SIGKILLed supervisor leaves no orphan: the process ends as on Ctrl-C (rows
/// and records flushed, its iceoryx2 node dropped; the last one out removes the domain's
/// files, see [`leave_domain`]). A watchdog thread ends the process with
/// [`EXIT_FAILURE`] if it is still alive [`ORPHAN_GRACE`] after the parent's death. If the
/// parent is already gone (`expected_parent` no longer our parent), exits at once.
#[allow(unsafe_code)]
pub fn die_with_parent(expected_parent: Option<u32>) {
    // SAFETY: prctl(PR_SET_PDEATHSIG, sig) takes two integers and touches no memory of ours.
    unsafe {
        libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM as libc::c_ulong);
    }
    if let Some(parent) = expected_parent {
        if orphaned(Some(parent)) {
            std::process::exit(EXIT_FAILURE);
        }
        let _ = std::thread::Builder::new()
            .name("orphan-watchdog".into())
            .spawn(move || {
                // The parent's death has no event a thread can block on (the SIGTERM goes
                // to iceoryx2's handler): look four times a second, a getppid each.
                while !orphaned(Some(parent)) {
                    std::thread::sleep(std::time::Duration::from_millis(250));
                }
                std::thread::sleep(ORPHAN_GRACE);
                eprintln!(
                    "the supervisor (pid {parent}) died and this process did not end within {ORPHAN_GRACE:?}: exiting"
                );
                std::process::exit(EXIT_FAILURE);
            });
    }
}

/// True when `expected_parent` is given and is no longer this process's parent (the
/// supervisor died).
#[allow(unsafe_code)]
pub fn orphaned(expected_parent: Option<u32>) -> bool {
    // SAFETY: getppid has no preconditions.
    let ppid = unsafe { libc::getppid() } as u32;
    expected_parent.is_some_and(|p| p != ppid)
}

/// Called by a process of mission `mission` once its node is dropped: when its supervisor
/// is gone (so nobody else will) and no process of the domain is alive any more, removes
/// the domain's leftovers (the resources of dead nodes, then every file of its prefix).
/// The last process out of a mission whose supervisor was killed so leaves nothing behind,
/// even for a sibling that was itself SIGKILLed. With a live supervisor it does nothing: the
/// supervisor cleans up at the end of the run.
pub fn leave_domain(mission: &str, expected_parent: Option<u32>) {
    if !orphaned(expected_parent) {
        return;
    }
    let Ok(domain) = crate::topics::Domain::new(mission) else {
        return;
    };
    if domain.alive_node_names().is_empty() {
        let dead = domain.cleanup_dead_nodes();
        let files = domain.remove_files();
        tracing::info!(
            dead,
            files,
            "last process of an orphaned mission: domain cleaned"
        );
    }
}

/// Sends SIGKILL to process `pid`; false when it does not exist (any more).
#[allow(unsafe_code)]
pub fn sigkill(pid: u32) -> bool {
    if pid == 0 || pid > i32::MAX as u32 {
        return false;
    }
    // SAFETY: kill(2) takes a pid and a signal number and touches no memory of ours.
    unsafe { libc::kill(pid as libc::pid_t, libc::SIGKILL) == 0 }
}

/// Loads the mission file of a process, or exits with [`EXIT_INVALID`] naming what is wrong.
pub fn load_mission_or_exit(
    process: &str,
    path: &std::path::Path,
) -> vbap_mission::config::Mission {
    match vbap_mission::config::Mission::load(path) {
        Ok(m) => m,
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
