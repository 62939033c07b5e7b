//! A user's own vbap: the same commands over the user's own field and control law.
//!
//! The extension points are traits: [`ScalarField`] (the sensed field, with its ground
//! truth) and [`ControlLaw`] (a vehicle's u_i). A user's crate implements them and hands
//! them to [`main`] in its own binary; that binary is then a `vbap` of its own:
//!
//! - `my_vbap sim MISSION ...`: the in-process simulator ([`vbap_sim::simulate_plugins`]);
//! - `my_vbap run MISSION ...`: the multi-process system, this same executable started
//!   again in each role (`my_vbap role field-server|coordinator|agent ...`,
//!   [`crate::supervise::Executables::this_exe_as_roles`]), so the field server samples
//!   the user's field, every agent flies the user's law and the coordinator judges the run
//!   by the user's field; in lockstep it writes the same files as `sim`, byte for byte;
//! - `check`, `formation`, `analyze` as in `vbap`.
//!
//! ```no_run
//! use vbap_cli::custom::Plugins;
//! use vbap_math::law::PaperLaw;
//!
//! fn main() {
//!     // e.g. `.with_field(MyField { .. })` for a user's own `ScalarField`
//!     let plugins = Plugins::default().with_law(PaperLaw);
//!     std::process::exit(vbap_cli::custom::main(plugins));
//! }
//! ```

use std::ffi::OsString;

use clap::Parser;
use field_server::{Sensors, World};
use vbap_ipc::process::EXIT_INVALID;

pub use crate::supervise::ROLE_COMMAND;
pub use vbap_sim::Plugins;

/// This executable in a role (`THIS role ...`): the roles' own command lines.
#[derive(Parser, Debug)]
#[command(name = ROLE_COMMAND)]
enum Role {
    /// The field server, sampling the plugged field.
    FieldServer(field_server::cli::Args),
    /// The coordinator, judging by the plugged field.
    Coordinator(coordinator::cli::Args),
    /// A vehicle agent, flying the plugged law.
    Agent(vehicle_agent::cli::Args),
}

/// The `main` of a user's own vbap (module documentation): plays a role when started as
/// `THIS role ...` by its own supervisor (and never returns then), otherwise runs the
/// command line with `plugins`. Returns the exit code.
pub fn main(plugins: Plugins) -> i32 {
    let args: Vec<OsString> = std::env::args_os().collect();
    if args.get(1).is_some_and(|a| a == ROLE_COMMAND) {
        let role = match Role::try_parse_from(&args[1..]) {
            Ok(role) => role,
            Err(e) => {
                let _ = e.print();
                return EXIT_INVALID;
            }
        };
        match role {
            Role::FieldServer(a) => field_server::cli::main_with(&a, |m| {
                Sensors::in_world(m, World::with_field(m, plugins.field_of(m)))
            }),
            Role::Coordinator(a) => coordinator::cli::main_with(&a, plugins.field.clone()),
            Role::Agent(a) => match plugins.law.clone() {
                Some(law) => vehicle_agent::cli::main_with(&a, law),
                None => vehicle_agent::cli::main(&a),
            },
        }
    }
    crate::cli::main_with(Some(&plugins))
}
