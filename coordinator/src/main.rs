//! `coordinator --mission FILE --run-dir DIR [--log FILE] [--parent PID
//! [--summary-to-parent]]`: the coordinator of a mission (`coordinator::cli`).

use clap::Parser;

fn main() {
    let args = coordinator::cli::Args::parse();
    coordinator::cli::main_with(&args, None)
}
