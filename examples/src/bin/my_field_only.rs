//! `my_field_only`: vbap over the user's own field, flying the paper's law: the reference
//! `my_vbap` is compared with to see what its own law changes.

fn main() {
    let mut plugins = vbap_examples::my_plugins();
    plugins.law = None;
    std::process::exit(vbap_cli::custom::main(plugins));
}
