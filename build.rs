//! Sets `cfg(checker)` when a model checker (loom or shuttle) replaces the std primitives, so the
//! ordinary std-thread tests can be switched off with one attribute.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(checker)");
    if std::env::var_os("CARGO_FEATURE_LOOM").is_some()
        || std::env::var_os("CARGO_FEATURE_SHUTTLE").is_some()
    {
        println!("cargo::rustc-cfg=checker");
    }
    println!("cargo::rerun-if-changed=build.rs");
}
