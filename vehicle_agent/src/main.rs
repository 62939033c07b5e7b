//! `vehicle_agent --mission FILE --id I [--rejoin] [--log FILE]`: one vehicle of a mission.

use std::sync::Arc;

use clap::Parser;
use vbap_math::law::PaperLaw;

fn main() {
    let args = vehicle_agent::cli::Args::parse();
    vehicle_agent::cli::main_with(&args, Arc::new(PaperLaw))
}
