//! The `wfic` command line. Built with a model checker's primitives (`--features loom` or
//! `shuttle`, `cfg(checker)`) it only says so: loom and shuttle types work inside their models only.

#[cfg(checker)]
fn main() -> std::process::ExitCode {
    eprintln!(
        "error: wfic was built with a model checker feature (loom or shuttle); rebuild without it"
    );
    std::process::ExitCode::from(2)
}

#[cfg(not(checker))]
fn main() -> std::process::ExitCode {
    wfic_experiments::cli::main()
}
