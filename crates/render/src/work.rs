//! Where a frame's workers get their work, and the one loop every worker runs.
//!
//! Every way the renderer shades an image goes through here: a frame's tiles on scoped threads
//! or on a rayon pool ([`crate::parallel`]), the rows of the reference grid
//! ([`crate::render_reference_grid`]), and the tiles an MPI rank is fed at its exchange rounds
//! (`crate::distributed`). Each is a [`Blocks`] layout (which pixels work item `i` covers, in the
//! order they are shaded) and a [`WorkSource`] (which item a worker takes next), consumed by
//! [`shade`]:
//!
//! * [`Counter`] hands out `0..count` from an atomic counter: the whole frame is known up front;
//! * [`Queue`] hands out what another thread pushes, and blocks a worker on a condition variable
//!   while it is empty but not yet closed: the MPI rank's main thread feeds it tiles as the ranks
//!   agree on them.
//!
//! A pixel's value depends on the seed, the pixel and what the cache holds when it is shaded,
//! never on which worker shades it or through which source: the same blocks shaded in the same
//! order give the same image.

use super::film::Image;
use super::integrator::{PixelIntegrator, SampleCounters};
use super::settings::RenderSettings;
use glam::Vec3;
use std::collections::VecDeque;
// The renderer never runs under the core's model checkers (lib.rs), so the queue's lock and
// condition variable are std's: `wfic::sync` has no condition variable to offer.
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};
use wfic::cache::CacheHandle;
use wfic::sync::{AtomicUsize, Ordering};

/// A source of work items (indices into a [`Blocks`] layout) shared by the workers of a frame:
/// each item is handed to exactly one worker.
pub trait WorkSource: Sync {
    /// The next item for the calling worker, or `None` once no item is left and none will come.
    /// A source fed by another thread may block until it has one.
    fn next_item(&self) -> Option<usize>;
}

/// The items `0..count`, each handed out once, in increasing order, by an atomic counter: the
/// source when every item of the frame is known before the workers start.
#[derive(Debug)]
pub struct Counter {
    next: AtomicUsize,
    count: usize,
}

impl Counter {
    /// The items `0..count`, none handed out yet.
    pub fn new(count: usize) -> Self {
        Self {
            next: AtomicUsize::new(0),
            count,
        }
    }
}

impl WorkSource for Counter {
    fn next_item(&self) -> Option<usize> {
        // Relaxed: the counter only hands out distinct indices, which the atomicity of
        // `fetch_add` guarantees on its own; no other memory is published through it (the
        // blocks' pixels come back through the workers' join).
        let item = self.next.fetch_add(1, Ordering::Relaxed);
        (item < self.count).then_some(item)
    }
}

/// A queue of items that another thread pushes while the workers take them, closed once no more
/// will come: a worker that finds it empty waits on a condition variable until an item or the
/// close arrives. Items come out in the order they were pushed.
#[derive(Debug, Default)]
pub struct Queue {
    state: Mutex<QueueState>,
    /// Signalled when items are pushed or the queue is closed.
    filled: Condvar,
}

#[derive(Debug, Default)]
struct QueueState {
    items: VecDeque<usize>,
    closed: bool,
}

impl Queue {
    /// An empty, open queue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Appends `items` and wakes the waiting workers.
    pub fn push(&self, items: impl IntoIterator<Item = usize>) {
        wfic::sync::unpoison(self.state.lock()).items.extend(items);
        self.filled.notify_all();
    }

    /// Says no more items will come: once the queue is empty, [`WorkSource::next_item`] returns
    /// `None` instead of waiting.
    pub fn close(&self) {
        wfic::sync::unpoison(self.state.lock()).closed = true;
        self.filled.notify_all();
    }

    /// Items pushed and not yet taken.
    pub fn len(&self) -> usize {
        wfic::sync::unpoison(self.state.lock()).items.len()
    }

    /// Whether no item waits.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl WorkSource for Queue {
    fn next_item(&self) -> Option<usize> {
        let mut state = wfic::sync::unpoison(self.state.lock());
        loop {
            if let Some(item) = state.items.pop_front() {
                return Some(item);
            }
            if state.closed {
                return None;
            }
            state = wfic::sync::unpoison(self.filled.wait(state));
        }
    }
}

/// How an image's pixels are cut into work items: how many items, and which pixels item `i`
/// covers, in the order a worker shades them (the order matters to a cache: a pixel may use the
/// records of the pixels shaded before it).
pub trait Blocks: Sync {
    /// The number of items.
    fn count(&self) -> usize;

    /// The number of pixels of item `item`.
    fn pixel_count(&self, item: usize) -> usize;

    /// Calls `pixel(x, y)` for every pixel of item `item`, in shading order.
    fn for_each_pixel(&self, item: usize, pixel: impl FnMut(u32, u32));
}

/// The frame's tiles: square blocks of `tile_size` pixels (smaller at the right and bottom
/// edges), numbered row by row; a tile's pixels are shaded row by row.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Tiles {
    size: u32,
    width: u32,
    height: u32,
    across: u32,
    count: usize,
}

