//! The render loop: image tiles handed out dynamically to the workers of one cache frame
//! (tray_rust's block queue, pbrt-v4's tile integrator), on scoped threads or on a rayon pool.
//! What a sample computes is the integrator's ([`PixelIntegrator`]); what a frame counts is
//! [`FrameStats`].

use super::film::Image;
use super::integrator::{PixelIntegrator, SampleCounters};
use super::scene::Scene;
use super::stats::FrameStats;
use super::{Camera, RenderSettings};
use wfic::cache::{CacheConfig, CacheHandle, CacheJob, IrradianceCache, NoCache, Scheme};
use wfic::ic::{Selection, WorkerId};
use wfic::sync::{AtomicUsize, Ordering};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::Instant;

/// Where a frame's workers run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Pool {
    /// One scoped thread per worker, started for the frame ([`wfic::cache::Frame::run`]).
    #[default]
    Scoped,
    /// A rayon pool of as many threads, one cache handle per pool thread
    /// ([`wfic::cache::Frame::run_on_pool`]).
    Rayon,
}

impl Pool {
    /// The name, as `--pool` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Self::Scoped => "threads",
            Self::Rayon => "rayon",
        }
    }
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// The linear HDR image.
    pub image: Image,
    /// Its statistics.
    pub stats: FrameStats,
}

/// The frame's tiles: square blocks of `tile_size` pixels, row by row.
pub(super) struct Tiles {
    size: u32,
    width: u32,
    height: u32,
    across: u32,
    pub(super) count: usize,
}

impl Tiles {
    pub(super) fn new(settings: &RenderSettings) -> Self {
        let size = settings.tile_size.max(1);
        let across = settings.width.div_ceil(size);
        Self {
            size,
            width: settings.width,
            height: settings.height,
            across,
            count: (across * settings.height.div_ceil(size)) as usize,
        }
    }

    /// The pixel rectangle `(x0, y0, x1, y1)` of tile `tile`.
    pub(super) fn rect(&self, tile: usize) -> (u32, u32, u32, u32) {
        let (tx, ty) = (tile as u32 % self.across, tile as u32 / self.across);
        let (x0, y0) = (tx * self.size, ty * self.size);
        (
            x0,
            y0,
            (x0 + self.size).min(self.width),
            (y0 + self.size).min(self.height),
        )
    }
}

fn progress_bar(tiles: usize, quiet: bool, label: &str) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(tiles as u64), ProgressDrawTarget::stderr());
    if let Ok(style) =
        ProgressStyle::with_template("{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles")
    {
        bar.set_style(style);
    }
    bar.set_message(label.to_owned());
    bar
}

/// What a worker hands back: its tiles' pixels and its counters.
struct WorkerOutput {
    tiles: Vec<(usize, Vec<Vec3>)>,
    counters: SampleCounters,
    /// From the worker's first look at the queue to finding it empty.
    busy: std::time::Duration,
}

/// Takes tiles from `next_tile` until none is left, shading each pixel through `handle`.
fn tile_loop<H: CacheHandle>(
    integrator: &PixelIntegrator<'_>,
    tiles: &Tiles,
    next_tile: &AtomicUsize,
    bar: &ProgressBar,
    handle: &mut H,
) -> WorkerOutput {
    let start = Instant::now();
    let mut out = WorkerOutput {
        tiles: Vec::new(),
        counters: SampleCounters::default(),
        busy: std::time::Duration::ZERO,
    };
    loop {
        // Relaxed: the counter only has to hand each tile to exactly one worker, which the
        // atomicity of `fetch_add` guarantees on its own; no other memory is published through
        // it (the tiles' pixels come back through the join).
        let tile = next_tile.fetch_add(1, Ordering::Relaxed);
        if tile >= tiles.count {
            break;
        }
        let (x0, y0, x1, y1) = tiles.rect(tile);
        let mut pixels = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
        for y in y0..y1 {
            for x in x0..x1 {
                pixels.push(integrator.pixel(x, y, handle, &mut out.counters));
            }
        }
        out.tiles.push((tile, pixels));
        bar.inc(1);
    }
    out.busy = start.elapsed();
    out
}

/// Renders one frame of `scene` seen by `camera` with `threads` workers (0 counts as 1) sharing
/// `cache`, on the pool `settings.pool` names, then closes the cache's frame (LW merges there,
/// timed).
///
/// The cache keeps its records, so calling this again renders the next frame of an animation
/// with them (the paper's §4.2). With [`wfic::cache::Sequential`] (TRA) a worker holds the
/// octree for the whole frame, so extra workers only wait: use one thread. With
/// [`NoCache`] the frame is the reference: the indirect term is estimated at every primary hit.
pub fn render_frame<C: IrradianceCache>(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
) -> FrameResult {
    render_frame_removing(scene, camera, settings, cache, threads, None)
}

