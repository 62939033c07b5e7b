//! `vbap_bridge --mission FILE --hosts FILE --host NAME [--log FILE] [--parent PID]`: the
//! bridge of one host of a mission spread over machines (started by `vbap run --hosts`).

use std::path::PathBuf;

use clap::Parser;
use vbap_ipc::process::{announce_ready, die_with_parent, finish, valid_or_exit};

/// The Zenoh bridge of one host of a vbap mission.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// The mission file.
    #[arg(long)]
    mission: PathBuf,
    /// The hosts file.
    #[arg(long)]
    hosts: PathBuf,
    /// This host's name in the hosts file.
    #[arg(long)]
    host: String,
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
    let mission = valid_or_exit(
        "vbap_bridge",
        vbap_mission::config::Mission::load(&args.mission),
    );
    vbap_ipc::process::join_domain(&mission.mission.name, args.parent);
    let hosts = valid_or_exit(
        "vbap_bridge",
        vbap_mission::hosts::Hosts::load(&args.hosts, mission.vehicles.count)
            .and_then(|h| h.host(&args.host).map(|_| ()).map(|()| h)),
    );
    let log = vbap_ipc::telemetry::init_watching(
        "vbap_bridge",
        args.log.as_deref(),
        vbap_ipc::telemetry::DEFAULT_FILTER,
        vbap_bridge::keys::WATCHED_ZENOH_EVENTS,
        vbap_bridge::run::watch_zenoh,
    );
    let result = vbap_bridge::run(&mission, &hosts, &args.host, announce_ready);
    vbap_ipc::process::leave_domain();
    finish("vbap_bridge", result.err().map(|e| format!("{e:#}")), log)
}
