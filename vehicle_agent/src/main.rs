//! `vehicle_agent --mission FILE --id I [--rejoin] [--log FILE]`: one vehicle of a mission.

use std::path::PathBuf;

use clap::Parser;
use vbap_ipc::process::{
    announce_ready, die_with_parent, finish, load_mission_or_exit, EXIT_INVALID,
};

/// One vehicle of a vbap mission (normally started by `vbap run`).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The mission file.
    #[arg(long)]
    mission: PathBuf,
    /// This vehicle's id (0-based, below vehicles.count).
    #[arg(long)]
    id: u32,
    /// This process is a restart: ask to join the mission under way.
    #[arg(long)]
    rejoin: bool,
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
    let mission = load_mission_or_exit("vehicle_agent", &args.mission);
    if args.id as usize >= mission.vehicles.count {
        eprintln!(
            "vehicle_agent: --id {}: must be below vehicles.count = {}",
            args.id, mission.vehicles.count
        );
        std::process::exit(EXIT_INVALID);
    }
    let process = format!("vehicle_agent_{}", args.id);
    let log = vbap_ipc::telemetry::init(&process, args.log.as_deref());
    let msgs = vbap_ipc::process::message_log(args.log.as_deref());
    let result = vehicle_agent::run::run(&mission, args.id, args.rejoin, msgs, announce_ready);
    vbap_ipc::process::leave_domain(&mission.mission.name, args.parent);
    finish(&process, result.err().map(|e| format!("{e:#}")), log);
}
