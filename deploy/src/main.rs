//! `vbap`: see `vbap --help`.

fn main() {
    std::process::exit(deploy::cli::main());
}
