//! `coordinator --mission FILE --run-dir DIR [--log FILE]`: the coordinator of a mission.

use std::path::PathBuf;

use clap::Parser;
use vbap_ipc::process::{
    announce_ready, die_with_parent, finish, load_mission_or_exit, EXIT_INVALID,
};
use vbap_mission::rundir::RunDir;

/// The coordinator of a vbap mission (normally started by `vbap run`).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The mission file.
    #[arg(long)]
    mission: PathBuf,
    /// The run directory to write into.
    #[arg(long)]
    run_dir: PathBuf,
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
    let mission = load_mission_or_exit("coordinator", &args.mission);
    let dir = RunDir::create(&args.run_dir).unwrap_or_else(|e| {
        eprintln!("coordinator: --run-dir {}: {e}", args.run_dir.display());
        std::process::exit(EXIT_INVALID);
    });
    let log = vbap_ipc::telemetry::init("coordinator", args.log.as_deref());
    let msgs = vbap_ipc::process::message_log(args.log.as_deref());
    let result = coordinator::run::run(&mission, &dir, msgs, announce_ready);
    vbap_ipc::process::leave_domain(&mission.mission.name, args.parent);
    finish("coordinator", result.err().map(|e| format!("{e:#}")), log);
}
