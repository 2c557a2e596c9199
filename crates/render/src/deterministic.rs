//! Deterministic frames (`wfic render --deterministic`): the same image, bit for bit, and the
//! same records at any thread count, on scoped threads or the rayon pool, for every scheme but
//! WF `Discard`.
//!
//! A frame is a few passes, each a frame of the cache ([`wfic::cache::deterministic`]):
//!
//! 1. **Pretraces** at [`PRETRACE_STRIDES`]: the pixels of a coarse grid (one in `s` x `s`),
//!    in blocks of up to `s` tiles a side, each look up their primary hit and, on a miss, compute
//!    and insert a record ([`PixelIntegrator::pretrace`]), as Radiance's overture pass and
//!    POV-Ray's pretrace fill the cache before the image.
//! 2. **The frame**: every pixel of every tile, shaded as in an ordinary frame.
//!
//! In each pass a block's lookups use the records of the earlier passes (and earlier frames) and
//! its own, never another block's of the same pass, and sum them in record-id order; a record's
//! id is its block, its pass's cache frame and its count in the block. So every pass's records
//! and pixels are a function of the passes before it, whatever thread shaded which block
//! (`docs/design.md`, deterministic frames). The pretraces are what keep this cheap: a block of
//! the final pass cannot use its neighbours' new records, and without coarse records already in
//! place it would compute its own along every tile border.
//!
//! Removal ([`render_frame_removing`](crate::parallel::render_frame_removing)) runs between
//! frames, before the first pass ([`IrradianceCache::remove`]): during a pass, what it took would
//! depend on which blocks' inserts came first.

use super::camera::Camera;
use super::film::{fnv1a, Image};
use super::integrator::{PixelIntegrator, SampleCounters};
use super::scene::Scene;
use super::settings::{Pool, RenderSettings};
use super::stats::FrameStats;
use super::work::{paint, Blocks, Tiles};
use super::FrameResult;
use glam::Vec3;
use std::time::Instant;
use wfic::cache::deterministic::MAX_TILES;
use wfic::cache::{CacheHandle, Frame, FrameReport, IrradianceCache, Scheme, TileHandle};
use wfic::ic::{Record, Selection};

/// The pretrace passes' grid strides, coarse to fine: one pass at one pixel in 4 x 4
/// (`docs/tried-and-dropped.md` has the schedules measured against it).
pub const PRETRACE_STRIDES: [u32; 1] = [4];

/// The side of a deterministic frame's tiles: the settings' tile size, doubled until the image
/// has at most [`MAX_TILES`] tiles (a tile's number is a worker id, 16 bits of a record id).
pub fn tile_side(settings: &RenderSettings) -> u32 {
    let mut side = settings.tile_size.max(1);
    while Tiles::sized(settings, side).count() > MAX_TILES {
        side *= 2;
    }
    side
}

/// The side of a pretrace pass's blocks at `stride`: `stride` tiles a side (as many grid pixels
/// a block as a tile has pixels), but no more than an eighth of the image's shorter side (at
/// least one tile), so that a pass has some 64 blocks to spread over the threads. A function of
/// the image and tile size only, never of the thread count.
fn block_side(settings: &RenderSettings, side: u32, stride: u32) -> u32 {
    let eighth = settings.width.min(settings.height) / 8;
    side.saturating_mul(stride).min(eighth).max(side)
}

/// Tiles of a pretrace pass: blocks of `side` pixels, each shading only its pixels on a `stride`
/// x `stride` grid (`x % stride == stride / 2`, likewise `y`), row by row.
pub struct GridTiles {
    tiles: Tiles,
    stride: u32,
}

impl GridTiles {
    /// The pixels of `lo..hi` on the grid.
    fn on_grid(&self, lo: u32, hi: u32) -> impl Iterator<Item = u32> {
        let (s, half) = (self.stride, self.stride / 2);
        let first = lo + (half + s - lo % s) % s;
        (first..hi).step_by(s as usize)
    }
}

impl Blocks for GridTiles {
    fn count(&self) -> usize {
        self.tiles.count()
    }

    fn pixel_count(&self, item: usize) -> usize {
        let (x0, y0, x1, y1) = self.tiles.rect(item);
        self.on_grid(x0, x1).count() * self.on_grid(y0, y1).count()
    }

    fn for_each_pixel(&self, item: usize, mut pixel: impl FnMut(u32, u32)) {
        let (x0, y0, x1, y1) = self.tiles.rect(item);
        for y in self.on_grid(y0, y1) {
            for x in self.on_grid(x0, x1) {
                pixel(x, y);
            }
        }
    }
}

