//! The user's errors and the exit codes of `vbap`: 0 success, 1 runtime failure, 2 invalid
//! input (a bad argument or mission file, named in the message). A leaf: it uses no other
//! module of this crate.

pub use vbap_ipc::process::InvalidInput;
use vbap_ipc::process::{EXIT_FAILURE, EXIT_INVALID};

/// Prints `e` as `vbap: <message>` on stderr and returns its exit code: [`EXIT_INVALID`]
/// for an [`InvalidInput`], a run directory that cannot be reported on or a mission-file
/// error, [`EXIT_FAILURE`] for anything else
/// (printed with its causes).
pub fn report(e: &anyhow::Error) -> i32 {
    if let Some(inv) = e.downcast_ref::<InvalidInput>() {
        eprintln!("vbap: {inv}");
        EXIT_INVALID
    } else if let Some(inv) = e.downcast_ref::<vbap_report::InvalidRunDir>() {
        eprintln!("vbap: {inv}");
        EXIT_INVALID
    } else if let Some(inv) = e.downcast_ref::<vbap_sim::RunDirRefused>() {
        eprintln!("vbap: {inv}");
        EXIT_INVALID
    } else if let Some(cfg) = e.downcast_ref::<vbap_mission::config::ConfigError>() {
        eprintln!("vbap: {cfg}");
        EXIT_INVALID
    } else {
        eprintln!("vbap: {e:#}");
        EXIT_FAILURE
    }
}
