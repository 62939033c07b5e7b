//! Process plumbing shared by the binaries: ending with the supervisor (or making a child
//! end with us), signals, exit codes.

use nix::sys::signal::Signal;

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
pub fn die_with_parent(expected_parent: Option<u32>) {
    let _ = nix::sys::prctl::set_pdeathsig(Signal::SIGTERM);
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
pub fn orphaned(expected_parent: Option<u32>) -> bool {
    let ppid = std::os::unix::process::parent_id();
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
