//! `coordinator --mission FILE --run-dir DIR [--log FILE]`: the coordinator of a mission.

use clap::Parser;

fn main() {
    let args = coordinator::cli::Args::parse();
    coordinator::cli::main_with(&args, None)
}
