//! `field_server --mission FILE [--log FILE]`: serves a mission's field.

use std::io::Write;
use std::path::PathBuf;

use clap::Parser;
use shared::config::Mission;
use shared::process::{die_with_parent, EXIT_FAILURE, EXIT_INVALID};

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
    let mission = match Mission::load(&args.mission) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("field_server: {e}");
            std::process::exit(EXIT_INVALID);
        }
    };
    let log = shared::telemetry::init("field_server", args.log.as_deref());
    let ready = || {
        println!("ready");
        let _ = std::io::stdout().flush();
    };
    let code = match field_server::run::run(&mission, ready) {
        Ok(()) => 0,
        Err(e) => {
            tracing::error!(error = format!("{e:#}"), "field server failed");
            eprintln!("field_server: {e:#}");
            EXIT_FAILURE
        }
    };
    if let Ok(g) = &log {
        g.flush();
    }
    drop(log);
    std::process::exit(code);
}
