//! `wfic reproduce ...` and `wfic compare ...`: arguments, progress, output.

use crate::animation::{self, AnimationConfig};
use crate::bounds::check_resources;
use crate::deterministic::{self, DeterministicConfig};
use crate::distributed::{self, DistributedConfig};
use crate::dynamic::{self, DynamicConfig};
use crate::harness::measure::Progress;
use crate::harness::provenance::command_line;
use crate::harness::{Check, Machine};
use crate::radiance::{self, RadianceConfig};
use crate::table1::{self, Table1Config};
use std::path::PathBuf;
use wfic::cache::Scheme;
use wfic_render::{limits, RenderSettings};

/// Primary rays per pixel in the experiments.
pub const SPP: u32 = 4;
/// Light samples per primary hit in the experiments: with [`SPP`], 8 shadow rays per pixel.
pub const LIGHT_SAMPLES: u32 = 2;

/// The experiments.
#[derive(Clone, Debug, clap::Subcommand)]
pub enum ReproduceCommand {
    /// Table 1 and Figure 1: every scene, empty cache, each scheme and thread count (table1.md,
    /// .csv, figure1.png, .svg).
    Table1(Table1Args),
    /// Figures 2 and 3: the 360° orbit reusing the cache, per scheme (animation-SCENE.*).
    Animation(AnimationArgs),
    /// A scene that moves: removal against a fresh and a stale cache, per scheme (dynamic.md,
    /// .csv, .png, .svg, dynamic-strip.png).
    Dynamic(DynamicArgs),
    /// One frame over MPI ranks against one process and Radiance's `rtrace -n P` (needs
    /// `--features mpi` and OpenMPI; distributed.md, .csv, .png, .svg).
    Distributed(DistributedArgs),
    /// Deterministic frames against ordinary WF frames: time, records, error, and their hashes
    /// at every thread count (deterministic.md, .csv).
    Deterministic(DeterministicArgs),
    /// The direct-light estimators side by side: variance x time at the primary hits, the
    /// seed-to-seed noise and frame time of default renders (direct.md, .csv, direct-crops.png).
    Direct(DirectArgs),
    /// A frame's cost against the image side (128 to 4 096) and the accuracy, on the Cornell box
    /// and Sponza: time a pixel, records, lookups, peak memory (scaling.md, .csv, .png, .svg).
    Scaling(ScalingArgs),
}

