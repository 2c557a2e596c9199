//! The subcommands.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::process::ExitCode;
use wfic::cache::IrradianceCache;
use wfic::cache::{CacheJob, Scheme};
use wfic::research::workload::{run_synthetic, Room, SyntheticFrame, SyntheticResult};

#[derive(Parser)]
#[command(
    name = "wfic",
    version,
    about = "Shared irradiance caches: TRA, LCK, LW and wait-free WF"
)]
struct Cli {
    /// Check every argument, and that the machine can start the threads and hold the frame,
    /// then stop before any work.
    #[arg(long, global = true)]
    dry_run: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render one frame of a built-in scene or an OBJ file with one cache scheme (PNG, PFM,
    /// record overlay, JSON statistics).
    Render(crate::render_cli::RenderArgs),
    /// Reproduce the paper's experiments: Table 1 with Figure 1, and the orbit animations
    /// (Figures 2 and 3).
    Reproduce {
        #[command(subcommand)]
        what: crate::reproduce_cli::ReproduceCommand,
    },
    /// Compare wfic with another renderer on the same scene (`compare radiance`).
    Compare {
        #[command(subcommand)]
        what: crate::reproduce_cli::CompareCommand,
    },
    /// List the built-in scenes: triangles, lights, whether each is the real model or a
    /// stand-in, and where it comes from.
    Scenes,
    /// Fill every cache scheme from several threads with a synthetic renderer-like workload and
    /// print what each did (time, samples, hits, sharing, overheads).
    Demo(DemoArgs),
}

#[derive(clap::Args)]
struct DemoArgs {
    /// Schemes to run (default: all cached ones; `none` computes every point, for comparison).
    #[arg(long, value_parser = crate::render_cli::scheme_parser(), value_delimiter = ',')]
    scheme: Vec<Scheme>,
    /// Worker threads (TRA always runs on one).
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Shading points per frame.
    #[arg(long, default_value_t = 400_000)]
    points: u64,
    /// Frames (the cache is kept across frames, as in the paper's animations).
    #[arg(long, default_value_t = 2)]
    frames: usize,
    /// Ward's accuracy a.
    #[arg(long, default_value_t = 0.3)]
    accuracy: f32,
    /// Busy-work iterations standing in for one hemisphere sampling.
    #[arg(long, default_value_t = 20_000)]
    work: u32,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// The command line as clap sees it: the derived arguments, each numeric option parsing through
/// its range ([`crate::bounds`]).
pub fn command() -> clap::Command {
    crate::bounds::apply(Cli::command())
}

pub fn main() -> ExitCode {
    let cli = Cli::from_arg_matches(&command().get_matches()).unwrap_or_else(|e| e.exit());
    let dry = cli.dry_run;
    let result = match cli.command {
        Command::Demo(args) => demo(&args, dry),
        Command::Reproduce { what } => crate::reproduce_cli::run(what, dry),
        Command::Compare { what } => crate::reproduce_cli::run_compare(what, dry),
        Command::Scenes => list_scenes(),
        Command::Render(args) => {
            let run = if dry {
                crate::render_cli::prepare(&args).map(drop)
            } else {
                crate::render_cli::run_render(args)
            };
            return match run {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    if !matches!(e, crate::render_cli::RenderError::Reported) {
                        eprintln!("error: {e}");
                    }
                    ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(1))
                }
            };
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::from(2)
        }
    }
}

/// `wfic scenes`: builds each built-in scene and prints what it is.
fn list_scenes() -> Result<(), String> {
    use wfic_render::scenes;
    println!(
        "{:<11} {:>9} {:>7} {:<9} origin",
        "scene", "triangles", "lights", "source"
    );
    for info in scenes::INFO {
        let scene = scenes::by_name(info.name)
            .expect("every INFO entry is a built-in scene")
            .map_err(|e| format!("{}: {e}", info.name))?;
        println!(
            "{:<11} {:>9} {:>7} {:<9} {}",
            info.name,
            scene.triangle_count(),
            scene.light_count(),
            info.source.name(),
            info.origin
        );
    }
    println!("(scenes/README.md: each model's origin, credit or licence, and its conversion)");
    Ok(())
}

fn demo(args: &DemoArgs, dry_run: bool) -> Result<(), String> {
    crate::bounds::check_resources(args.threads, None)?;
    if dry_run {
        return Ok(());
    }
    let schemes = if args.scheme.is_empty() {
        Scheme::CACHED.to_vec()
    } else {
        args.scheme.clone()
    };
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let room = Room { size: 10.0 };
    println!(
        "synthetic irradiance-cache workload: {} shading points x {} frames, accuracy {}, {} cores{}",
        args.points,
        args.frames,
        args.accuracy,
        cores,
        if args.threads > cores {
            format!(" ({} threads: OVERSUBSCRIBED, not scaling)", args.threads)
        } else {
            String::new()
        }
    );
    println!(
        "{:<11} {:>7} {:>5} {:>9} {:>9} {:>9} {:>8} {:>10} {:>9} {:>9}",
        "scheme",
        "threads",
        "frame",
        "seconds",
        "samples",
        "hits",
        "sharing",
        "lock-wait",
        "merge",
        "discarded"
    );
    for scheme in schemes {
        let threads = if scheme == Scheme::Tra {
            1
        } else {
            args.threads
        };
        let config = room.config(args.accuracy);
        let rows = scheme.build(
            config,
            Frames {
                room,
                threads,
                args,
            },
        );
        for (frame, r) in rows.iter().enumerate() {
            let w = &r.report.workers;
            println!(
                "{:<11} {:>7} {:>5} {:>9.3} {:>9} {:>9} {:>7.1}% {:>10.4} {:>9.4} {:>9}",
                if frame == 0 { scheme.name() } else { "" },
                threads,
                frame,
                r.wall.as_secs_f64(),
                w.stored + w.discarded,
                w.hits,
                100.0 * w.shared_hits as f64 / w.hits.max(1) as f64,
                w.lock_wait.as_secs_f64(),
                r.report.merge.as_secs_f64(),
                w.discarded
            );
        }
    }
    Ok(())
}

/// The demo's frames on one scheme's cache.
struct Frames<'a> {
    room: Room,
    threads: usize,
    args: &'a DemoArgs,
}

impl CacheJob for Frames<'_> {
    type Output = Vec<SyntheticResult>;
    fn run<C: IrradianceCache>(self, cache: C) -> Vec<SyntheticResult> {
        frames(cache, self.room, self.threads, self.args)
    }
}

fn frames<C: IrradianceCache>(
    mut cache: C,
    room: Room,
    threads: usize,
    args: &DemoArgs,
) -> Vec<SyntheticResult> {
    let total = args.points * args.frames as u64;
    let bar = ProgressBar::new(total);
    if args.quiet || !std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template("{prefix:>11} [{bar:40}] {pos}/{len} points ({eta})")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(cache.scheme().name());
    let mut out = Vec::new();
    for frame in 0..args.frames as u64 {
        let done = frame * args.points;
        let spec = SyntheticFrame {
            room,
            threads: u32::try_from(threads).expect("--threads is at most 1024"),
            points: args.points as usize,
            work_per_record: args.work,
            seed: 0x1234 + frame,
        };
        out.push(run_synthetic(&mut cache, &spec, &|finished| {
            bar.set_position(done + finished as u64);
        }));
    }
    bar.finish_and_clear();
    out
}