/// Runs `work` on every tile `0..tiles` of `frame`, on `pool` if there is one, else on `threads`
/// scoped threads; the results in tile order.
fn run_tiles<'f, C, T, F>(
    frame: &'f Frame<'_, C>,
    pool: Option<&rayon::ThreadPool>,
    threads: usize,
    tiles: usize,
    work: F,
) -> Vec<T>
where
    C: IrradianceCache,
    T: Send,
    F: Fn(&mut TileHandle<C::Handle<'f>>, usize) -> T + Sync,
{
    match pool {
        Some(pool) => frame.run_tiles_on_pool(pool, tiles, work),
        None => frame.run_tiles(threads, tiles, work),
    }
}

/// Adds `other`'s counters and merge time to `report`.
fn add(report: &mut FrameReport, other: FrameReport) {
    report.workers += &other.workers;
    report.merge += other.merge;
}

/// One pass of a deterministic frame: its tiles, and what shading one of them does.
pub enum Pass {
    /// Pretrace pass `number` over the grid pixels of its blocks.
    Pretrace {
        /// The pass's number among the pretraces (part of its random streams).
        number: u32,
        /// Its blocks.
        blocks: GridTiles,
    },
    /// The frame's own pass: every pixel of every tile.
    Frame(Tiles),
}

impl Pass {
    /// The passes of a deterministic frame of `settings` with a cache of `scheme`: the pretraces
    /// (none for [`Scheme::None`], which caches nothing), then the frame.
    pub fn all(settings: &RenderSettings, scheme: Scheme) -> Vec<Pass> {
        let side = tile_side(settings);
        let strides: &[u32] = if scheme == Scheme::None {
            &[]
        } else {
            &PRETRACE_STRIDES
        };
        let mut passes: Vec<Pass> = (strides.iter().enumerate())
            .map(|(number, &stride)| Pass::Pretrace {
                number: u32::try_from(number).unwrap_or(u32::MAX),
                blocks: GridTiles {
                    tiles: Tiles::sized(settings, block_side(settings, side, stride)),
                    stride,
                },
            })
            .collect();
        passes.push(Pass::Frame(Tiles::sized(settings, side)));
        passes
    }

    /// How many tiles the pass has.
    pub fn count(&self) -> usize {
        match self {
            Pass::Pretrace { blocks, .. } => blocks.count(),
            Pass::Frame(tiles) => tiles.count(),
        }
    }

    /// Shades tile `tile` of the pass through `handle`: its pixels in shading order (none for a
    /// pretrace), and what it counted.
    pub fn shade<H: CacheHandle>(
        &self,
        integrator: &PixelIntegrator<'_>,
        handle: &mut H,
        tile: usize,
    ) -> (Vec<Vec3>, SampleCounters) {
        let mut c = SampleCounters::default();
        let mut pixels = Vec::new();
        match self {
            Pass::Pretrace { number, blocks } => blocks.for_each_pixel(tile, |x, y| {
                integrator.pretrace((x, y), *number, handle, &mut c);
            }),
            Pass::Frame(tiles) => {
                pixels.reserve(tiles.pixel_count(tile));
                tiles.for_each_pixel(tile, |x, y| {
                    pixels.push(integrator.pixel(x, y, handle, &mut c));
                });
            }
        }
        (pixels, c)
    }
}

/// Renders one deterministic frame (see the module's documentation) of `scene` seen by `camera`
/// with `threads` workers sharing `cache`, after removing what `removal` selects.
///
/// # Panics
/// If the cache's scheme is WF `Discard` ([`Scheme::is_deterministic`]): it drops records by
/// the schedule. The command line refuses that combination before it gets here. As
/// [`crate::render_frame`] for settings out of their ranges.
pub fn render<C: IrradianceCache>(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    cache: &mut C,
    threads: usize,
    removal: Option<&Selection>,
) -> FrameResult {
    settings.assert_valid(threads);
    let start = Instant::now();
    let scheme = cache.scheme();
    assert!(
        scheme.is_deterministic(),
        "a deterministic frame cannot run {scheme}: it drops records by the schedule"
    );
    let threads = threads.max(1);
    let removed = removal.map_or(0, |s| cache.remove(s));
    let integrator = PixelIntegrator::new(scene, camera, settings, cache.config().accuracy());
    let pool = (settings.pool == Pool::Rayon).then(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("wfic-render-{i}"))
            .build()
            .expect("a rayon pool of the frame's threads")
    });
    let mut counters = SampleCounters::default();
    let mut report = FrameReport::default();
    let mut pretrace = (0.0, 0);
    let mut image = Image::new(settings.width, settings.height);
    for pass in Pass::all(settings, scheme) {
        let frame = cache.frame();
        let done = run_tiles(&frame, pool.as_ref(), threads, pass.count(), |h, t| {
            pass.shade(&integrator, h, t)
        });
        add(&mut report, frame.close());
        for (t, (pixels, c)) in done.into_iter().enumerate() {
            counters += c;
            if let Pass::Frame(tiles) = &pass {
                paint(tiles, t, pixels, &mut image);
            }
        }
        if let Pass::Pretrace { .. } = pass {
            pretrace = (start.elapsed().as_secs_f64(), counters.ic_samples);
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let records = cache.snapshot();
    let mut stats = FrameStats::new(
        scheme.name(),
        threads,
        settings,
        seconds,
        &counters,
        &report,
        records.len(),
    );
    stats.removed += removed as u64;
    (stats.pretrace_seconds, stats.pretrace_records) = pretrace;
    stats.frame_hash = image.hash();
    stats.records_hash = Some(records_hash(&records));
    FrameResult { image, stats }
}

/// A hash of a record set, independent of the order `records` lists it in: every record's id,
/// position, normal, irradiance, radius and gradients, as bit patterns, sorted by id, through
/// FNV-1a, as 16 hexadecimal digits.
pub fn records_hash(records: &[Record]) -> String {
    let mut sorted: Vec<&Record> = records.iter().collect();
    sorted.sort_unstable_by_key(|r| r.id());
    let words = sorted.into_iter().flat_map(|r| {
        let id = r.id().get();
        let vectors = [r.position, r.normal, r.irradiance]
            .into_iter()
            .chain(r.grad_t)
            .chain(r.grad_r);
        [(id >> 32) as u32, id as u32, r.radius.to_bits()]
            .into_iter()
            .chain(vectors.flat_map(|v: Vec3| v.to_array().map(f32::to_bits)))
            .collect::<Vec<u32>>()
    });
    format!("{:016x}", fnv1a(words))
}
