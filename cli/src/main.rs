//! `vbap`: see `vbap --help`.

fn main() {
    std::process::exit(vbap_cli::cli::main());
}
