//! `my_vbap`: vbap over a user's own field and control law (see the crate documentation).
//! `my_vbap sim MISSION`, `my_vbap run MISSION`, with every flag of `vbap sim` / `vbap run`.

fn main() {
    std::process::exit(vbap_cli::custom::main(vbap_examples::my_plugins()));
}