impl Tiles {
    /// The tiles of a `settings.width` x `settings.height` image.
    pub fn new(settings: &RenderSettings) -> Self {
        Self::sized(settings, settings.tile_size)
    }

    /// The tiles of side `size` (0 counts as 1) of a `settings.width` x `settings.height` image.
    pub fn sized(settings: &RenderSettings, size: u32) -> Self {
        let size = size.max(1);
        let across = settings.width.div_ceil(size);
        Self {
            size,
            width: settings.width,
            height: settings.height,
            across,
            count: across as usize * settings.height.div_ceil(size) as usize,
        }
    }

    /// The side of a tile.
    pub fn size(&self) -> u32 {
        self.size
    }

    /// The pixel rectangle `(x0, y0, x1, y1)` of tile `tile` (`x1`, `y1` exclusive).
    pub fn rect(&self, tile: usize) -> (u32, u32, u32, u32) {
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

impl Blocks for Tiles {
    fn count(&self) -> usize {
        self.count
    }

    fn pixel_count(&self, tile: usize) -> usize {
        let (x0, y0, x1, y1) = self.rect(tile);
        ((x1 - x0) * (y1 - y0)) as usize
    }

    fn for_each_pixel(&self, tile: usize, mut pixel: impl FnMut(u32, u32)) {
        let (x0, y0, x1, y1) = self.rect(tile);
        for y in y0..y1 {
            for x in x0..x1 {
                pixel(x, y);
            }
        }
    }
}

/// The rows of a `stride` x `stride` grid over the image, one item per row: pixel `(x, y)` is
/// on the grid when `x % stride == stride / 2` and `y % stride == stride / 2`; a row's pixels
/// are shaded left to right.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GridRows {
    rows: Vec<u32>,
    columns: Vec<u32>,
}

impl GridRows {
    /// The grid rows of a `settings.width` x `settings.height` image (a `stride` of 0 counts as
    /// 1: every pixel).
    pub fn new(settings: &RenderSettings, stride: u32) -> Self {
        let stride = stride.max(1);
        let on_grid = |size: u32| (stride / 2..size).step_by(stride as usize).collect();
        Self {
            rows: on_grid(settings.height),
            columns: on_grid(settings.width),
        }
    }
}

impl Blocks for GridRows {
    fn count(&self) -> usize {
        self.rows.len()
    }

    fn pixel_count(&self, _: usize) -> usize {
        self.columns.len()
    }

