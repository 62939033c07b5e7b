//! `vehicle_agent --mission FILE --id I [--rejoin] [--incarnation N] [--log FILE]`: one
//! vehicle of a mission, flying the mission's control law (`control.law`).

use clap::Parser;

fn main() {
    let args = vehicle_agent::cli::Args::parse();
    vehicle_agent::cli::main(&args)
}
