//! Process plumbing shared by the three binaries: dying with the supervisor, exit codes.

/// Exit code: success.
pub const EXIT_OK: i32 = 0;
/// Exit code: runtime failure.
pub const EXIT_FAILURE: i32 = 1;
/// Exit code: invalid input (config, arguments).
pub const EXIT_INVALID: i32 = 2;

/// Asks the kernel to SIGKILL this process when its parent dies (PR_SET_PDEATHSIG), so a
/// crashed supervisor leaves no orphan. If the parent is already gone (`expected_parent`
/// no longer our parent), exits at once.
#[allow(unsafe_code)]
pub fn die_with_parent(expected_parent: Option<u32>) {
    // SAFETY: prctl(PR_SET_PDEATHSIG, sig) takes two integers and touches no memory of ours.
    unsafe {
        libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL as libc::c_ulong);
    }
    if let Some(parent) = expected_parent {
        // SAFETY: getppid has no preconditions.
        let ppid = unsafe { libc::getppid() } as u32;
        if ppid != parent {
            std::process::exit(EXIT_FAILURE);
        }
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
pub fn load_mission_or_exit(process: &str, path: &std::path::Path) -> crate::config::Mission {
    match crate::config::Mission::load(path) {
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