/// [`render_frame`], with worker 0 first removing what `removal` selects through its handle
/// ([`wfic::cache::CacheHandle::remove`]), while the other workers already shade: for a scene
/// that changed since the cache's last frame. The frame's time includes the removal; the
/// statistics count what it took ([`FrameStats::removed`]).
pub fn render_frame_removing<C: IrradianceCache>(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
    removal: Option<&Selection>,
) -> FrameResult {
    let start = Instant::now();
    let threads = threads.max(1);
    let scheme = cache.scheme().name();
    let integrator = PixelIntegrator::new(scene, camera, settings, cache.config().accuracy());
    let tiles = Tiles::new(settings);
    let bar = progress_bar(
        tiles.count,
        settings.quiet,
        &format!("{} {scheme}", scene.name()),
    );
    let next_tile = AtomicUsize::new(0);
    let frame = cache.frame();
    let work = |handle: &mut C::Handle<'_>, worker: WorkerId| {
        if let Some(selection) = removal.filter(|_| worker == WorkerId::new(0)) {
            handle.remove(selection);
        }
        tile_loop(&integrator, &tiles, &next_tile, &bar, handle)
    };
    let outputs = match settings.pool {
        Pool::Scoped => frame.run(threads, work),
        Pool::Rayon => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .thread_name(|i| format!("wfic-render-{i}"))
                .build()
                .expect("a rayon pool of the frame's threads");
            frame.run_on_pool(&pool, work)
        }
    };
    let report = frame.close();
    bar.finish_and_clear();

    let mut image = Image::new(settings.width, settings.height);
    let mut counters = SampleCounters::default();
    let worker_seconds: Vec<f64> = outputs.iter().map(|o| o.busy.as_secs_f64()).collect();
    for out in outputs {
        for (tile, pixels) in out.tiles {
            let (x0, y0, x1, _) = tiles.rect(tile);
            let tw = x1 - x0;
            for (i, p) in pixels.into_iter().enumerate() {
                image.set(x0 + i as u32 % tw, y0 + i as u32 / tw, p);
            }
        }
        counters += out.counters;
    }
    let seconds = start.elapsed().as_secs_f64();
    let mut stats = FrameStats::new(
        scheme,
        threads,
        settings,
        seconds,
        &counters,
        &report,
        cache.stats().records,
    );
    stats.worker_seconds = worker_seconds;
    FrameResult { image, stats }
}

/// Renders one frame with `scheme` and a fresh cache (the reference for `none`), returning the
/// frame and the records the cache holds afterwards.
pub fn render_with_scheme(
    scheme: Scheme,
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    config: CacheConfig,
    threads: usize,
) -> (FrameResult, Vec<wfic::ic::Record>) {
    struct Frame<'a> {
        scene: &'a Scene,
        camera: &'a Camera,
        settings: &'a RenderSettings,
        threads: usize,
    }
    impl CacheJob for Frame<'_> {
        type Output = (FrameResult, Vec<wfic::ic::Record>);
        fn run<C: IrradianceCache>(self, mut cache: C) -> Self::Output {
            let out = render_frame(
                self.scene,
                self.camera,
                self.settings,
                &mut cache,
                self.threads,
            );
            (out, cache.snapshot())
        }
    }
    scheme.build(
        config,
        Frame {
            scene,
            camera,
            settings,
            threads,
        },
    )
}

/// Renders the reference (scheme `none`): [`render_frame`] with a [`NoCache`] over `config`.
pub fn render_reference(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    config: CacheConfig,
    threads: usize,
) -> FrameResult {
    render_frame(scene, camera, settings, &mut NoCache::new(config), threads)
}

/// [`render_reference`] at the pixels of a `stride` x `stride` grid only: pixel `(x, y)` is
/// shaded when `x % stride == stride / 2` and `y % stride == stride / 2`; the others stay black.
/// A shaded pixel has the value the full reference gives it (every pixel's random streams
/// depend on the seed and the pixel only), at `1 / stride^2` of the cost: for error measures
/// against a brute-force image too slow to compute whole (`wfic compare radiance`). Returns the
/// image and the wall-clock seconds.
pub fn render_reference_grid(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    config: CacheConfig,
    threads: usize,
    stride: u32,
) -> (Image, f64) {
    let start = Instant::now();
    let stride = stride.max(1);
    let mut cache = NoCache::new(config);
    let integrator = PixelIntegrator::new(scene, camera, settings, config.accuracy());
    let rows: Vec<u32> = (stride / 2..settings.height)
        .step_by(stride as usize)
        .collect();
    let next_row = AtomicUsize::new(0);
    let frame = cache.frame();
    let outputs = frame.run(threads.max(1), |handle, _| {
        let mut counters = SampleCounters::default();
        let mut out = Vec::new();
        loop {
            // Relaxed: as in `tile_loop`, the counter only hands each row to one worker; the
            // pixels come back through the join.
            let i = next_row.fetch_add(1, Ordering::Relaxed);
            let Some(&y) = rows.get(i) else { break };
            for x in (stride / 2..settings.width).step_by(stride as usize) {
                out.push((x, y, integrator.pixel(x, y, handle, &mut counters)));
            }
        }
        out
    });
    frame.close();
    let mut image = Image::new(settings.width, settings.height);
    for (x, y, p) in outputs.into_iter().flatten() {
        image.set(x, y, p);
    }
    (image, start.elapsed().as_secs_f64())
}

/// Renders `frames` frames of the scene's orbit ([`Camera::orbit`] at `i / frames` turns) with one
/// cache that keeps its records from frame to frame (the paper's §4.2 walkthroughs), calling
/// `each(i, &frame)` after each frame; returns the frames' statistics.
pub fn render_orbit<C: IrradianceCache>(
    scene: &Scene,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
    frames: usize,
    mut each: impl FnMut(usize, &FrameResult),
) -> Vec<FrameStats> {
    (0..frames)
        .map(|i| {
            let camera = Camera::orbit(scene, i as f32 / frames.max(1) as f32);
            let out = render_frame(scene, &camera, settings, cache, threads);
            each(i, &out);
            out.stats
        })
        .collect()
}
