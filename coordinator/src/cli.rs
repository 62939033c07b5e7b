//! The coordinator's command line (`coordinator --mission FILE --run-dir DIR [--log FILE]
//! [--parent PID]`), as a library: the shipped binary and a user's own executable (judging
//! the run by its own field) parse and run it alike.

use std::path::PathBuf;
use std::sync::Arc;

use shared::field::ScalarField;
use shared::process::{
    announce_ready, die_with_parent, finish, load_mission_or_exit, EXIT_INVALID,
};
use shared::rundir::RunDir;

/// The coordinator of a vbap mission (normally started by `vbap run`).
#[derive(clap::Parser, Debug)]
#[command(version, about)]
pub struct Args {
    /// The mission file.
    #[arg(long)]
    pub mission: PathBuf,
    /// The run directory to write into.
    #[arg(long)]
    pub run_dir: PathBuf,
    /// JSON-lines log file (default: stderr).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Exit when this process (the supervisor) is no longer our parent.
    #[arg(long)]
    pub parent: Option<u32>,
}

/// Runs the coordinator of `args`, its recorder judging by `truth` (None: the mission's
/// own field; see [`crate::record::set_process_truth`]), then exits the process (code 0,
/// or 1 with the error on stderr; 2 for an invalid mission or run directory).
pub fn main_with(args: &Args, truth: Option<Arc<dyn ScalarField>>) -> ! {
    die_with_parent(args.parent);
    let mission = load_mission_or_exit("coordinator", &args.mission);
    let dir = RunDir::create(&args.run_dir).unwrap_or_else(|e| {
        eprintln!("coordinator: --run-dir {}: {e}", args.run_dir.display());
        std::process::exit(EXIT_INVALID);
    });
    if let Some(field) = truth {
        crate::record::set_process_truth(field);
    }
    let log = shared::telemetry::init("coordinator", args.log.as_deref());
    let msgs = shared::process::message_log(args.log.as_deref());
    let result = crate::run::run(&mission, &dir, msgs, announce_ready);
    shared::process::leave_domain(&mission.mission.name, args.parent);
    finish("coordinator", result.err().map(|e| format!("{e:#}")), log)
}
