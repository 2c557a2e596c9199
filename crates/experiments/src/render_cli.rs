//! `wfic render`: one frame of a built-in scene or an OBJ file with one cache scheme, written as
//! a tone-mapped PNG, a PFM, a record-position overlay and JSON statistics.
//!
//! `src/main.rs` wires the subcommand to [`run_render`]; [`RenderError::exit_code`] says how to
//! exit (2 for bad input, 1 for a failure while writing).

use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
use glam::Vec3;
use std::fmt;
use std::path::{Path, PathBuf};
use wfic::cache::Scheme;
use wfic_render::film::worker_colour;
use wfic_render::limits;
use wfic_render::settings::DirectSampling;
use wfic_render::{obj, render_with_scheme, scenes, Camera, Pool, RenderSettings, Scene};

/// `--scheme` parses from the cache layer's list: names, and descriptions for `--help`.
pub fn scheme_parser() -> impl TypedValueParser<Value = Scheme> {
    PossibleValuesParser::new(
        Scheme::ALL.map(|s| PossibleValue::new(s.name()).help(s.description())),
    )
    .map(|name| Scheme::from_name(&name).expect("the parser admits only the schemes' names"))
}

/// `--pool` parses from the renderer's pools.
pub fn pool_parser() -> impl TypedValueParser<Value = Pool> {
    let pools = [Pool::Scoped, Pool::Rayon];
    PossibleValuesParser::new(pools.map(|p| {
        PossibleValue::new(p.name()).help(match p {
            Pool::Scoped => "one scoped thread per worker, started for each frame",
            Pool::Rayon => "a rayon thread pool, one cache handle per pool thread",
        })
    }))
    .map(move |name| {
        pools
            .into_iter()
            .find(|p| p.name() == name)
            .expect("the parser admits only the pools' names")
    })
}

/// A point `x,y,z`, each coordinate within [`limits::COORDINATE`].
/// `--direct` parses from the renderer's estimators.
pub fn direct_parser() -> impl TypedValueParser<Value = DirectSampling> {
    PossibleValuesParser::new(["bounds", "power-over-distance"]).map(|name| match name.as_str() {
        "bounds" => DirectSampling::Bounds,
        _ => DirectSampling::PowerOverDistance,
    })
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    crate::bounds::parse_point(s, limits::COORDINATE)
}

