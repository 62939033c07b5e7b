//! The field server's command line (`field_server --mission FILE [--log FILE] [--parent
//! PID]`), as a library: the shipped binary and a user's own executable (over its own
//! field) parse and run it alike.

use std::path::PathBuf;

use vbap_ipc::process::{announce_ready, die_with_parent, finish, valid_or_exit};
use vbap_mission::config::Mission;

use crate::Sensors;

/// The field server of a vbap mission (normally started by `vbap run`).
#[derive(clap::Parser, Debug)]
#[command(version, about)]
pub struct Args {
    /// The mission file.
    #[arg(long)]
    pub mission: PathBuf,
    /// JSON-lines log file (default: stderr).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Exit when this process (the supervisor) is no longer our parent.
    #[arg(long)]
    pub parent: Option<u32>,
}

/// Runs the field server of `args` over the sensors `sensors` makes of the mission, then
/// exits the process (code 0, or 1 with the error on stderr; 2 for an invalid mission).
pub fn main_with(args: &Args, sensors: impl FnOnce(&Mission) -> Sensors) -> ! {
    die_with_parent(args.parent);
    let mission = valid_or_exit(
        "field_server",
        vbap_mission::config::Mission::load(&args.mission),
    );
    vbap_ipc::process::join_domain(&mission.mission.name, args.parent);
    let log = vbap_ipc::telemetry::init("field_server", args.log.as_deref());
    let msgs = vbap_ipc::process::message_log(args.log.as_deref());
    let result = crate::run::run_with(&mission, sensors(&mission), msgs, announce_ready);
    vbap_ipc::process::leave_domain();
    finish("field_server", result.err().map(|e| format!("{e:#}")), log)
}
