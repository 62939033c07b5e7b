//! `field_server --mission FILE [--log FILE]`: serves a mission's field.

use clap::Parser;

fn main() {
    let args = field_server::cli::Args::parse();
    field_server::cli::main_with(&args, field_server::Sensors::new)
}
