//! `cargo run --release --example render -- --scene cornell --scheme wf --threads 2`: the
//! `wfic render` subcommand as a stand-alone program.
// The renderer is compiled out under the model checkers (`cfg(checker)`, set by build.rs).
#[cfg(not(checker))]
mod app {
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: wfic::render::cli::RenderArgs,
    }

    pub fn main() {
        let cli = Cli::parse();
        if let Err(e) = wfic::render::cli::run_render(cli.args) {
            eprintln!("error: {e}");
            std::process::exit(e.exit_code());
        }
    }
}

fn main() {
    #[cfg(not(checker))]
    app::main();
}
