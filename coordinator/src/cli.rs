//! The coordinator's command line (`coordinator --mission FILE --run-dir DIR [--log FILE]
//! [--parent PID [--summary-to-parent]]`), as a library: the shipped binary and a user's own executable (judging
//! the run by its own field) parse and run it alike.

use std::path::PathBuf;
use std::sync::Arc;

use crate::planner::{Planner, PlannerParams};

use vbap_ipc::process::{
    announce_ready, die_with_parent, finish, orphaned, valid_or_exit, EXIT_INVALID,
};
use vbap_mission::field::ScalarField;
use vbap_mission::rundir::{RunDir, Summary};

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
    /// Hand the summary to the supervisor (`--parent`) on standard output instead of
    /// writing `summary.json`: it completes the summary and writes the file once. Written
    /// here all the same when the supervisor is gone.
    #[arg(long, requires = "parent")]
    pub summary_to_parent: bool,
}

/// Runs the coordinator of `args`, its recorder judging by `truth` (None: the mission's
/// own field), then exits the process (code 0,
/// or 1 with the error on stderr; 2 for an invalid mission or run directory).
pub fn main_with(args: &Args, truth: Option<Arc<dyn ScalarField>>) -> ! {
    die_with_parent(args.parent);
    let mission = valid_or_exit(
        "coordinator",
        vbap_mission::config::Mission::load(&args.mission),
    );
    vbap_ipc::process::join_domain(&mission.mission.name, args.parent);
    let dir = RunDir::create(&args.run_dir).unwrap_or_else(|e| {
        eprintln!("coordinator: --run-dir {}: {e}", args.run_dir.display());
        std::process::exit(EXIT_INVALID);
    });
    let log = vbap_ipc::telemetry::init("coordinator", args.log.as_deref());
    let msgs = vbap_ipc::process::message_log(args.log.as_deref());
    let truth = truth.unwrap_or_else(|| Arc::new(mission.field()));
    let new_planner = |ids: &[u32]| {
        Planner::new(
            PlannerParams::from_mission(&mission),
            mission.start_vec(),
            ids,
        )
    };
    let result = crate::run::run_with(&mission, &dir, msgs, announce_ready, truth, new_planner);
    let result = result.and_then(|summary| {
        let parent = args.parent.filter(|_| args.summary_to_parent);
        deliver(&summary, &dir, parent)
    });
    vbap_ipc::process::leave_domain();
    finish("coordinator", result.err().map(|e| format!("{e:#}")), log)
}

/// Hands `summary` to the supervisor `parent` (one line on standard output), or, without
/// one (none asked for, or it died: the line cannot be written), writes `summary.json`.
fn deliver(summary: &Summary, dir: &RunDir, parent: Option<u32>) -> anyhow::Result<()> {
    use std::io::Write;
    if parent.is_some() && !orphaned(parent) {
        let line = crate::handover::summary_line(summary)?;
        let mut out = std::io::stdout().lock();
        match writeln!(out, "{line}").and_then(|()| out.flush()) {
            Ok(()) => return Ok(()),
            Err(e) => tracing::warn!(error = %e, "the supervisor is gone: writing summary.json"),
        }
    }
    anyhow::Context::context(summary.write(dir), "writing summary.json")
}
