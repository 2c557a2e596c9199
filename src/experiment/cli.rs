//! `wfic reproduce table1` and `wfic reproduce animation`: arguments, progress bar, output.

use super::animation::{self, AnimationConfig};
use super::table1::{self, Table1Config};
use super::Machine;
use crate::render::cli::Scheme;
use crate::render::RenderSettings;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;

/// The experiments.
#[derive(Clone, Debug, clap::Subcommand)]
pub enum ReproduceCommand {
    /// Table 1 and Figure 1: every scene with an empty cache, TRA on 1 thread and each parallel
    /// scheme at each thread count, several runs each (medians). Writes table1.md, table1.csv
    /// and figure1.png.
    Table1(Table1Args),
    /// Figures 2 and 3: the 360° orbit reusing the cache across frames, per scheme. Writes
    /// animation-<scene>.csv, .md and .png.
    Animation(AnimationArgs),
}

/// Arguments of `wfic reproduce table1`.
#[derive(Clone, Debug, clap::Args)]
pub struct Table1Args {
    /// Output directory.
    #[arg(long)]
    pub out_dir: PathBuf,
    /// Smaller images and fewer runs (160x160, 3 runs): a few minutes on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Scenes (default: all five).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Parallel schemes (default: lck, lck-rw, lw, wf, wf-discard; TRA always runs on 1 thread).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub schemes: Vec<Scheme>,
    /// Thread counts of the parallel schemes.
    #[arg(long, value_delimiter = ',', default_value = "2,4,8")]
    pub threads: Vec<usize>,
    /// Timed runs per column (default: 3 with --quick, 5 without).
    #[arg(long)]
    pub runs: Option<usize>,
    /// Image width (default: 160 with --quick, 320 without).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default: as the width).
    #[arg(long)]
    pub height: Option<u32>,
    /// Hemisphere rays per irradiance record.
    #[arg(long, default_value_t = 512)]
    pub rays_per_record: u32,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Arguments of `wfic reproduce animation`.
#[derive(Clone, Debug, clap::Args)]
pub struct AnimationArgs {
    /// Built-in scene.
    #[arg(long, default_value = "cornell")]
    pub scene: String,
    /// Frames over one full orbit.
    #[arg(long, default_value_t = 100)]
    pub frames: usize,
    /// Threads of the parallel schemes (TRA runs on 1).
    #[arg(long, default_value_t = 8)]
    pub threads: usize,
    /// Schemes (default: tra, lck, lck-rw, lw, wf, wf-discard).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub schemes: Vec<Scheme>,
    /// Image width.
    #[arg(long, default_value_t = 160)]
    pub width: u32,
    /// Image height (default: as the width).
    #[arg(long)]
    pub height: Option<u32>,
    /// Hemisphere rays per irradiance record.
    #[arg(long, default_value_t = 512)]
    pub rays_per_record: u32,
    /// Output directory.
    #[arg(long)]
    pub out_dir: PathBuf,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

fn bar(len: usize, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(len as u64), ProgressDrawTarget::stderr());
    if let Ok(style) = ProgressStyle::with_template(
        "[{elapsed_precise}] {wide_bar} {pos}/{len} frames (eta {eta}) {msg}",
    ) {
        bar.set_style(style);
    }
    bar
}

/// The command line, for the output's provenance.
fn command_line() -> String {
    let args: Vec<String> = std::env::args().collect();
    let mut words = vec!["wfic".to_owned()];
    words.extend(args.into_iter().skip(1));
    words.join(" ")
}

fn size(width: u32, height: Option<u32>) -> Result<(u32, u32), String> {
    let h = height.unwrap_or(width);
    if width == 0 || h == 0 {
        return Err(format!("image size {width}x{h} is empty"));
    }
    Ok((width, h))
}

fn check_rays(rays: u32) -> Result<(), String> {
    if rays == 0 {
        return Err("--rays-per-record must be at least 1".to_owned());
    }
    Ok(())
}

/// Runs `wfic reproduce ...`.
pub fn run(command: ReproduceCommand) -> Result<(), String> {
    let machine = Machine::detect();
    match command {
        ReproduceCommand::Table1(a) => {
            check_rays(a.rays_per_record)?;
            let (w, h) = size(a.width.unwrap_or(if a.quick { 160 } else { 320 }), a.height)?;
            let runs = a.runs.unwrap_or(if a.quick { 3 } else { 5 });
            let mut config = Table1Config::paper(w, h, runs);
            config.settings = RenderSettings::new(w, h).rays_per_record(a.rays_per_record);
            if !a.scenes.is_empty() {
                config.scenes = a.scenes.clone();
            }
            if !a.schemes.is_empty() {
                config.schemes = a.schemes.clone();
            }
            config.threads = a.threads.clone();
            let mut threads = vec![1];
            threads.extend(&config.threads);
            println!("{}", machine.banner(&threads));
            let pb = bar(config.total_frames(), a.quiet);
            let mut first = true;
            let t = table1::run(&config, &machine, &mut |label| {
                if !first {
                    pb.inc(1);
                }
                first = false;
                pb.set_message(label.to_owned());
            })?;
            pb.finish_and_clear();
            t.write(&a.out_dir, &command_line())?;
            for c in t.checks() {
                println!(
                    "{:<11} {:<58} {:<4} {}",
                    c.scene,
                    c.claim,
                    if c.holds { "yes" } else { "NO" },
                    c.detail
                );
            }
            println!(
                "wrote {}/table1.md, table1.csv, figure1.png ({:.0} s)",
                a.out_dir.display(),
                t.seconds
            );
            Ok(())
        }
        ReproduceCommand::Animation(a) => {
            check_rays(a.rays_per_record)?;
            let (w, h) = size(a.width, a.height)?;
            let schemes = if a.schemes.is_empty() {
                Scheme::CACHED.to_vec()
            } else {
                a.schemes.clone()
            };
            let config = AnimationConfig {
                scene: a.scene.clone(),
                frames: a.frames,
                threads: a.threads,
                schemes,
                settings: RenderSettings::new(w, h).rays_per_record(a.rays_per_record),
            };
            let threads: Vec<usize> = config
                .schemes
                .iter()
                .map(|s| config.threads_of(*s))
                .collect();
            println!("{}", machine.banner(&threads));
            let pb = bar(config.frames * config.schemes.len(), a.quiet);
            let mut first = true;
            let anim = animation::run(&config, &machine, &mut |label| {
                if !first {
                    pb.inc(1);
                }
                first = false;
                pb.set_message(label.to_owned());
            })?;
            pb.finish_and_clear();
            anim.write(&a.out_dir, &command_line())?;
            for o in &anim.orbits {
                println!(
                    "{:<11} {:>2} threads: total {:>7.2} s, {:>7} IC samples",
                    o.scheme.name(),
                    o.threads,
                    o.total_seconds(),
                    o.total_samples()
                );
            }
            println!(
                "wrote {}/animation-{}.csv, .md, .png",
                a.out_dir.display(),
                a.scene
            );
            Ok(())
        }
    }
}