/// Arguments of `wfic render`.
#[derive(Clone, Debug, clap::Args)]
pub struct RenderArgs {
    /// Built-in scene: cornell, desk, conference, office or sponza.
    #[arg(long, default_value = "cornell", conflicts_with = "obj")]
    pub scene: String,
    /// Render this OBJ file (with its MTL: `Kd` diffuse colour, `Ke` emission) instead of a
    /// built-in scene.
    #[arg(long, value_name = "FILE")]
    pub obj: Option<PathBuf>,
    /// Cache scheme (`none`: the indirect term at every pixel, no cache).
    #[arg(long, value_parser = scheme_parser(), default_value = "wf")]
    pub scheme: Scheme,
    /// Worker threads.
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Where the workers run.
    #[arg(long, value_parser = pool_parser(), default_value = "threads")]
    pub pool: Pool,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Ward's accuracy `a` (smaller: more records).
    #[arg(long, default_value_t = 0.25)]
    pub accuracy: f32,
    /// Hemisphere rays per irradiance record.
    #[arg(long, default_value_t = 512)]
    pub rays_per_record: u32,
    /// Smoothing `k` (at least 1): pixels interpolate every record valid at accuracy `k a`; new
    /// records are still computed only where none is valid at `a` (1: Ward's cache).
    #[arg(long, default_value_t = 1.0)]
    pub smoothing: f32,
    /// Light samples (shadow rays) per primary hit for direct light.
    #[arg(long, default_value_t = 16)]
    pub light_samples: u32,
    /// Primary rays per pixel (stratified jitter; each hit makes its own cache lookup).
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    /// How direct light is sampled: `bounds` (every emitter that can reach a point sampled on
    /// its own when the light samples allow, chosen by an importance with both cosines, bulbs
    /// by cone) or `power-over-distance` (the earlier estimator, kept as the baseline).
    #[arg(long, value_parser = direct_parser(), default_value = "bounds")]
    pub direct: DirectSampling,
    /// Seed of the per-pixel random streams.
    #[arg(long, default_value_t = 0x5eed)]
    pub seed: u64,
    /// Camera position `x,y,z` (default: the scene's camera).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Point the camera looks at `x,y,z` (default: the scene's).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<Vec3>,
    /// Use the scene's orbit camera at this time (turns: 0 and 1 are the same position) instead
    /// of its default camera; `--eye`/`--target` still override.
    #[arg(long, value_name = "T")]
    pub orbit: Option<f32>,
    /// Tone-mapped PNG output.
    #[arg(long, default_value = "render.png")]
    pub out: PathBuf,
    /// HDR output in Radiance's RGBE format (opened by standard HDR tools). Default: the PNG's
    /// name with `.hdr`.
    #[arg(long)]
    pub hdr: Option<PathBuf>,
    /// HDR output as a PFM (32-bit floats, what the accuracy checks read). Default: the PNG's
    /// name with `.pfm`.
    #[arg(long)]
    pub pfm: Option<PathBuf>,
    /// Record-position overlay (PNG). Default: the PNG's name with `-records.png`.
    #[arg(long)]
    pub records: Option<PathBuf>,
    /// Statistics as JSON.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Deterministic frames: the same image and records, bit for bit, at any --threads and
    /// --pool (pretrace passes, then tiles that use only earlier passes' records and their own,
    /// summed in record-id order; not with --scheme wf-discard, which drops records by the
    /// schedule).
    #[arg(long)]
    pub deterministic: bool,
    /// Render over MPI: run under `mpirun -np R`; the ranks split the tiles and exchange new
    /// records; rank 0 writes the outputs (needs the `mpi` feature; scheme `wf`). With
    /// --deterministic the tiles are dealt round robin and the records exchanged once a pass
    /// (--batch-records and --batch-ms do not apply): the image is the single process's, bit for
    /// bit, at any rank count.
    #[arg(long)]
    pub distributed: bool,
    /// With --distributed: a rank starts an exchange round once it has this many new records.
    #[arg(long, default_value_t = 256, requires = "distributed")]
    pub batch_records: usize,
    /// With --distributed: ... or this many milliseconds after its previous round.
    #[arg(long, default_value_t = 20, requires = "distributed")]
    pub batch_ms: u64,
    /// With --distributed: the ranks' caches share nothing (the baseline).
    #[arg(long, requires = "distributed")]
    pub no_share: bool,
    /// With --distributed: render this many frames of the scene's orbit camera (frame i at time
    /// i / N), each rank keeping its cache across the frames; outputs get `-000`, `-001`, ...
    /// before their extension, and the statistics hold one entry a frame.
    #[arg(long, default_value_t = 1, requires = "distributed")]
    pub frames: usize,
    /// With --distributed, for the failure tests: this rank fails after its first tile.
    #[arg(long, hide = true, requires = "distributed")]
    pub fail_rank: Option<u32>,
    /// With --fail-rank: the rank leaves the process (status 3) instead of panicking.
    #[arg(long, hide = true, requires = "fail_rank")]
    pub fail_exit: bool,
}

/// What went wrong in `wfic render`.
#[derive(Debug)]
pub enum RenderError {
    /// Bad input: unknown scene, zero threads or size, bad OBJ file, bad setting. Exit code 2.
    Usage(String),
    /// A failure while writing output. Exit code 1.
    Io(String),
    /// Bad input this process has printed already (a rank of an MPI job, which prints before it
    /// waits for the other ranks, so that no rank is killed before its message is out). Exit
    /// code 2.
    Reported,
}

