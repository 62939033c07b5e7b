//! `vehicle_agent --mission FILE --id I [--log FILE]`: one vehicle of a mission.

use std::path::PathBuf;

use clap::Parser;
use shared::config::Mission;
use shared::process::{die_with_parent, EXIT_FAILURE, EXIT_INVALID};

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
    /// JSON-lines log file (default: stderr).
    #[arg(long)]
    log: Option<PathBuf>,
    /// This process is a restart: ask to join the mission under way.
    #[arg(long)]
    rejoin: bool,
    /// Exit when this process (the supervisor) is no longer our parent.
    #[arg(long)]
    parent: Option<u32>,
}

fn main() {
    let args = Args::parse();
    die_with_parent(args.parent);
    let mission = match Mission::load(&args.mission) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("vehicle_agent: {e}");
            std::process::exit(EXIT_INVALID);
        }
    };
    if args.id as usize >= mission.vehicles.count {
        eprintln!(
            "vehicle_agent: --id {}: must be below vehicles.count = {}",
            args.id, mission.vehicles.count
        );
        std::process::exit(EXIT_INVALID);
    }
    let log = shared::telemetry::init(&format!("vehicle_agent_{}", args.id), args.log.as_deref());
    let code = match vehicle_agent::run::run(&mission, args.id, args.rejoin, || {
        println!("ready");
        let _ = std::io::Write::flush(&mut std::io::stdout());
    }) {
        Ok(()) => 0,
        Err(e) => {
            tracing::error!(vehicle = args.id, error = format!("{e:#}"), "agent failed");
            eprintln!("vehicle_agent {}: {e:#}", args.id);
            EXIT_FAILURE
        }
    };
    if let Ok(g) = &log {
        g.flush();
    }
    drop(log);
    std::process::exit(code);
}
