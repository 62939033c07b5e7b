//! `coordinator --mission FILE --run-dir DIR [--log FILE]`: the coordinator of a mission.

use std::io::Write;
use std::path::PathBuf;

use clap::Parser;
use shared::config::Mission;
use shared::process::{die_with_parent, EXIT_FAILURE, EXIT_INVALID};
use shared::rundir::RunDir;

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
    let mission = match Mission::load(&args.mission) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("coordinator: {e}");
            std::process::exit(EXIT_INVALID);
        }
    };
    let dir = match RunDir::create(&args.run_dir) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("coordinator: --run-dir {}: {e}", args.run_dir.display());
            std::process::exit(EXIT_INVALID);
        }
    };
    let log = shared::telemetry::init("coordinator", args.log.as_deref());
    let ready = || {
        println!("ready");
        let _ = std::io::stdout().flush();
    };
    let code = match coordinator::run::run(&mission, &dir, ready) {
        Ok(()) => 0,
        Err(e) => {
            tracing::error!(error = format!("{e:#}"), "coordinator failed");
            eprintln!("coordinator: {e:#}");
            EXIT_FAILURE
        }
    };
    if let Ok(g) = &log {
        g.flush();
    }
    drop(log);
    std::process::exit(code);
}