impl RenderError {
    /// The process exit code for this error.
    pub fn exit_code(&self) -> i32 {
        match self {
            Self::Usage(_) | Self::Reported => 2,
            Self::Io(_) => 1,
        }
    }
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Usage(m) | Self::Io(m) => f.write_str(m),
            Self::Reported => f.write_str("(printed above)"),
        }
    }
}

impl std::error::Error for RenderError {}

fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "render".to_owned());
    path.with_file_name(format!("{stem}{suffix}"))
}

/// Loads the scene the arguments name.
pub fn load_scene(args: &RenderArgs) -> Result<Scene, RenderError> {
    let mut scene = match &args.obj {
        Some(file) => obj::load(file).map_err(|e| RenderError::Usage(e.to_string()))?,
        None => scenes::by_name(&args.scene)
            .ok_or_else(|| {
                RenderError::Usage(format!(
                    "unknown scene `{}` (expected one of: {})",
                    args.scene,
                    scenes::NAMES.join(", ")
                ))
            })?
            .map_err(|e| RenderError::Usage(e.to_string()))?,
    };
    if let Some(t) = args.orbit {
        limits::ORBIT
            .check(t)
            .map_err(|e| RenderError::Usage(e.for_option()))?;
        scene.set_camera(Camera::orbit(&scene, t));
    }
    if args.eye.is_some() || args.target.is_some() {
        let mut camera = scene.camera();
        camera.eye = args.eye.unwrap_or(camera.eye);
        camera.target = args.target.unwrap_or(camera.target);
        if (camera.target - camera.eye).length() <= 0.0 {
            return Err(RenderError::Usage("--eye and --target coincide".to_owned()));
        }
        scene.set_camera(camera);
    }
    Ok(scene)
}

/// Checks the arguments against their ranges ([`wfic_render::limits`]; the parser has already
/// done so for the command line's own) and builds the render settings.
pub fn settings_from(args: &RenderArgs) -> Result<RenderSettings, RenderError> {
    let usage = |m: String| Err(RenderError::Usage(m));
    let out_of_range = |e: limits::OutOfRange| RenderError::Usage(e.for_option());
    limits::THREADS.check(args.threads).map_err(out_of_range)?;
    if args.deterministic && args.no_share {
        return usage(
            "--deterministic cannot run with --no-share: its ranks exchange every pass's records, \
             which is what makes the image the single process's"
                .to_owned(),
        );
    }
    if args.deterministic && !args.scheme.is_deterministic() {
        return usage(format!(
            "--deterministic cannot run --scheme {}: it drops a record whose insert loses a race, \
             so the records kept depend on the schedule (use wf)",
            args.scheme
        ));
    }
    let mut settings = RenderSettings::new(args.width, args.height)
        .accuracy(args.accuracy)
        .rays_per_record(args.rays_per_record)
        .smoothing(args.smoothing)
        .light_samples(args.light_samples)
        .pixel_samples(args.spp)
        .seed(args.seed)
        .quiet(args.quiet)
        .pool(args.pool);
    settings.deterministic = args.deterministic;
    settings.direct = args.direct;
    settings.validate().map_err(out_of_range)?;
    Ok(settings)
}

/// Everything `wfic render` checks before it starts: the arguments, the scene, the cache's
/// configuration, and that the machine can start the threads and hold the frame
/// ([`crate::bounds::check_resources`]). `--dry-run` stops here.
///
/// # Errors
/// Bad input, exit code 2.
pub fn prepare(
    args: &RenderArgs,
) -> Result<(RenderSettings, Scene, wfic::cache::CacheConfig), RenderError> {
    let settings = settings_from(args)?;
    if args.distributed {
        #[cfg(not(feature = "mpi"))]
        return Err(no_mpi());
        #[cfg(feature = "mpi")]
        {
            limits::FRAMES
                .check(args.frames)
                .map_err(|e| RenderError::Usage(e.for_option()))?;
            exchange_from(args)
                .validate()
                .map_err(|e| RenderError::Usage(e.for_option()))?;
        }
    }
    let scene = load_scene(args)?;
    let config = settings
        .cache_config(&scene)
        .map_err(|e| RenderError::Usage(e.to_string()))?;
    crate::bounds::check_resources(args.threads, Some((settings.width, settings.height)))
        .map_err(RenderError::Usage)?;
    Ok((settings, scene, config))
}