    fn for_each_pixel(&self, row: usize, mut pixel: impl FnMut(u32, u32)) {
        let y = self.rows[row];
        for &x in &self.columns {
            pixel(x, y);
        }
    }
}

/// What a worker hands back from [`shade`]: its items' pixels and its counters.
#[derive(Debug, Default)]
pub struct WorkerOutput {
    /// Each item it shaded with its pixels, in [`Blocks::for_each_pixel`]'s order.
    pub blocks: Vec<(usize, Vec<Vec3>)>,
    /// What it counted while shading.
    pub counters: SampleCounters,
    /// From its first request for an item to finding none left.
    pub busy: Duration,
}

impl WorkerOutput {
    /// Writes the pixels of every shaded item into `image`, at their places in `blocks`.
    pub fn paint(&self, blocks: &impl Blocks, image: &mut Image) {
        for (item, pixels) in &self.blocks {
            paint(blocks, *item, pixels.iter().copied(), image);
        }
    }
}

/// Writes `pixels`, the values of item `item` in shading order, into `image`.
pub fn paint(
    blocks: &impl Blocks,
    item: usize,
    pixels: impl IntoIterator<Item = Vec3>,
    image: &mut Image,
) {
    let mut pixels = pixels.into_iter();
    blocks.for_each_pixel(item, |x, y| {
        if let Some(p) = pixels.next() {
            image.set(x, y, p);
        }
    });
}

/// The worker loop: takes items from `source` until it has none left, shading every pixel of
/// each through `integrator` and `handle`, and calls `done(item)` after each item.
pub fn shade<H: CacheHandle>(
    integrator: &PixelIntegrator<'_>,
    blocks: &impl Blocks,
    source: &impl WorkSource,
    handle: &mut H,
    mut done: impl FnMut(usize),
) -> WorkerOutput {
    let start = Instant::now();
    let mut out = WorkerOutput::default();
    while let Some(item) = source.next_item() {
        let mut pixels = Vec::with_capacity(blocks.pixel_count(item));
        blocks.for_each_pixel(item, |x, y| {
            pixels.push(integrator.pixel(x, y, handle, &mut out.counters));
        });
        out.blocks.push((item, pixels));
        done(item);
    }
    out.busy = start.elapsed();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_counter_hands_out_each_item_once() {
        let counter = Counter::new(3);
        let got: Vec<_> = std::iter::from_fn(|| counter.next_item()).collect();
        assert_eq!(got, [0, 1, 2]);
        assert_eq!(counter.next_item(), None);
    }

    #[test]
    fn a_counter_shared_by_threads_hands_out_every_item_once() {
        let counter = Counter::new(1000);
        let mut all: Vec<usize> = std::thread::scope(|s| {
            let workers: Vec<_> = (0..4)
                .map(|_| s.spawn(|| std::iter::from_fn(|| counter.next_item()).collect::<Vec<_>>()))
                .collect();
            workers
                .into_iter()
                .flat_map(|w| w.join().unwrap())
                .collect()
        });
        all.sort_unstable();
        assert_eq!(all, (0..1000).collect::<Vec<_>>());
    }

    #[test]
    fn a_queue_counts_the_items_that_wait() {
        let queue = Queue::new();
        assert!(queue.is_empty());
        queue.push(0..3);
        assert_eq!(queue.len(), 3);
        assert!(!queue.is_empty());
        assert_eq!(queue.next_item(), Some(0));
        assert_eq!(queue.len(), 2);
    }

    #[test]
    fn a_tile_is_as_wide_as_asked_and_at_least_one_pixel() {
        let settings = RenderSettings::new(5, 3);
        assert_eq!(Tiles::sized(&settings, 4).size(), 4);
        assert_eq!(Tiles::sized(&settings, 0).size(), 1);
        assert_eq!(Tiles::sized(&settings, 0).count(), 15);
    }

    #[test]
    fn a_queue_blocks_until_fed_and_ends_when_closed() {
        let queue = Queue::new();
        let taken = std::thread::scope(|s| {
            let workers: Vec<_> = (0..3)
                .map(|_| s.spawn(|| std::iter::from_fn(|| queue.next_item()).collect::<Vec<_>>()))
                .collect();
            // The workers wait on the empty queue; each push wakes them.
            for chunk in [0..4, 4..5, 5..9] {
                std::thread::sleep(Duration::from_millis(5));
                queue.push(chunk);
            }
            queue.close();
            let mut all: Vec<usize> = workers
                .into_iter()
                .flat_map(|w| w.join().unwrap())
                .collect();
            all.sort_unstable();
            all
        });
        assert_eq!(taken, (0..9).collect::<Vec<_>>());
        assert!(queue.is_empty());
        assert_eq!(queue.next_item(), None);
    }

    #[test]
    fn a_queue_hands_out_in_push_order() {
        let queue = Queue::new();
        queue.push([7, 3]);
        queue.push([5]);
        queue.close();
        assert_eq!(queue.len(), 3);
        let got: Vec<_> = std::iter::from_fn(|| queue.next_item()).collect();
        assert_eq!(got, [7, 3, 5]);
    }

    #[test]
    fn tiles_cover_the_image_once_row_by_row() {
        let mut settings = RenderSettings::new(37, 21);
        settings.tile_size = 16;
        let tiles = Tiles::new(&settings);
        assert_eq!(tiles.count(), 3 * 2);
        let mut seen = vec![0u32; 37 * 21];
        for t in 0..tiles.count() {
            let mut order = Vec::new();
            tiles.for_each_pixel(t, |x, y| order.push((y, x)));
            assert_eq!(order.len(), tiles.pixel_count(t));
            assert!(
                order.windows(2).all(|w| w[0] < w[1]),
                "tile {t} out of order"
            );
            for (y, x) in order {
                seen[(y * 37 + x) as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&n| n == 1));
        assert_eq!(tiles.rect(4), (16, 16, 32, 21));
        assert_eq!(tiles.rect(5), (32, 16, 37, 21));
        assert_eq!(tiles.rect(2), (32, 0, 37, 16));
    }

    #[test]
    fn grid_rows_hold_the_grid_pixels_left_to_right() {
        let grid = GridRows::new(&RenderSettings::new(10, 7), 3);
        assert_eq!(grid.count(), 2);
        let mut row = Vec::new();
        grid.for_each_pixel(1, |x, y| row.push((x, y)));
        assert_eq!(row, [(1, 4), (4, 4), (7, 4)]);
        assert_eq!(grid.pixel_count(1), 3);
        // Stride 0 counts as 1: every pixel.
        assert_eq!(GridRows::new(&RenderSettings::new(4, 5), 0).count(), 5);
    }

    #[test]
    fn painting_puts_each_block_back_where_it_was_shaded() {
        let mut settings = RenderSettings::new(5, 3);
        settings.tile_size = 2;
        let tiles = Tiles::new(&settings);
        let mut image = Image::new(5, 3);
        for t in 0..tiles.count() {
            let mut values = Vec::new();
            tiles.for_each_pixel(t, |x, y| {
                values.push(Vec3::new(x as f32, y as f32, t as f32))
            });
            paint(&tiles, t, values, &mut image);
        }
        for y in 0..3 {
            for x in 0..5 {
                let p = image.get(x, y);
                assert_eq!((p.x, p.y), (x as f32, y as f32));
                assert_eq!(p.z as usize, (y / 2 * 3 + x / 2) as usize);
            }
        }
    }
}