/// Arguments of `wfic reproduce scaling`.
#[derive(Clone, Debug, clap::Args)]
pub struct ScalingArgs {
    /// Sides 64 to 256 and three accuracies at 128: a minute on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Scenes (default: cornell,sponza).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// Output.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Arguments of `wfic reproduce direct`.
#[derive(Clone, Debug, clap::Args)]
pub struct DirectArgs {
    /// 24 x 24 hits, 4 estimates each, 96 x 96 renders: a minute on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Scenes (default: all five).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// Output.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Arguments of `wfic reproduce deterministic`.
#[derive(Clone, Debug, clap::Args)]
pub struct DeterministicArgs {
    /// 128x128, 1 primary ray, at most 128 rays a record, 3 seeds: a few minutes on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Scenes (default: all five).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// Thread counts.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    pub threads: Vec<usize>,
    /// Seeds (runs) per scene and thread count (default 3 with --quick, 7 without).
    #[arg(long)]
    pub runs: Option<usize>,
    /// The brute-force references are traced at one pixel in STRIDE x STRIDE.
    #[arg(long, default_value_t = 2)]
    pub stride: u32,
    /// Rank counts of `mpirun` jobs, one thread a rank (default: 2 when wfic is built with the
    /// `mpi` feature, none without).
    #[arg(long, value_delimiter = ',')]
    pub ranks: Option<Vec<usize>>,
    /// Image size (default 256, quick 128).
    #[command(flatten)]
    pub size: SizeArgs,
    /// Sampling.
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// Output.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Where the results go, and whether progress is shown: every experiment's.
#[derive(Clone, Debug, clap::Args)]
pub struct OutputArgs {
    /// Output directory.
    #[arg(long)]
    pub out_dir: PathBuf,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// The image size options.
#[derive(Clone, Debug, clap::Args)]
pub struct SizeArgs {
    /// Image width (default: the experiment's, smaller with --quick).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default: as the width).
    #[arg(long)]
    pub height: Option<u32>,
}

impl SizeArgs {
    /// The size, `width` standing in for a missing width, each side and the pixels within
    /// [`limits::WIDTH`], [`limits::HEIGHT`] and [`limits::PIXELS`].
    pub fn get(&self, width: u32) -> Result<(u32, u32), String> {
        let w = self.width.unwrap_or(width);
        let h = self.height.unwrap_or(w);
        let range = |e: limits::OutOfRange| e.for_option();
        limits::WIDTH.check(w).map_err(range)?;
        limits::HEIGHT.check(h).map_err(range)?;
        RenderSettings::new(w, h).validate().map_err(range)?;
        Ok((w, h))
    }
}

/// Arguments of `wfic reproduce distributed`.
#[derive(Clone, Debug, clap::Args)]
pub struct DistributedArgs {
    /// The scene.
    #[arg(long, default_value = distributed::SCENE)]
    pub scene: String,
    /// A smoke run: 96 x 96, 128 rays a record, one run a job, three batch sizes.
    #[arg(long)]
    pub quick: bool,
    /// Image size (default 256, quick 96).
    #[command(flatten)]
    pub size: SizeArgs,
    /// Hemisphere rays per record (default 512, quick 128).
    #[arg(long)]
    pub rays_per_record: Option<u32>,
    /// Ward's accuracy `a`, for wfic and Radiance (`-aa`).
    #[arg(long, default_value_t = 0.15)]
    pub accuracy: f32,
    /// Light samples per primary hit.
    #[arg(long, default_value_t = 8)]
    pub light_samples: u32,
    /// Runs per job, each job reporting its median (default 3, quick 1).
    #[arg(long)]
    pub runs: Option<usize>,
    /// The batch sizes of the sweep (default 4,16,64,256,1024,4096; quick 16,256,4096).
    #[arg(long, value_delimiter = ',')]
    pub batches: Option<Vec<usize>>,
    /// The main jobs' batch size.
    #[arg(long, default_value_t = 256)]
    pub batch_records: usize,
    /// The main jobs' batch timer (ms).
    #[arg(long, default_value_t = 20)]
    pub batch_ms: u64,
    /// Skip Radiance (otherwise `rtrace` must be found: `pip install pyradiance`).
    #[arg(long)]
    pub no_radiance: bool,
    /// Frames of the orbit animation (default 12, quick 4; 0 or 1: none).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Output.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Arguments of `wfic reproduce dynamic`.
#[derive(Clone, Debug, clap::Args)]
pub struct DynamicArgs {
    /// The moving scene.
    #[arg(long, default_value = dynamic::SCENE)]
    pub scene: String,
    /// A smoke run: 64 x 64, 8 frames, 1 primary ray a pixel, 128 rays a record.
    #[arg(long)]
    pub quick: bool,
    /// Frames over the block's slide (default 24, quick 8).
    #[arg(long)]
    pub frames: Option<usize>,
    /// Threads of the parallel schemes (TRA runs on 1).
    #[arg(long, default_value_t = 2)]
    pub threads: usize,
    /// Passes of the removal mode per scheme, frame times their median (default 3, quick 1).
    #[arg(long)]
    pub passes: Option<usize>,
    /// Removal tolerances swept with WF, in multiples of a (default 0.5,2,4,8; quick 4).
    #[arg(long, value_delimiter = ',')]
    pub sweep: Option<Vec<f32>>,
    /// Schemes (default: tra, lck, lw, wf).
    #[arg(long, value_parser = crate::render_cli::scheme_parser(), value_delimiter = ',')]
    pub schemes: Option<Vec<Scheme>>,
    /// Image size (default 128, quick 64).
    #[command(flatten)]
    pub size: SizeArgs,
    /// Sampling (--quick: 1 primary ray, at most 128 rays a record).
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// Output.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// The sampling options the experiments share.
#[derive(Clone, Debug, clap::Args)]
pub struct SamplingArgs {
    /// Hemisphere rays per irradiance record.
    #[arg(long, default_value_t = 512)]
    pub rays_per_record: u32,
    /// Primary rays per pixel (each primary hit makes its own cache lookup).
    #[arg(long, default_value_t = SPP)]
    pub spp: u32,
    /// Light samples (shadow rays) per primary hit.
    #[arg(long, default_value_t = LIGHT_SAMPLES)]
    pub light_samples: u32,
}

impl SamplingArgs {
    /// Render settings for a `width` x `height` image, checked against their ranges
    /// ([`RenderSettings::validate`]).
    pub fn settings(&self, (width, height): (u32, u32)) -> Result<RenderSettings, String> {
        let settings = RenderSettings::new(width, height)
            .rays_per_record(self.rays_per_record)
            .pixel_samples(self.spp)
            .light_samples(self.light_samples);
        settings.validate().map_err(|e| e.for_option())?;
        Ok(settings)
    }
}

/// Arguments of `wfic reproduce table1`.
#[derive(Clone, Debug, clap::Args)]
pub struct Table1Args {
    /// 160x160, 3 runs, 11 for the compared columns: a few minutes on 2 cores.
    #[arg(long)]
    pub quick: bool,
    /// Scenes (default: all five).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Option<Vec<String>>,
    /// Parallel schemes (default: lck, lck-rw, lw, wf, wf-discard; TRA always runs on 1 thread).
    #[arg(long, value_parser = crate::render_cli::scheme_parser(), value_delimiter = ',')]
    pub schemes: Option<Vec<Scheme>>,
    /// Thread counts of the parallel schemes.
    #[arg(long, value_delimiter = ',', default_value = "2,4,8")]
    pub threads: Vec<usize>,
    /// Timed runs per column (default: 3 with --quick, 5 without).
    #[arg(long)]
    pub runs: Option<usize>,
    /// Runs of TRA and of LCK, LW, WF at 2 threads (default 11 quick, 15; at least --runs).
    #[arg(long)]
    pub paired_runs: Option<usize>,
    /// Image size (default 320, quick 160).
    #[command(flatten)]
    pub size: SizeArgs,
    /// Sampling.
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// Render the machine control (WF on 1 thread, two TRA frames at once) each round (default
    /// true).
    #[arg(long)]
    pub controls: Option<bool>,
    /// Output.
    #[command(flatten)]
    pub output: OutputArgs,
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
    #[arg(long, value_parser = crate::render_cli::scheme_parser(), value_delimiter = ',')]
    pub schemes: Option<Vec<Scheme>>,
    /// Image size (default 160).
    #[command(flatten)]
    pub size: SizeArgs,
    /// Sampling.
    #[command(flatten)]
    pub sampling: SamplingArgs,
    /// Output.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// `value` when given, else `quick` or `full` as `--quick` says.
fn or_quick<T>(value: Option<T>, quick: bool, (q, full): (T, T)) -> T {
    value.unwrap_or(if quick { q } else { full })
}

/// Prints the checks as `yes claim: figures` lines.
pub(crate) fn print_checks(checks: &[Check]) {
    for c in checks {
        println!("{:<4} {}: {}", c.verdict.plain(), c.claim, c.detail);
    }
}

/// The most threads of `counts` (1 when empty).
fn most(counts: &[usize]) -> usize {
    counts.iter().copied().max().unwrap_or(1)
}

fn table1(a: Table1Args, machine: &Machine, dry_run: bool) -> Result<(), String> {
    let (w, h) = a.size.get(if a.quick { 160 } else { 320 })?;
    let runs = or_quick(a.runs, a.quick, (3, 5));
    let paper = Table1Config::paper(w, h, runs);
    let config = Table1Config {
        scenes: a.scenes.unwrap_or(paper.scenes),
        schemes: a.schemes.unwrap_or(paper.schemes),
        threads: a.threads,
        // An explicit --paired-runs below --runs is refused by `table1::run`; the default never is.
        paired_runs: a
            .paired_runs
            .unwrap_or(runs.max(if a.quick { 11 } else { 15 })),
        settings: a.sampling.settings((w, h))?,
        controls: a.controls.unwrap_or(true),
        ..paper
    };
    config.validate()?;
    check_resources(most(&config.threads), Some((w, h)))?;
    if dry_run {
        return Ok(());
    }
    println!("{}", machine.banner(&config.thread_counts()));
    let progress = Progress::new(config.total_frames(), a.output.quiet);
    let t = progress.run(|p| table1::run(&config, machine, p))?;
    t.write(&a.output.out_dir, &command_line())?;
    for c in t.checks() {
        println!(
            "{:<11} {:<58} {:<4} {}",
            c.scene,
            c.claim,
            c.verdict.plain(),
            c.detail
        );
    }
    println!(
        "wrote {}/table1.md, table1.csv, figure1.png, figure1.svg ({:.0} s)",
        a.output.out_dir.display(),
        t.seconds
    );
    Ok(())
}

fn distributed(a: DistributedArgs, machine: &Machine, dry_run: bool) -> Result<(), String> {
    let (w, h) = a.size.get(if a.quick { 96 } else { 256 })?;
    let rays = or_quick(a.rays_per_record, a.quick, (128, 512));
    let settings = RenderSettings::new(w, h)
        .rays_per_record(rays)
        .light_samples(a.light_samples)
        .accuracy(a.accuracy)
        .quiet(true);
    settings.validate().map_err(|e| e.for_option())?;
    let config = DistributedConfig {
        scene: a.scene.clone(),
        settings,
        runs: or_quick(a.runs, a.quick, (1, 3)),
        batches: or_quick(
            a.batches,
            a.quick,
            (vec![16, 256, 4096], vec![4, 16, 64, 256, 1024, 4096]),
        ),
        batch_ms: a.batch_ms,
        batch_records: a.batch_records,
        stride: 2,
        radiance_resolution: 128,
        radiance: !a.no_radiance,
        animation_frames: or_quick(a.frames, a.quick, (4, 12)),
    };
    config.validate()?;
    check_resources(1, Some((w, h)))?;
    if dry_run {
        return Ok(());
    }
    println!("{}", machine.banner_with_ranks(&[], &config.rank_counts()));
    let quiet = a.output.quiet;
    let progress = Progress::new(config.jobs(), quiet).echo(quiet);
    let start = std::time::Instant::now();
    let out_dir = &a.output.out_dir;
    let d = progress.run(|p| distributed::run(&config, machine, out_dir, p))?;
    d.write(out_dir, &command_line())?;
    print_checks(&d.checks());
    println!(
        "wrote {}/distributed.md, distributed.csv, distributed.png, distributed.svg ({:.0} s)",
        out_dir.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn dynamic(a: DynamicArgs, machine: &Machine, dry_run: bool) -> Result<(), String> {
    let (w, h) = a.size.get(if a.quick { 64 } else { 128 })?;
    let mut sampling = a.sampling.clone();
    if a.quick {
        sampling.spp = 1;
        sampling.rays_per_record = sampling.rays_per_record.min(128);
    }
    let config = DynamicConfig {
        scene: a.scene.clone(),
        frames: or_quick(a.frames, a.quick, (8, 24)),
        threads: a.threads,
        schemes: a
            .schemes
            .unwrap_or(vec![Scheme::Tra, Scheme::Lck, Scheme::Lw, Scheme::Wf]),
        settings: sampling.settings((w, h))?.quiet(true),
        passes: or_quick(a.passes, a.quick, (1, 3)),
        sweep: or_quick(a.sweep, a.quick, (vec![4.0], vec![0.5, 2.0, 4.0, 8.0])),
    };
    config.validate()?;
    check_resources(config.threads, Some((w, h)))?;
    if dry_run {
        return Ok(());
    }
    println!("{}", machine.banner(&config.thread_counts()));
    let progress = Progress::new(config.total_frames(), a.output.quiet);
    let start = std::time::Instant::now();
    let d = progress.run(|p| dynamic::run(&config, machine, p))?;
    d.write(&a.output.out_dir, &command_line())?;
    print_checks(&d.checks());
    println!(
        "wrote {}/dynamic.md, dynamic.csv, dynamic.png, dynamic.svg, dynamic-strip.png ({:.0} s)",
        a.output.out_dir.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn animation(a: AnimationArgs, machine: &Machine, dry_run: bool) -> Result<(), String> {
    let (w, h) = a.size.get(160)?;
    let config = AnimationConfig {
        scene: a.scene.clone(),
        frames: a.frames,
        threads: a.threads,
        schemes: a.schemes.unwrap_or(Scheme::CACHED.to_vec()),
        settings: a.sampling.settings((w, h))?,
    };
    config.validate()?;
    check_resources(config.threads, Some((w, h)))?;
    if dry_run {
        return Ok(());
    }
    println!("{}", machine.banner(&config.thread_counts()));
    let frames = config.frames * config.schemes.len();
    let progress = Progress::new(frames, a.output.quiet);
    let anim = progress.run(|p| animation::run(&config, machine, p))?;
    anim.write(&a.output.out_dir, &command_line())?;
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
        "wrote {}/animation-{}.csv, .md, .png, .svg",
        a.output.out_dir.display(),
        a.scene
    );
    Ok(())
}

fn deterministic(a: DeterministicArgs, machine: &Machine, dry_run: bool) -> Result<(), String> {
    let (w, h) = a.size.get(if a.quick { 128 } else { 256 })?;
    let mut sampling = a.sampling.clone();
    if a.quick {
        sampling.spp = 1;
        sampling.rays_per_record = sampling.rays_per_record.min(128);
    }
    let config = DeterministicConfig {
        scenes: a
            .scenes
            .unwrap_or(wfic_render::scenes::NAMES.map(str::to_owned).to_vec()),
        threads: a.threads,
        runs: or_quick(a.runs, a.quick, (3, 7)),
        settings: sampling.settings((w, h))?,
        stride: a.stride,
        ranks: a.ranks.unwrap_or(if cfg!(feature = "mpi") {
            vec![2]
        } else {
            Vec::new()
        }),
    };
    config.validate()?;
    check_resources(most(&config.threads), Some((w, h)))?;
    if dry_run {
        return Ok(());
    }
    let ranks: Vec<(usize, usize)> = config.ranks.iter().map(|&r| (r, 1)).collect();
    println!("{}", machine.banner_with_ranks(&config.threads, &ranks));
    let progress = Progress::new(config.frames(), a.output.quiet).echo(a.output.quiet);
    let start = std::time::Instant::now();
    let d = progress.run(|p| deterministic::run(&config, machine, p))?;
    d.write(&a.output.out_dir, &command_line())?;
    print_checks(&d.checks());
    println!(
        "wrote {}/deterministic.md, deterministic.csv ({:.0} s)",
        a.output.out_dir.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

fn direct(a: DirectArgs, dry_run: bool) -> Result<(), String> {
    let scenes = a
        .scenes
        .unwrap_or(wfic_render::scenes::NAMES.map(str::to_owned).to_vec());
    let config = if a.quick {
        crate::direct::DirectConfig::quick(scenes)
    } else {
        crate::direct::DirectConfig::full(scenes)
    };
    check_resources(1, Some((config.size, config.size)))?;
    if dry_run {
        return Ok(());
    }
    let progress = Progress::new(config.scenes.len() * 3, a.output.quiet).echo(a.output.quiet);
    let start = std::time::Instant::now();
    let d = progress.run(|p| crate::direct::run(&config, p))?;
    d.write(&a.output.out_dir, &command_line())?;
    print_checks(&d.checks());
    println!(
        "wrote {}/direct.md, direct.csv, direct-crops.png ({:.0} s)",
        a.output.out_dir.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Runs `wfic reproduce ...`; with `dry_run`, only checks its arguments and resources.
pub fn run(command: ReproduceCommand, dry_run: bool) -> Result<(), String> {
    let machine = Machine::detect();
    match command {
        ReproduceCommand::Table1(a) => table1(a, &machine, dry_run),
        ReproduceCommand::Distributed(a) => distributed(a, &machine, dry_run),
        ReproduceCommand::Dynamic(a) => dynamic(a, &machine, dry_run),
        ReproduceCommand::Animation(a) => animation(a, &machine, dry_run),
        ReproduceCommand::Deterministic(a) => deterministic(a, &machine, dry_run),
        ReproduceCommand::Direct(a) => direct(a, dry_run),
        ReproduceCommand::Scaling(a) => crate::scaling::reproduce(a, dry_run),
    }
}

/// What `wfic compare` compares wfic with.
#[derive(Clone, Debug, clap::Subcommand)]
pub enum CompareCommand {
    /// Radiance (`rtrace -ab 1`) beside wfic at matched settings, and the time ratio at equal
    /// error (radiance.md, .csv, SCENE-side-by-side.png; needs `pip install pyradiance`).
    Radiance(RadianceArgs),
}

/// Arguments of `wfic compare radiance`.
#[derive(Clone, Debug, clap::Args)]
pub struct RadianceArgs {
    /// Built-in scenes, comma-separated (`all`: every one).
    #[arg(long, value_delimiter = ',', required = true)]
    pub scene: Vec<String>,
    /// A smoke run: 96 x 96, 128 rays per record, a short sweep.
    #[arg(long)]
    pub quick: bool,
    /// Output folder.
    #[arg(long, default_value = "results/radiance")]
    pub out_dir: std::path::PathBuf,
    /// Image size (default 256, quick 96).
    #[command(flatten)]
    pub size: SizeArgs,
    /// Rays per record, `-ad` (default 512, quick 128).
    #[arg(long)]
    pub rays_per_record: Option<u32>,
    /// Ward's accuracy, `-aa`.
    #[arg(long)]
    pub accuracy: Option<f32>,
    /// Radiance's ambient resolution, `-ar`.
    #[arg(long)]
    pub resolution: Option<u32>,
    /// Keep the exported scene, rays and ambient files (DIR/work-SCENE/).
    #[arg(long)]
    pub keep_work: bool,
    /// Renders of every measured setting: median time, mean error (default 3, quick 1).
    #[arg(long)]
    pub repeats: Option<u32>,
    /// A copy of Radiance's source tree (`LBNL-ETA/Radiance`, branch `auxiliary`): the desk and
    /// the office are then also rendered by Radiance from its own original model
    /// (`obj/office`), as published, in rows of their own.
    #[arg(long, value_name = "DIR")]
    pub radiance_tree: Option<PathBuf>,
}

/// Sets `field` to `value` when given and inside `limit`.
fn set_within(
    field: &mut u32,
    value: Option<u32>,
    limit: limits::Limit<u32>,
) -> Result<(), String> {
    if let Some(v) = value {
        *field = limit.check(v).map_err(|e| e.for_option())?;
    }
    Ok(())
}

/// The comparison's configuration from its arguments, refusing what cannot run.
fn radiance_config(a: &RadianceArgs) -> Result<RadianceConfig, String> {
    let names = wfic_render::scenes::NAMES;
    let scenes: Vec<String> = if a.scene.iter().any(|s| s == "all") {
        names.iter().map(|s| s.to_string()).collect()
    } else {
        a.scene.clone()
    };
    if let Some(s) = scenes
        .iter()
        .find(|s| wfic_render::scenes::info(s).is_none())
    {
        return Err(format!(
            "unknown scene `{s}` (expected one of: {}, or all)",
            names.join(", ")
        ));
    }
    let mut config = if a.quick {
        RadianceConfig::quick(scenes)
    } else {
        RadianceConfig::full(scenes)
    };
    if a.size.width.is_some() || a.size.height.is_some() {
        config.size = a.size.get(config.size.0)?;
    }
    set_within(
        &mut config.rays,
        a.rays_per_record,
        crate::bounds::RADIANCE_RAYS,
    )?;
    if let Some(acc) = a.accuracy {
        config.accuracy = limits::ACCURACY.check(acc).map_err(|e| e.for_option())?;
    }
    set_within(
        &mut config.resolution,
        a.resolution,
        crate::bounds::RESOLUTION,
    )?;
    config.keep_work = a.keep_work;
    config.radiance_tree.clone_from(&a.radiance_tree);
    set_within(&mut config.repeats, a.repeats, crate::bounds::REPEATS)?;
    Ok(config)
}

/// Runs `wfic compare ...`; with `dry_run`, only checks its arguments and resources.
pub fn run_compare(command: CompareCommand, dry_run: bool) -> Result<(), String> {
    match command {
        CompareCommand::Radiance(a) => {
            let config = radiance_config(&a)?;
            // wfic renders at 1 and 2 threads.
            check_resources(2, Some(config.size))?;
            if dry_run {
                return Ok(());
            }
            radiance::run(&config, &a.out_dir, &command_line())
        }
    }
}