/// The MPI exchange the arguments ask for.
#[cfg(feature = "mpi")]
fn exchange_from(args: &RenderArgs) -> wfic_render::distributed::Exchange {
    wfic_render::distributed::Exchange {
        batch_records: args.batch_records,
        batch_ms: args.batch_ms,
        share: !args.no_share,
    }
}

/// Runs `wfic render`.
pub fn run_render(args: RenderArgs) -> Result<(), RenderError> {
    if args.distributed {
        return run_distributed(args);
    }
    let (settings, scene, config) = prepare(&args)?;
    let camera = scene.camera();
    if args.scheme == Scheme::Tra && args.threads > 1 {
        eprintln!(
            "note: tra holds its octree for the whole frame; the other {} worker(s) only wait",
            args.threads - 1
        );
    }
    let (frame, records) = render_with_scheme(
        args.scheme,
        &scene,
        &camera,
        &settings,
        config,
        args.threads,
    );
    let io = |e: std::io::Error| RenderError::Io(e.to_string());
    let exposure = frame.image.auto_exposure();
    frame.image.write_png(&args.out, exposure).map_err(io)?;
    let pfm = args
        .pfm
        .clone()
        .unwrap_or_else(|| args.out.with_extension("pfm"));
    frame
        .image
        .write_pfm(&pfm)
        .map_err(|e| RenderError::Io(format!("{}: {e}", pfm.display())))?;
    let hdr = args
        .hdr
        .clone()
        .unwrap_or_else(|| args.out.with_extension("hdr"));
    frame
        .image
        .write_hdr(&hdr)
        .map_err(|e| RenderError::Io(format!("{}: {e}", hdr.display())))?;
    let overlay = args
        .records
        .clone()
        .unwrap_or_else(|| with_suffix(&args.out, "-records.png"));
    let view = camera.view(settings.width, settings.height);
    let points: Vec<_> = records
        .iter()
        .filter_map(|r| {
            view.project(r.position)
                .map(|p| (p, worker_colour(r.id().worker().index())))
        })
        .collect();
    frame
        .image
        .write_overlay_png(&overlay, exposure, &points)
        .map_err(io)?;
    let summary = wfic_render::stats::SceneSummary::of(&scene, args.obj.is_none());
    let json = frame.stats.to_json(scene.name(), &summary);
    if let Some(path) = &args.stats {
        std::fs::write(path, &json)
            .map_err(|e| RenderError::Io(format!("{}: {e}", path.display())))?;
    }
    let s = &frame.stats;
    println!(
        "{} {} {}x{} threads={}: {:.3} s, {} IC samples, {} lookups, {} hits ({:.1}% shared), \
         lock wait {:.4} s, merge {:.4} s, {} discarded, {} records, image hash {}; wrote {}, \
         {}, {}, {}",
        scene.name(),
        s.scheme,
        s.width,
        s.height,
        s.threads,
        s.seconds,
        s.ic_samples,
        s.lookups,
        s.hits,
        100.0 * s.sharing,
        s.lock_wait_seconds,
        s.merge_seconds,
        s.discarded,
        s.cache_records,
        s.frame_hash,
        args.out.display(),
        pfm.display(),
        hdr.display(),
        overlay.display(),
    );
    Ok(())
}

#[cfg(not(feature = "mpi"))]
fn run_distributed(_: RenderArgs) -> Result<(), RenderError> {
    Err(no_mpi())
}

