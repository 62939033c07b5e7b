//! The vehicle agent's command line (`vehicle_agent --mission FILE --id I [--rejoin]
//! [--incarnation N] [--log FILE] [--parent PID]`), as a library: the shipped binary and a user's own executable
//! (flying its own control law) parse and run it alike.

use std::path::PathBuf;
use std::sync::Arc;

use vbap_ipc::process::{announce_ready, die_with_parent, finish, valid_or_exit, EXIT_INVALID};
use vbap_math::law::ControlLaw;

/// One vehicle of a vbap mission (normally started by `vbap run`).
#[derive(clap::Parser, Debug)]
#[command(version, about)]
pub struct Args {
    /// The mission file.
    #[arg(long)]
    pub mission: PathBuf,
    /// This vehicle's id (0-based, below vehicles.count).
    #[arg(long)]
    pub id: u32,
    /// This process is a restart: ask to join the mission under way.
    #[arg(long)]
    pub rejoin: bool,
    /// Incarnation of this process in the vehicle's slot: 1 for the first process, one
    /// more per restart (the supervisor says which); 0 (default) when unknown. Carried in
    /// every state, so the coordinator tells a new process from the one it knew.
    #[arg(long, default_value_t = 0)]
    pub incarnation: u32,
    /// JSON-lines log file (default: stderr).
    #[arg(long)]
    pub log: Option<PathBuf>,
    /// Exit when this process (the supervisor) is no longer our parent.
    #[arg(long)]
    pub parent: Option<u32>,
}

/// Runs the vehicle of `args` flying the mission's law ([`crate::mission_law`]: the
/// paper's, or the robust law under `control.law = "robust"`), then exits as
/// [`main_with`] does.
pub fn main(args: &Args) -> ! {
    main_flying(args, None)
}

/// Runs the vehicle of `args` flying `law`, then exits the process (code 0, or 1 with the
/// error on stderr; 2 for an invalid mission or id).
pub fn main_with(args: &Args, law: Arc<dyn ControlLaw>) -> ! {
    main_flying(args, Some(law))
}

/// [`main_with`] flying `law`, or the mission's law when None.
fn main_flying(args: &Args, law: Option<Arc<dyn ControlLaw>>) -> ! {
    die_with_parent(args.parent);
    let mission = valid_or_exit(
        "vehicle_agent",
        vbap_mission::config::Mission::load(&args.mission),
    );
    vbap_ipc::process::join_domain(&mission.mission.name, args.parent);
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
    let law = law.unwrap_or_else(|| crate::mission_law(&mission));
    let start = crate::run::Start {
        id: args.id,
        rejoin: args.rejoin,
        incarnation: args.incarnation,
    };
    let result = crate::run::run_with(&mission, start, law, msgs, announce_ready);
    vbap_ipc::process::leave_domain();
    finish(&process, result.err().map(|e| format!("{e:#}")), log)
}
