//! `field_server --mission FILE [--log FILE]`: serves a mission's field.

use std::path::PathBuf;

use clap::Parser;
use vbap_ipc::process::{announce_ready, die_with_parent, finish, load_mission_or_exit};

/// The field server of a vbap mission (normally started by `vbap run`).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The mission file.
    #[arg(long)]
    mission: PathBuf,
    /// JSON-lines log file (default: stderr).
    #[arg(long)]
    log: Option<PathBuf>,
    /// Exit when this process (the supervisor) is no longer our parent.
    #[arg(long)]
    parent: Option<u32>,
}

fn main() {
    let args = Args::parse();
    die_with_parent(args.parent);
    let mission = load_mission_or_exit("field_server", &args.mission);
    let log = vbap_ipc::telemetry::init("field_server", args.log.as_deref());
    let msgs = vbap_ipc::process::message_log(args.log.as_deref());
    let result = field_server::run::run(&mission, msgs, announce_ready);
    vbap_ipc::process::leave_domain(&mission.mission.name, args.parent);
    finish("field_server", result.err().map(|e| format!("{e:#}")), log);
}