#[cfg(not(feature = "mpi"))]
fn no_mpi() -> RenderError {
    RenderError::Usage(
        "--distributed needs wfic built with the `mpi` feature: install OpenMPI \
         (apt-get install libopenmpi-dev openmpi-bin libclang-dev), then \
         cargo build --release --features mpi, and run under mpirun -np R"
            .to_owned(),
    )
}

/// `wfic render --distributed`, on every rank of the job.
#[cfg(feature = "mpi")]
fn run_distributed(args: RenderArgs) -> Result<(), RenderError> {
    use mpi::traits::Communicator;
    use wfic_render::distributed::render_distributed_frames;
    let Some((universe, threading)) = mpi::initialize_with_threading(mpi::Threading::Multiple)
    else {
        return Err(RenderError::Usage("MPI was initialised already".to_owned()));
    };
    let world = universe.world();
    let (rank, size) = (world.rank(), world.size());
    if threading != mpi::Threading::Multiple {
        eprintln!(
            "rank {rank}: warning: this MPI gives {threading:?} threads, not Multiple; a panic on \
             a worker thread still aborts the job, through a call MPI does not promise to allow"
        );
    }
    // A panic on any thread ends the whole job at once: otherwise the other ranks wait in the
    // next collective for a rank that will never reach it.
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        previous(info);
        eprintln!("error: rank {rank} of {size} panicked; aborting the MPI job");
        mpi::topology::SimpleCommunicator::world().abort(101);
    }));
    let (settings, scene, config) = distributed_setup(&world, &args)?;
    let exchange = exchange_from(&args);
    let cameras: Vec<Camera> = if args.frames == 1 {
        vec![scene.camera()]
    } else {
        (0..args.frames)
            .map(|i| Camera::orbit(&scene, i as f32 / args.frames as f32))
            .collect()
    };
    let fail = args.fail_rank.map(|r| (r, args.fail_exit));
    let frames = render_distributed_frames(
        &world,
        &scene,
        &cameras,
        &settings,
        config,
        args.threads,
        &exchange,
        fail,
    )
    .map_err(|e| refuse(&world, e.to_string()))?;
    let Some(frames) = frames else {
        return Ok(());
    };
    for (i, (frame, camera)) in frames.iter().zip(&cameras).enumerate() {
        let numbering = (frames.len() > 1).then_some(i);
        write_distributed_frame(&args, &scene, &settings, frame, camera, numbering, size)?;
    }
    if let Some(path) = &args.stats {
        let stats = wfic_render::stats::DistributedStats {
            scene: scene.name().to_owned(),
            triangles: scene.triangle_count(),
            width: settings.width,
            height: settings.height,
            batch_records: exchange.batch_records,
            batch_ms: exchange.batch_ms,
            share: exchange.share,
            frames: wfic_render::stats::DistributedFrames::new(
                frames.into_iter().map(|f| f.stats).collect(),
            ),
        };
        std::fs::write(path, stats.to_json())
            .map_err(|e| RenderError::Io(format!("{}: {e}", path.display())))?;
    }
    Ok(())
}

/// A refusal, printed by every rank of the job, which then waits for the others to have printed
/// theirs: `mpirun` kills the job when the first rank exits with an error, and a message not
/// written by then is lost.
#[cfg(feature = "mpi")]
fn refuse(world: &mpi::topology::SimpleCommunicator, message: String) -> RenderError {
    use mpi::collective::CommunicatorCollectives;
    eprintln!("error: {message}");
    world.barrier();
    RenderError::Reported
}

/// Every rank checks its own arguments and loads the scene; the ranks then agree on whether all
/// of them can go on, so a bad argument on one rank stops every rank with a message instead of
/// a hang.
#[cfg(feature = "mpi")]
fn distributed_setup(
    world: &mpi::topology::SimpleCommunicator,
    args: &RenderArgs,
) -> Result<(RenderSettings, Scene, wfic::cache::CacheConfig), RenderError> {
    use mpi::traits::{Communicator, CommunicatorCollectives};
    let (rank, size) = (world.rank(), world.size());
    let setup = || -> Result<_, RenderError> {
        if args.scheme != Scheme::Wf {
            return Err(RenderError::Usage(format!(
                "--distributed renders with the wait-free cache on every rank: use --scheme wf, \
                 not {}",
                args.scheme
            )));
        }
        prepare(args)
    };
    let ready = setup();
    let ok = u8::from(ready.is_ok());
    let mut oks = vec![0u8; size as usize];
    world.all_gather_into(&ok, &mut oks[..]);
    let ready = match ready {
        Err(e) => return Err(refuse(world, format!("rank {rank}: {e}"))),
        Ok(_) if oks.contains(&0) => {
            let bad: Vec<String> = (0..size)
                .filter(|&r| oks[r as usize] == 0)
                .map(|r| r.to_string())
                .collect();
            return Err(refuse(
                world,
                format!(
                    "rank {rank}: rank(s) {} refused their arguments (see their messages)",
                    bad.join(", ")
                ),
            ));
        }
        Ok(ready) => ready,
    };
    Ok(ready)
}

/// Writes frame `frame` of a distributed render (rank 0): its PNG, PFM and record overlay, their
/// names numbered `-NNN` when `numbering` is `Some(NNN)`; prints a line about it.
#[cfg(feature = "mpi")]
fn write_distributed_frame(
    args: &RenderArgs,
    scene: &Scene,
    settings: &RenderSettings,
    frame: &wfic_render::distributed::DistributedFrame,
    camera: &Camera,
    numbering: Option<usize>,
    size: i32,
) -> Result<(), RenderError> {
    let io = |path: &Path, e: std::io::Error| RenderError::Io(format!("{}: {e}", path.display()));
    let numbered = |p: &Path| match numbering {
        None => p.to_path_buf(),
        Some(i) => {
            let ext = p
                .extension()
                .map_or(String::new(), |e| format!(".{}", e.to_string_lossy()));
            with_suffix(&p.with_extension(""), &format!("-{i:03}{ext}"))
        }
    };
    let out = numbered(&args.out);
    let exposure = frame.image.auto_exposure();
    frame
        .image
        .write_png(&out, exposure)
        .map_err(|e| io(&out, e))?;
    let pfm = numbered(
        &args
            .pfm
            .clone()
            .unwrap_or_else(|| args.out.with_extension("pfm")),
    );
    frame.image.write_pfm(&pfm).map_err(|e| io(&pfm, e))?;
    let overlay = numbered(
        &args
            .records
            .clone()
            .unwrap_or_else(|| with_suffix(&args.out, "-records.png")),
    );
    let view = camera.view(settings.width, settings.height);
    let points: Vec<_> = frame
        .records
        .iter()
        .filter_map(|(rank, r)| view.project(r.position).map(|p| (p, worker_colour(*rank))))
        .collect();
    frame
        .image
        .write_overlay_png(&overlay, exposure, &points)
        .map_err(|e| io(&overlay, e))?;
    let stats = &frame.stats;
    let sent: u64 = stats.ranks.iter().map(|r| r.bytes_sent).sum();
    println!(
        "{} distributed over {} ranks ({}): {:.3} s, {} records computed ({} duplicates), \
         {} bytes exchanged; wrote {}, {}, {}",
        scene.name(),
        size,
        stats
            .ranks
            .iter()
            .map(|r| format!(
                "rank {}: {} threads, {} tiles, {} records",
                r.rank, r.threads, r.tiles, r.records_computed
            ))
            .collect::<Vec<_>>()
            .join("; "),
        stats.seconds,
        stats.records_computed,
        stats.duplicates,
        sent,
        out.display(),
        pfm.display(),
        overlay.display(),
    );
    Ok(())
}
