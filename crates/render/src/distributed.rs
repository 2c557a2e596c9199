//! One frame rendered by several processes over MPI (feature `mpi`), each rank running its
//! threads on a local wait-free cache and exchanging new records with the others in batches.
//!
//! **Design.** Every rank loads the same scene and settings; a fingerprint of both is gathered
//! first, and a rank that differs makes every rank stop with the same error (not a wrong
//! picture). The frame's tiles are handed out in chunks at the exchange rounds: each round,
//! every rank whose own queue holds fewer tiles than twice its threads gets the next chunk, in
//! rank order, from a counter that every rank advances the same way from the same gathered
//! queue lengths, so no message is needed to agree on it. A slow rank asks for less, and the
//! tiles go to whoever is short of work.
//!
//! Each rank's workers run the renderer's one worker loop ([`crate::work::shade`]) over the
//! rank's tile [`Queue`], which the rounds fill and close once no tile is left; a worker that
//! finds it empty sleeps on its condition variable. They render through a handle that also
//! copies every record they store into an outbox. The rank's main thread (the only one that
//! calls MPI) runs the rounds, sleeping between them on a channel of the workers' events (a tile
//! taken, a batch ready, a worker done): every `batch_ms` milliseconds, or as soon as the outbox
//! holds `batch_records` records, the queue runs short or the workers are done, it gathers
//! every rank's queue length and state (`MPI_Allgather`) and every rank's new records
//! (`MPI_Allgatherv`), and inserts the others' records into the local cache through a handle of
//! its own (a wait-free insert beside the workers'). A collective waits for every rank, so a
//! round lasts as long as its slowest rank takes to reach it; the workers do not wait for it.
//! The rounds end when every rank has rendered every tile it was given and no tile is left.
//! Then rank 0 gathers the tiles' pixels (`MPI_Gatherv`) and every rank's computed records (for
//! the duplicate count), and writes the image.
//!
//! **Failures.** A panic on any thread of any rank prints the rank and aborts the whole job
//! (`MPI_Abort`), so the other ranks do not hang in a collective. A rank that exits without
//! finishing is seen by `mpirun`, which ends the job. Nothing is written before the frame is
//! complete on rank 0.

use super::camera::Camera;
use super::deterministic;
use super::film::Image;
use super::integrator::{PixelIntegrator, SampleCounters};
use super::scene::Scene;
use super::settings::RenderSettings;
use super::stats::DistributedFrameStats;
pub use super::stats::RankStats;
use super::work::{self, shade, Blocks, Queue, Tiles, WorkSource};
use glam::Vec3;
use mpi::datatype::PartitionMut;
use mpi::topology::SimpleCommunicator;
use mpi::traits::*;
use mpi::Count;
use std::fmt;
use std::sync::mpsc;
use std::time::{Duration, Instant};
use wfic::cache::wf::Minimal;
use wfic::cache::{
    CacheConfig, CacheHandle, CasFailure, Inserted, IrradianceCache, Scheme, WaitFree,
};
use wfic::ic::{self, InsertError, Interpolated, Record, RecordId, Selection, WorkerId};
use wfic::sync::Mutex;

/// How long a rank's main thread waits for a worker's event before it checks whether a round
/// is due again.
const RECHECK: Duration = Duration::from_micros(250);

/// How records cross between ranks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exchange {
    /// A round starts as soon as a rank's outbox holds this many records (at least 1).
    pub batch_records: usize,
    /// ... or this long after the previous round.
    pub batch_ms: u64,
    /// False: the ranks render their tiles with caches that share nothing (the baseline that
    /// shows what the exchange buys). Tiles and the image are handled the same way.
    pub share: bool,
}

impl Exchange {
    /// Checks the batches against [`crate::limits::BATCH_RECORDS`] and
    /// [`crate::limits::BATCH_MS`].
    ///
    /// # Errors
    /// The first one out of its range.
    pub fn validate(&self) -> Result<(), crate::limits::OutOfRange> {
        crate::limits::BATCH_RECORDS.check(self.batch_records)?;
        crate::limits::BATCH_MS.check(self.batch_ms)?;
        Ok(())
    }

    fn assert_valid(&self) {
        if let Err(e) = self.validate() {
            panic!("invalid exchange: {e}");
        }
    }
}

impl Default for Exchange {
    fn default() -> Self {
        Self {
            batch_records: 256,
            batch_ms: 20,
            share: true,
        }
    }
}

/// A record as it crosses between ranks: its fields as plain floats, the rank that computed it,
/// and its id there. An ordinary frame's receiver gives the record an id of its own; a
/// deterministic frame's inserts it through its tile's handle, which gives it the same id.
#[derive(Equivalence, Clone, Copy, Debug, Default, PartialEq)]
pub struct WireRecord {
    /// position, normal, irradiance (3 each), radius, translational then rotational gradient (9
    /// each): 28 floats.
    pub fields: [f32; 28],
    /// The rank that computed it.
    pub origin: u32,
    /// Its id on that rank ([`wfic::ic::RecordId::get`]).
    pub id: u64,
}

impl WireRecord {
    /// `record`, computed by rank `origin`.
    pub fn new(record: &Record, origin: u32) -> Self {
        let mut fields = [0.0; 28];
        let mut put = |at: usize, v: Vec3| fields[at..at + 3].copy_from_slice(&v.to_array());
        put(0, record.position);
        put(3, record.normal);
        put(6, record.irradiance);
        for c in 0..3 {
            put(10 + 3 * c, record.grad_t[c]);
            put(19 + 3 * c, record.grad_r[c]);
        }
        fields[9] = record.radius;
        Self {
            fields,
            origin,
            id: record.id().get(),
        }
    }

    /// The record again (unsealed: the cache that stores it gives it an id).
    pub fn record(&self) -> Record {
        let f = &self.fields;
        let v = |at: usize| Vec3::new(f[at], f[at + 1], f[at + 2]);
        Record::new(v(0), v(3), v(6), f[9])
            .with_gradients([v(10), v(13), v(16)], [v(19), v(22), v(25)])
    }

    /// The record's id on the rank that computed it.
    pub fn record_id(&self) -> RecordId {
        let worker = WorkerId::new((self.id >> 48) as u32);
        RecordId::new(worker, (self.id >> 32) & 0xffff, self.id & 0xffff_ffff)
    }

    /// A digest of the fields' bits (FNV-1a), order-sensitive: what a sender and its receivers
    /// compare.
    pub fn digest(records: &[WireRecord]) -> u64 {
        let mut h = Fnv::new();
        for r in records {
            h.write_record(r);
        }
        h.finish()
    }
}

/// FNV-1a over 64-bit words: the fingerprints and digests (deterministic across processes, which
/// `std`'s hasher does not promise).
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn write(&mut self, word: u64) {
        for byte in word.to_le_bytes() {
            self.0 ^= u64::from(byte);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }

    fn finish(&self) -> u64 {
        self.0
    }

    /// Writes what a digest of exchanged records covers: the fields' bits, then the origin.
    fn write_record(&mut self, r: &WireRecord) {
        for x in r.fields {
            self.write(u64::from(x.to_bits()));
        }
        self.write(u64::from(r.origin));
    }
}

/// What every rank must agree on: a line a person can compare, and a fingerprint that also
/// covers every vertex and material of the scene.
pub fn fingerprint(
    scene: &Scene,
    camera: &Camera,
    settings: &RenderSettings,
    exchange: &Exchange,
) -> (String, u64) {
    let s = settings;
    let line =
        format!(
        "scene {} ({} triangles), {}x{}, a {} smoothing {}, {} rays a record, {} light samples, {} spp, seed \
         {:#x}, radius clamps {}-{} px, tile {}, eye {} target {}, batch {} records / {} ms, {}{}",
        scene.name(),
        scene.triangle_count(),
        s.width,
        s.height,
        s.accuracy,
        s.smoothing,
        s.rays_per_record,
        s.light_samples,
        s.pixel_samples,
        s.seed,
        s.min_radius_pixels,
        s.max_radius_pixels,
        s.tile_size,
        camera.eye,
        camera.target,
        exchange.batch_records,
        exchange.batch_ms,
        if exchange.share { "shared" } else { "not shared" },
        if s.deterministic { ", deterministic" } else { "" },
    );
    let mut h = Fnv::new();
    for b in line.bytes() {
        h.write(u64::from(b));
    }
    for (vertices, material) in scene.triangles() {
        for v in vertices {
            for x in v.to_array() {
                h.write(u64::from(x.to_bits()));
            }
        }
        h.write(u64::from(material));
    }
    for m in scene.materials() {
        for x in m.albedo.to_array().into_iter().chain(m.emission.to_array()) {
            h.write(u64::from(x.to_bits()));
        }
    }
    (line, h.finish())
}

/// The tiles of a frame handed out in chunks, the same way on every rank.
#[derive(Clone, Debug, PartialEq)]
pub struct TilePlan {
    /// Tiles in the frame.
    pub count: usize,
    /// The next tile no rank has been given.
    pub next: usize,
}

impl TilePlan {
    /// `count` tiles, none given out yet.
    pub fn new(count: usize) -> Self {
        Self { count, next: 0 }
    }

    /// One round: `queued[r]` tiles wait in rank `r`'s queue and `want[r]` is the number it
    /// keeps queued (twice its threads): a rank below it gets `want[r]` more. Returns the tiles
    /// each rank is given (ranges, in rank order), advancing `next`.
    pub fn hand_out(&mut self, queued: &[u64], want: &[u64]) -> Vec<std::ops::Range<usize>> {
        queued
            .iter()
            .zip(want)
            .map(|(&q, &w)| {
                let start = self.next;
                if q < w {
                    self.next = (start + w.max(1) as usize).min(self.count);
                }
                start..self.next
            })
            .collect()
    }

    /// Whether every tile has been given out.
    pub fn exhausted(&self) -> bool {
        self.next >= self.count
    }
}

/// A distributed frame as rank 0 sees it.
#[derive(Clone, Debug)]
pub struct DistributedFrame {
    /// The assembled image.
    pub image: Image,
    /// Every rank's computed records (positions and normals as computed), with their rank.
    pub records: Vec<(u32, Record)>,
    /// Its statistics: every rank's, the duplicates and the seconds, as the statistics file
    /// holds them.
    pub stats: DistributedFrameStats,
}

/// Why a distributed frame did not happen.
#[derive(Clone, Debug, PartialEq)]
pub enum DistributedError {
    /// The ranks were not given the same scene and settings.
    Mismatch {
        /// This rank.
        rank: u32,
        /// This rank's settings line.
        mine: String,
        /// The ranks whose fingerprint differs from rank 0's.
        differing: Vec<u32>,
    },
}

impl fmt::Display for DistributedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Mismatch {
                rank,
                mine,
                differing,
            } => {
                let list: Vec<String> = differing.iter().map(u32::to_string).collect();
                write!(
                    f,
                    "rank {rank}: the ranks were not given the same scene and settings (rank(s) {} \
                     differ from rank 0); every rank must run the same command. This rank has: \
                     {mine}",
                    list.join(", ")
                )
            }
        }
    }
}

impl std::error::Error for DistributedError {}

/// What a rank's workers tell its main thread, which waits on them for the next round instead of
/// polling.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Event {
    /// A worker took a tile: the queue is shorter.
    Took,
    /// The outbox holds a batch.
    Batch,
    /// A worker found the queue closed and empty; every record it stored is in the outbox.
    Finished,
}

/// The rank's tile queue as a worker sees it: the [`Queue`] its main thread feeds, each take
/// (and the final `None`) also reported to the main thread.
struct Fed<'a> {
    queue: &'a Queue,
    events: mpsc::Sender<Event>,
}

impl WorkSource for Fed<'_> {
    fn next_item(&self) -> Option<usize> {
        let tile = self.queue.next_item();
        // A send fails only once the main thread has stopped listening (it is unwinding).
        let _ = self.events.send(match tile {
            Some(_) => Event::Took,
            None => Event::Finished,
        });
        tile
    }
}

/// A worker's handle that copies every record it stores into the rank's outbox (sent to the
/// other ranks when the exchange shares, and kept for the duplicate count either way), telling
/// the main thread when the outbox holds a batch.
struct Sending<'h, H> {
    inner: &'h mut H,
    outbox: &'h Mutex<Vec<Record>>,
    batch: usize,
    events: mpsc::Sender<Event>,
}

impl<H: CacheHandle> CacheHandle for Sending<'_, H> {
    fn worker(&self) -> WorkerId {
        self.inner.worker()
    }

    fn frame(&self) -> u64 {
        self.inner.frame()
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: wfic::cache::Visibility,
    ) -> Option<Interpolated> {
        self.inner.lookup_visible(point, normal, visible)
    }

    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        self.inner.lookup(point, normal)
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        let outcome = self.inner.insert(record)?;
        if matches!(outcome, Inserted::Stored(_)) {
            let pending = {
                let mut outbox = wfic::sync::unpoison(self.outbox.lock());
                outbox.push(record);
                outbox.len()
            };
            if pending == self.batch {
                // As in `Fed`: only fails while the main thread unwinds.
                let _ = self.events.send(Event::Batch);
            }
        }
        Ok(outcome)
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        self.inner.remove(selection)
    }

    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        self.inner.valid_records(point, normal, out)
    }

    fn stats(&self) -> &wfic::cache::WorkerStats {
        self.inner.stats()
    }
}

/// A deterministic tile's handle that keeps every record it stores, sealed with its id, for the
/// pass's exchange.
struct Keeping<'h, H> {
    inner: &'h mut H,
    kept: Vec<Record>,
}

impl<H: CacheHandle> CacheHandle for Keeping<'_, H> {
    fn worker(&self) -> WorkerId {
        self.inner.worker()
    }

    fn frame(&self) -> u64 {
        self.inner.frame()
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: wfic::cache::Visibility,
    ) -> Option<Interpolated> {
        self.inner.lookup_visible(point, normal, visible)
    }

    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        self.inner.lookup(point, normal)
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        let outcome = self.inner.insert(record)?;
        if let Inserted::Stored(id) = outcome {
            self.kept.push(record.sealed(id));
        }
        Ok(outcome)
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        self.inner.remove(selection)
    }

    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        self.inner.valid_records(point, normal, out);
    }

    fn stats(&self) -> &wfic::cache::WorkerStats {
        self.inner.stats()
    }
}

/// Renders one frame per camera, in order, over the ranks of `world` (every rank calls this with
/// the same scene, cameras, settings and exchange; `threads` may differ between ranks), each rank
/// keeping its cache from frame to frame (the paper's animations, shared between processes): a
/// frame's records, and the records the other ranks sent during it, serve every later frame.
/// Rank 0 gets the frames; the others get `None`. One frame is a one-camera slice
/// (`std::slice::from_ref`). The ranks agree first on a fingerprint of all of it, every camera
/// included.
///
/// `fail` (for the failure tests): `Some((rank, exit))` makes that rank panic (or, with `exit`,
/// leave the process with status 3) once it has rendered its first tile.
///
/// # Errors
/// [`DistributedError::Mismatch`] on every rank when the ranks' scenes, cameras or settings
/// differ.
///
/// # Panics
/// As [`crate::render_frame`] for settings out of their ranges, and with `invalid exchange: ...`
/// if a batch is out of [`crate::limits::BATCH_RECORDS`] or [`crate::limits::BATCH_MS`].
#[allow(clippy::too_many_arguments)]
pub fn render_distributed_frames(
    world: &SimpleCommunicator,
    scene: &Scene,
    cameras: &[Camera],
    settings: &RenderSettings,
    config: CacheConfig,
    threads: usize,
    exchange: &Exchange,
    fail: Option<(u32, bool)>,
) -> Result<Option<Vec<DistributedFrame>>, DistributedError> {
    settings.assert_valid(threads);
    exchange.assert_valid();
    let rank = world.rank() as u32;
    // No camera, no frame: nothing to agree on (every rank returns at once).
    if !cameras.is_empty() {
        agree(world, scene, cameras, settings, exchange)?;
    }
    let job = Job {
        world,
        rank,
        size: world.size() as usize,
        threads: threads.max(1),
        scene,
        settings,
        config,
        exchange,
        fail,
    };
    let mut cache = WaitFree::<Minimal>::new(config, CasFailure::Adopt);
    let mut frames = Vec::with_capacity(cameras.len());
    for camera in cameras {
        let start = Instant::now();
        let mine = if settings.deterministic {
            job.render_deterministic(&mut cache, camera, start)
        } else {
            job.render_frame(&mut cache, camera, start)
        };
        if let Some(frame) = job.assemble(mine, start) {
            frames.push(frame);
        }
    }
    Ok((rank == 0).then_some(frames))
}

/// The fingerprint of a run of frames: [`fingerprint`]'s line and hash for the first camera,
/// with the number of frames and every camera's eye and target hashed in (and the number named
/// in the line when there are several). `cameras` is not empty.
fn frames_fingerprint(
    scene: &Scene,
    cameras: &[Camera],
    settings: &RenderSettings,
    exchange: &Exchange,
) -> (String, u64) {
    let (mut line, print) = fingerprint(scene, &cameras[0], settings, exchange);
    let mut h = Fnv::new();
    h.write(print);
    h.write(cameras.len() as u64);
    for c in cameras {
        for x in c.eye.to_array().into_iter().chain(c.target.to_array()) {
            h.write(u64::from(x.to_bits()));
        }
    }
    if cameras.len() > 1 {
        line.push_str(&format!(", {} frames", cameras.len()));
    }
    (line, h.finish())
}

/// Agreement: every rank gathers every rank's fingerprint of the scene, the settings and the
/// cameras (at least one), so every rank reaches the same verdict.
fn agree(
    world: &SimpleCommunicator,
    scene: &Scene,
    cameras: &[Camera],
    settings: &RenderSettings,
    exchange: &Exchange,
) -> Result<(), DistributedError> {
    let (rank, size) = (world.rank() as u32, world.size() as usize);
    let (line, print) = frames_fingerprint(scene, cameras, settings, exchange);
    let mut prints = vec![0u64; size];
    world.all_gather_into(&print, &mut prints[..]);
    let differing: Vec<u32> = (0..size as u32)
        .filter(|&r| prints[r as usize] != prints[0])
        .collect();
    if differing.is_empty() {
        Ok(())
    } else {
        Err(DistributedError::Mismatch {
            rank,
            mine: line,
            differing,
        })
    }
}

/// What every frame of a distributed render shares on one rank.
struct Job<'a> {
    world: &'a SimpleCommunicator,
    rank: u32,
    size: usize,
    /// This rank's worker threads (at least 1).
    threads: usize,
    scene: &'a Scene,
    settings: &'a RenderSettings,
    config: CacheConfig,
    exchange: &'a Exchange,
    fail: Option<(u32, bool)>,
}

/// What one rank rendered of a frame.
struct RankFrame {
    /// Its tiles' pixels.
    tiles: Vec<(usize, Vec<Vec3>)>,
    /// The records its workers computed.
    computed: Vec<Record>,
    stats: RankStats,
}

impl Job<'_> {
    /// Renders this rank's share of the frame seen by `camera` with `cache`: the workers shade
    /// the tiles the rounds feed them while this (MPI's) thread runs the rounds.
    fn render_frame(
        &self,
        cache: &mut WaitFree<Minimal>,
        camera: &Camera,
        start: Instant,
    ) -> RankFrame {
        let integrator =
            PixelIntegrator::new(self.scene, camera, self.settings, self.config.accuracy());
        let tiles = Tiles::new(self.settings);
        let queue = Queue::new();
        let outbox = Mutex::new(Vec::new());
        let (events, heard) = mpsc::channel();
        let mut rounds = Rounds::new(self, TilePlan::new(tiles.count()), &queue, &outbox, heard);
        // What the workers need of the job (the communicator stays on this thread).
        let (threads, rank, fail) = (self.threads, self.rank, self.fail);
        let batch = self.exchange.batch_records.max(1);
        let frame = cache.frame();
        let outputs = wfic::sync::thread::scope(|s| {
            let render = s.spawn(|| {
                // Moved in: the channel disconnects once every worker has returned.
                let events = events;
                frame.run(threads, |handle, _| {
                    let mut handle = Sending {
                        inner: handle,
                        outbox: &outbox,
                        batch,
                        events: events.clone(),
                    };
                    let source = Fed {
                        queue: &queue,
                        events: events.clone(),
                    };
                    shade(&integrator, &tiles, &source, &mut handle, |_| {
                        fail_if_asked(fail, rank)
                    })
                })
            });
            // The rounds, with a handle of their own for the others' records.
            let mut remote = frame.handle_for(WorkerId::new(self.threads as u32));
            rounds.run(&mut remote);
            drop(remote);
            render
                .join()
                .unwrap_or_else(|p| std::panic::resume_unwind(p))
        });
        let (mut stats, computed) = rounds.finish();
        stats.seconds = start.elapsed().as_secs_f64();
        frame.close();
        stats.cache_records = cache.stats().records as u64;
        let mut counters = SampleCounters::default();
        let mut mine = Vec::new();
        for out in outputs {
            mine.extend(out.blocks);
            counters += out.counters;
        }
        stats.tiles = mine.len();
        stats.ic_samples = counters.ic_samples;
        stats.records_computed = computed.len() as u64;
        RankFrame {
            tiles: mine,
            computed,
            stats,
        }
    }

    /// Renders this rank's share of a deterministic frame ([`crate::deterministic`]) seen by
    /// `camera` with `cache`: every pass is a cache frame of the same number on every rank, whose
    /// tiles are dealt round robin (tile `t` to rank `t mod size`); after its tiles, a rank
    /// gathers every rank's new records with their ids (`MPI_Allgatherv`) and inserts the
    /// others' through the handle of the tile that made them, in that tile's order, so that each
    /// gets the id it has on its own rank. Every rank then holds the records, ids included, that
    /// one process running every tile would, and the next pass sees what it would see.
    fn render_deterministic(
        &self,
        cache: &mut WaitFree<Minimal>,
        camera: &Camera,
        start: Instant,
    ) -> RankFrame {
        let integrator =
            PixelIntegrator::new(self.scene, camera, self.settings, self.config.accuracy());
        let (rank, size) = (self.rank as usize, self.size);
        let mut stats = RankStats {
            rank: self.rank,
            threads: self.threads,
            ..RankStats::default()
        };
        let (mut sent, mut received) = (
            Fnv::new(),
            (0..size).map(|_| Fnv::new()).collect::<Vec<_>>(),
        );
        let (mut counters, mut computed, mut pixels) =
            (SampleCounters::default(), Vec::new(), Vec::new());
        for pass in deterministic::Pass::all(self.settings, Scheme::Wf) {
            let frame = cache.frame();
            let mine: Vec<usize> = (rank..pass.count()).step_by(size).collect();
            // What the workers need of the job (the communicator stays on this thread).
            let (fail, me) = (self.fail, self.rank);
            let done = frame.run_tile_list(self.threads, &mine, |h, t| {
                let mut keeping = Keeping {
                    inner: h,
                    kept: Vec::new(),
                };
                let out = pass.shade(&integrator, &mut keeping, t);
                fail_if_asked(fail, me);
                (out, keeping.kept)
            });
            // This pass's records of this rank's tiles, in id order: by tile, then in each
            // tile's own order.
            let new: Vec<Record> = done
                .iter()
                .flat_map(|(_, kept)| kept.iter().copied())
                .collect();
            let outgoing: Vec<WireRecord> =
                new.iter().map(|r| WireRecord::new(r, self.rank)).collect();
            let incoming = self.all_gather(&outgoing, &mut stats);
            let inserting = Instant::now();
            for w in &outgoing {
                sent.write_record(w);
            }
            let bytes = std::mem::size_of::<WireRecord>() as u64;
            stats.records_sent += outgoing.len() as u64;
            stats.bytes_sent += bytes * outgoing.len() as u64 * (size as u64 - 1);
            let mut handle: Option<(WorkerId, _)> = None;
            for w in incoming.iter().filter(|w| w.origin != self.rank) {
                stats.records_received += 1;
                stats.bytes_received += bytes;
                received[w.origin as usize].write_record(w);
                let id = w.record_id();
                if !matches!(&handle, Some((tile, _)) if *tile == id.worker()) {
                    handle = Some((id.worker(), frame.handle_for(id.worker())));
                }
                let (_, h) = handle.as_mut().expect("the tile's handle");
                let got = h.insert(w.record());
                assert!(
                    stored_as(&got, id),
                    "rank {rank}: record {id} from rank {} came back as {got:?}: the ranks' \
                     caches have diverged",
                    w.origin
                );
                stats.records_inserted += 1;
            }
            drop(handle);
            stats.insert_seconds += inserting.elapsed().as_secs_f64();
            stats.rounds += 1;
            frame.close();
            computed.extend(new);
            for (t, ((p, c), _)) in mine.into_iter().zip(done) {
                counters += c;
                if let deterministic::Pass::Frame(_) = pass {
                    pixels.push((t, p));
                }
            }
        }
        stats.seconds = start.elapsed().as_secs_f64();
        stats.sent_digest = sent.finish();
        stats.received_digests = received.iter().map(Fnv::finish).collect();
        stats.received_digests[rank] = 0;
        stats.cache_records = cache.stats().records as u64;
        stats.tiles = pixels.len();
        stats.ic_samples = counters.ic_samples;
        stats.records_computed = computed.len() as u64;
        RankFrame {
            tiles: pixels,
            computed,
            stats,
        }
    }

    /// Every rank's `outgoing` records, by rank (`MPI_Allgatherv`), the collective timed.
    fn all_gather(&self, outgoing: &[WireRecord], stats: &mut RankStats) -> Vec<WireRecord> {
        let (world, size) = (self.world, self.size);
        let entered = Instant::now();
        let mut counts = vec![0 as Count; size];
        world.all_gather_into(&(outgoing.len() as Count), &mut counts[..]);
        let total: usize = counts.iter().map(|&c| c as usize).sum();
        let mut incoming = vec![WireRecord::default(); total];
        if total > 0 {
            let displs = displacements(&counts);
            let mut partition = PartitionMut::new(&mut incoming[..], &counts[..], &displs[..]);
            world.all_gather_varcount_into(outgoing, &mut partition);
        }
        stats.collective_seconds += entered.elapsed().as_secs_f64();
        incoming
    }

    /// Gathers every rank's tiles, statistics and computed records on rank 0, which assembles
    /// the frame; `None` on the other ranks.
    fn assemble(&self, mine: RankFrame, start: Instant) -> Option<DistributedFrame> {
        let (world, rank) = (self.world, self.rank);
        let root = world.process_at_rank(0);
        let index: Vec<u64> = mine.tiles.iter().map(|(t, _)| *t as u64).collect();
        let pixels: Vec<f32> = mine
            .tiles
            .iter()
            .flat_map(|(_, p)| p.iter().flat_map(|v| v.to_array()))
            .collect();
        let wire: Vec<WireRecord> = mine
            .computed
            .iter()
            .map(|r| WireRecord::new(r, rank))
            .collect();
        let json = serde_json::to_string(&mine.stats).expect("rank statistics serialise");
        let gathered_index = gather(world, &root, &index);
        let gathered_pixels = gather(world, &root, &pixels);
        let gathered_records = gather(world, &root, &wire);
        let gathered_json = gather(world, &root, json.as_bytes());
        if rank != 0 {
            return None;
        }
        let (index, pixels, wire, json) = (
            gathered_index.expect("rank 0 gathers"),
            gathered_pixels.expect("rank 0 gathers"),
            gathered_records.expect("rank 0 gathers"),
            gathered_json.expect("rank 0 gathers"),
        );
        let side = if self.settings.deterministic {
            deterministic::tile_side(self.settings)
        } else {
            self.settings.tile_size
        };
        let tiles = Tiles::sized(self.settings, side);
        let mut image = Image::new(self.settings.width, self.settings.height);
        for (tiles_of_rank, pixels_of_rank) in index.iter().zip(&pixels) {
            let mut values = pixels_of_rank.chunks_exact(3).map(Vec3::from_slice);
            for tile in tiles_of_rank {
                let tile = *tile as usize;
                work::paint(
                    &tiles,
                    tile,
                    values.by_ref().take(tiles.pixel_count(tile)),
                    &mut image,
                );
            }
        }
        let ranks: Vec<RankStats> = json
            .iter()
            .map(|b| serde_json::from_slice(b).expect("a rank's statistics parse"))
            .collect();
        let records: Vec<(u32, Record)> = wire
            .iter()
            .flatten()
            .map(|w| (w.origin, w.record()))
            .collect();
        let duplicates = count_duplicates(&records, self.config.accuracy());
        let seconds = start.elapsed().as_secs_f64();
        Some(DistributedFrame {
            image,
            records,
            stats: DistributedFrameStats::new(ranks, duplicates, seconds),
        })
    }
}

/// Whether a record another rank sent was stored under `id`, the id it has on that rank: in a
/// deterministic frame every rank's cache gives a tile's records the same ids, so any other
/// outcome means the ranks' caches have diverged.
fn stored_as(got: &Result<Inserted, InsertError>, id: RecordId) -> bool {
    matches!(got, Ok(Inserted::Stored(stored)) if *stored == id)
}

/// The failure `--fail-rank` asks for (`fail`, see [`render_distributed_frames`]), if it names `rank`:
/// called after each tile.
fn fail_if_asked(fail: Option<(u32, bool)>, rank: u32) {
    if fail == Some((rank, false)) {
        panic!("rank {rank}: the failure asked for by --fail-rank");
    }
    if fail == Some((rank, true)) {
        eprintln!("rank {rank}: exiting as asked by --fail-rank");
        std::process::exit(3);
    }
}

/// A rank's exchange rounds during one frame, run by its MPI thread.
struct Rounds<'a> {
    job: &'a Job<'a>,
    plan: TilePlan,
    queue: &'a Queue,
    outbox: &'a Mutex<Vec<Record>>,
    events: mpsc::Receiver<Event>,
    /// Workers that have reported [`Event::Finished`].
    finished: usize,
    stats: RankStats,
    sent_digest: Fnv,
    received_digest: Vec<Fnv>,
    computed: Vec<Record>,
}

/// What the ranks agree on at a round: every rank's state.
struct Round {
    /// Per rank: tiles queued, tiles it wants queued, 1 when it is done, records it sends.
    states: Vec<u64>,
    /// The others' records and this rank's own, by rank.
    incoming: Vec<WireRecord>,
}

impl<'a> Rounds<'a> {
    fn new(
        job: &'a Job<'a>,
        plan: TilePlan,
        queue: &'a Queue,
        outbox: &'a Mutex<Vec<Record>>,
        events: mpsc::Receiver<Event>,
    ) -> Self {
        Self {
            stats: RankStats {
                rank: job.rank,
                threads: job.threads,
                received_digests: vec![Fnv::new().finish(); job.size],
                ..RankStats::default()
            },
            received_digest: (0..job.size).map(|_| Fnv::new()).collect(),
            job,
            plan,
            queue,
            outbox,
            events,
            finished: 0,
            sent_digest: Fnv::new(),
            computed: Vec::new(),
        }
    }

    /// Runs rounds until every rank has rendered every tile it was given, no tile is left and
    /// no record is in flight. The first round starts at once.
    fn run(&mut self, remote: &mut impl CacheHandle) {
        let period = Duration::from_millis(self.job.exchange.batch_ms);
        let mut deadline = None;
        loop {
            self.wait_for_round(deadline);
            deadline = Some(Instant::now() + period);
            if self.round(remote) {
                break;
            }
        }
    }

    fn note(&mut self, event: Event) {
        if event == Event::Finished {
            self.finished += 1;
        }
    }

    /// Waits until a round is due: at `deadline` (`None`: now), or as soon as the outbox holds
    /// a batch, the queue holds fewer tiles than there are workers while tiles are left, or every
    /// worker has finished. Sleeps on the workers' events between checks.
    fn wait_for_round(&mut self, deadline: Option<Instant>) {
        let Some(deadline) = deadline else { return };
        let (threads, batch) = (self.job.threads, self.job.exchange.batch_records.max(1));
        loop {
            let pending = wfic::sync::unpoison(self.outbox.lock()).len();
            // A full batch, a queue short of work while tiles are left, or every worker done
            // (`round_due`, which the unit tests pin).
            let starved = (self.queue.len(), self.plan.exhausted());
            if round_due(pending, batch, starved, threads, self.finished) {
                return;
            }
            let Some(left) = deadline.checked_duration_since(Instant::now()) else {
                return;
            };
            // Woken by the workers' events, and every RECHECK in any case: on a loaded machine
            // an event can wait for this thread longer than the conditions above take to hold,
            // and a round that starts late lets the other ranks render what they would have
            // received (the batch sweep's rounds and duplicates).
            match self.events.recv_timeout(left.min(RECHECK)) {
                Ok(event) => self.note(event),
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                // Every worker has returned.
                Err(mpsc::RecvTimeoutError::Disconnected) => return,
            }
        }
    }

    /// One round: takes the outbox, agrees on every rank's state and new records, inserts the
    /// others' records and hands out tiles. Returns whether the frame is over on every rank.
    fn round(&mut self, remote: &mut impl CacheHandle) -> bool {
        // Every event so far: a worker that has reported Finished stored its last record in
        // the outbox before (the channel orders the two), so the outbox taken below holds them.
        while let Ok(event) = self.events.try_recv() {
            self.note(event);
        }
        let done = self.finished == self.job.threads;
        let new = std::mem::take(&mut *wfic::sync::unpoison(self.outbox.lock()));
        let rank = self.job.rank;
        let outgoing: Vec<WireRecord> = if self.job.exchange.share {
            new.iter().map(|r| WireRecord::new(r, rank)).collect()
        } else {
            Vec::new()
        };
        for r in &outgoing {
            for x in r.fields {
                self.sent_digest.write(u64::from(x.to_bits()));
            }
            self.sent_digest.write(u64::from(r.origin));
        }
        self.computed.extend(new);
        let state = [
            self.queue.len() as u64,
            tiles_wanted(self.job.threads),
            u64::from(done), // a worker finishes once the queue closes: the plan is exhausted
            outgoing.len() as u64,
        ];
        let round = self.agree_on(&state, &outgoing);
        if !round.incoming.is_empty() {
            self.insert(&round.incoming, outgoing.len(), remote);
        }
        self.stats.rounds += 1;
        // Every rank sees the same states, so every rank advances the plan the same way.
        let size = self.job.size;
        let states = &round.states;
        let queued: Vec<u64> = (0..size).map(|r| states[4 * r]).collect();
        let want: Vec<u64> = (0..size).map(|r| states[4 * r + 1]).collect();
        let all_done = (0..size).all(|r| states[4 * r + 2] == 1);
        let given = self.plan.hand_out(&queued, &want);
        self.queue.push(given[rank as usize].clone());
        if self.plan.exhausted() {
            self.queue.close();
        }
        all_done && round.incoming.is_empty()
    }

    /// The round's collectives: every rank's `state` (`MPI_Allgather`), then, when any rank
    /// sends records, every rank's `outgoing` (`MPI_Allgatherv`); timed.
    fn agree_on(&mut self, state: &[u64; 4], outgoing: &[WireRecord]) -> Round {
        let (world, size) = (self.job.world, self.job.size);
        let mut states = vec![0u64; 4 * size];
        let entered = Instant::now();
        world.all_gather_into(&state[..], &mut states[..]);
        let counts: Vec<Count> = (0..size).map(|r| states[4 * r + 3] as Count).collect();
        let total: usize = counts.iter().map(|&c| c as usize).sum();
        let mut incoming = vec![WireRecord::default(); total];
        if total > 0 {
            let displs = displacements(&counts);
            let mut partition = PartitionMut::new(&mut incoming[..], &counts[..], &displs[..]);
            world.all_gather_varcount_into(outgoing, &mut partition);
        }
        self.stats.collective_seconds += entered.elapsed().as_secs_f64();
        Round { states, incoming }
    }

    /// Counts the `sent` records this rank sent, and inserts the others' `incoming` records into
    /// the cache through `remote`, digesting them by sender; timed.
    fn insert(&mut self, incoming: &[WireRecord], sent: usize, remote: &mut impl CacheHandle) {
        let inserting = Instant::now();
        let bytes = std::mem::size_of::<WireRecord>() as u64;
        let (rank, size) = (self.job.rank, self.job.size);
        let stats = &mut self.stats;
        stats.records_sent += sent as u64;
        stats.bytes_sent += bytes * sent as u64 * (size as u64 - 1);
        for r in incoming.iter().filter(|r| r.origin != rank) {
            stats.records_received += 1;
            stats.bytes_received += bytes;
            let d = &mut self.received_digest[r.origin as usize];
            for x in r.fields {
                d.write(u64::from(x.to_bits()));
            }
            d.write(u64::from(r.origin));
            if let Ok(Inserted::Stored(_)) = remote.insert(r.record()) {
                stats.records_inserted += 1;
            }
        }
        stats.insert_seconds += inserting.elapsed().as_secs_f64();
    }

    /// The rank's statistics of the rounds, digests included, and the records its workers
    /// computed.
    fn finish(self) -> (RankStats, Vec<Record>) {
        let mut stats = self.stats;
        stats.sent_digest = self.sent_digest.finish();
        stats.received_digests = self.received_digest.iter().map(Fnv::finish).collect();
        stats.received_digests[self.job.rank as usize] = 0;
        (stats, self.computed)
    }
}

/// Records computed where a record that another rank computed is also valid (Ward's weight at the
/// record's own position and normal): work another rank had done or was doing.
pub fn count_duplicates(records: &[(u32, Record)], accuracy: f32) -> u64 {
    records
        .iter()
        .filter(|(rank, r)| {
            records.iter().any(|(other, o)| {
                other != rank && ic::valid_weight(o, r.position, r.normal, accuracy).is_some()
            })
        })
        .count() as u64
}

/// Where each rank's part starts in a variable-count buffer: the running sum of `counts`.
fn displacements(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |at, &c| {
            let d = *at;
            *at += c;
            Some(d)
        })
        .collect()
}

/// Gathers every rank's `mine` on rank 0 (`MPI_Gatherv`), by rank; `None` on the other ranks.
fn gather<T: Equivalence + Default + Clone>(
    world: &SimpleCommunicator,
    root: &mpi::topology::Process<'_>,
    mine: &[T],
) -> Option<Vec<Vec<T>>> {
    let size = world.size() as usize;
    let n = mine.len() as Count;
    if world.rank() == 0 {
        let mut counts = vec![0 as Count; size];
        root.gather_into_root(&n, &mut counts[..]);
        let displs = displacements(&counts);
        let mut all = vec![T::default(); counts.iter().map(|&c| c as usize).sum()];
        {
            let mut partition = PartitionMut::new(&mut all[..], &counts[..], &displs[..]);
            root.gather_varcount_into_root(mine, &mut partition);
        }
        let mut out = Vec::with_capacity(size);
        for (d, c) in displs.iter().zip(&counts) {
            out.push(all[*d as usize..(*d + *c) as usize].to_vec());
        }
        Some(out)
    } else {
        root.gather_into(&n);
        root.gather_varcount_into(mine);
        None
    }
}

/// The tiles a rank of `threads` workers asks to hold queued at a round: two a worker, so that
/// each has the next at hand while the round runs.
fn tiles_wanted(threads: usize) -> u64 {
    2 * threads as u64
}

/// Whether a round is due now ([`Rounds::wait_for_round`]): the outbox holds a batch (`pending`
/// records of `batch`), the queue holds fewer tiles than there are workers while the plan has
/// tiles left (`starved`: the queue's length and whether the plan is exhausted), or all
/// `threads` workers have finished.
fn round_due(
    pending: usize,
    batch: usize,
    starved: (usize, bool),
    threads: usize,
    finished: usize,
) -> bool {
    let (queued, exhausted) = starved;
    pending >= batch || (queued < threads && !exhausted) || finished == threads
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_crosses_the_wire_whole() {
        let r = Record::new(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::Z,
            Vec3::new(0.1, 0.2, 0.3),
            0.7,
        )
        .with_gradients(
            [Vec3::X, Vec3::Y * 2.0, Vec3::Z * 3.0],
            [Vec3::ONE, Vec3::NEG_ONE, Vec3::splat(0.5)],
        );
        let w = WireRecord::new(&r, 5);
        let back = w.record();
        assert_eq!(back.position, r.position);
        assert_eq!(back.normal, r.normal);
        assert_eq!(back.irradiance, r.irradiance);
        assert_eq!(back.radius, r.radius);
        assert_eq!(back.grad_t, r.grad_t);
        assert_eq!(back.grad_r, r.grad_r);
        assert_eq!(w.origin, 5);
        // The digest sees every field and the order.
        let mut other = w;
        other.fields[27] += 1.0;
        assert_ne!(WireRecord::digest(&[w]), WireRecord::digest(&[other]));
        assert_ne!(
            WireRecord::digest(&[w, other]),
            WireRecord::digest(&[other, w])
        );
    }

    #[test]
    fn a_record_keeps_its_id_across_the_wire() {
        let id = RecordId::new(WorkerId::new(3), 0xabcd, 0x1234_5678);
        let r = Record::new(Vec3::ONE, Vec3::Z, Vec3::ONE, 1.0).sealed(id);
        let back = WireRecord::new(&r, 1).record_id();
        assert_eq!(back, id);
        assert_eq!(
            (back.worker(), back.frame(), back.seq()),
            (WorkerId::new(3), 0xabcd, 0x1234_5678)
        );
    }

    /// `Fnv` is FNV-1a over each word's eight little-endian bytes.
    #[test]
    fn fnv_is_fnv_1a_over_each_words_bytes() {
        let reference = |bytes: &[u8]| {
            bytes.iter().fold(0xcbf2_9ce4_8422_2325_u64, |h, &b| {
                (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
            })
        };
        // The reference against FNV-1a's published 64-bit test vectors (Fowler, Noll and Vo).
        assert_eq!(reference(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(reference(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(reference(b"foobar"), 0x8594_4171_f739_67e8);
        let words = [0x61, 0x0123_4567_89ab_cdef, u64::MAX, 0];
        let mut h = Fnv::new();
        for w in words {
            h.write(w);
        }
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        assert_eq!(h.finish(), reference(&bytes));
    }

    /// The Cornell box from its camera at 32 x 24, with the default exchange.
    fn cornell_32x24() -> (Scene, Camera, RenderSettings, Exchange) {
        let scene = crate::scenes::cornell().unwrap();
        let camera = scene.camera();
        (
            scene,
            camera,
            RenderSettings::new(32, 24),
            Exchange::default(),
        )
    }

    /// The fingerprint is the same for the same frame and differs when a setting does.
    #[test]
    fn the_fingerprint_names_the_settings_and_tells_them_apart() {
        let (scene, camera, settings, exchange) = cornell_32x24();
        let (line, print) = fingerprint(&scene, &camera, &settings, &exchange);
        assert!(line.starts_with("scene cornell ("), "{line}");
        assert!(line.contains("32x24"), "{line}");
        assert_eq!(
            fingerprint(&scene, &camera, &settings, &exchange),
            (line.clone(), print)
        );
        let mut reseeded = settings.clone();
        reseeded.seed = 7;
        let (other_line, other) = fingerprint(&scene, &camera, &reseeded, &exchange);
        assert_ne!(other_line, line);
        assert_ne!(other, print);
    }

    /// A run of frames is told apart by its number of frames and by any camera, and its line
    /// names the number when there are several.
    #[test]
    fn the_frames_fingerprint_covers_every_camera_and_names_the_count() {
        let (scene, camera, settings, exchange) = cornell_32x24();
        let print = |cameras: &[Camera]| frames_fingerprint(&scene, cameras, &settings, &exchange);
        let (one_line, one) = print(&[camera]);
        assert_eq!(
            one_line,
            fingerprint(&scene, &camera, &settings, &exchange).0
        );
        assert!(!one_line.contains("frames"), "{one_line}");
        let (two_line, two) = print(&[camera, camera]);
        assert!(two_line.ends_with(", 2 frames"), "{two_line}");
        assert_ne!(two, one);
        let mut moved = camera;
        moved.eye.x += 0.5;
        let (moved_line, moved_print) = print(&[camera, moved]);
        assert_eq!(moved_line, two_line, "the line names the first camera only");
        assert_ne!(moved_print, two, "the hash sees the second camera");
        assert_eq!(print(&[camera, camera]).1, two);
    }

    /// A received record counts as inserted only if stored under its own id.
    #[test]
    fn a_received_record_must_keep_its_id() {
        let id = RecordId::new(WorkerId::new(3), 2, 7);
        let other = RecordId::new(WorkerId::new(3), 2, 8);
        assert!(stored_as(&Ok(Inserted::Stored(id)), id));
        assert!(!stored_as(&Ok(Inserted::Stored(other)), id));
        assert!(!stored_as(&Ok(Inserted::Discarded(id)), id));
    }

    #[test]
    fn a_rank_asks_for_two_tiles_a_worker() {
        assert_eq!(tiles_wanted(1), 2);
        assert_eq!(tiles_wanted(3), 6);
    }

    /// A round starts on a full batch, a starved queue with tiles left, or every worker done,
    /// and not otherwise.
    #[test]
    fn a_round_is_due_on_a_batch_a_starved_queue_or_the_end() {
        // Two workers, batches of 4, two tiles queued, tiles left, nobody finished: wait.
        let (batch, threads, fed) = (4, 2, (2, false));
        assert!(!round_due(3, batch, fed, threads, 0), "a batch short: wait");
        assert!(round_due(4, batch, fed, threads, 0), "a full batch");
        assert!(round_due(9, batch, fed, threads, 0), "more than a batch");
        assert!(
            round_due(0, batch, (1, false), threads, 0),
            "a starved queue"
        );
        assert!(
            !round_due(0, batch, (1, true), threads, 0),
            "starved, nothing left to give"
        );
        assert!(
            !round_due(0, batch, (1, true), threads, 1),
            "one worker still at work"
        );
        assert!(
            round_due(0, batch, (0, true), threads, 2),
            "every worker done"
        );
    }

    #[test]
    fn an_exchange_out_of_its_ranges_is_refused_by_name() {
        assert_eq!(Exchange::default().validate(), Ok(()));
        let none = Exchange {
            batch_records: 0,
            ..Exchange::default()
        };
        let slow = Exchange {
            batch_ms: 3_600_001,
            ..Exchange::default()
        };
        assert!(none
            .validate()
            .unwrap_err()
            .to_string()
            .contains("batch_records 0"));
        assert!(slow
            .validate()
            .unwrap_err()
            .to_string()
            .contains("batch_ms 3600001"));
        let panic = std::panic::catch_unwind(|| none.assert_valid()).expect_err("refused");
        let message = panic.downcast_ref::<String>().unwrap();
        assert!(
            message.starts_with("invalid exchange: batch_records 0"),
            "{message}"
        );
    }

    /// A cache in its third frame (frame 2), holding two records of frame 0 near (1, 1, 1).
    fn cache_in_frame_2() -> WaitFree<Minimal> {
        let config = wfic::cache::CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.3).unwrap();
        let mut cache = WaitFree::<Minimal>::new(config, CasFailure::Adopt);
        cache.frame().run(1, |h, _| {
            for x in [1.0, 1.05] {
                h.insert(at(x)).unwrap();
            }
        });
        cache.frame().run(1, |_, _| ());
        cache
    }

    fn at(x: f32) -> Record {
        Record::new(Vec3::new(x, 1.0, 1.0), Vec3::Z, Vec3::ONE, 0.5)
    }

    /// What a wrapping handle must pass through to the cache's own: its worker and frame, the
    /// visible lookup, the valid records, the statistics and the removal's count.
    fn passes_through(h: &mut impl CacheHandle, worker: WorkerId) {
        let p = Vec3::ONE;
        assert_eq!(h.worker(), worker);
        assert_eq!(h.frame(), 2);
        let visible = wfic::cache::Visibility::new(2, worker);
        assert!(
            h.lookup_visible(p, Vec3::Z, visible).is_some(),
            "frame 0's records are visible"
        );
        let mut out = Vec::new();
        h.valid_records(p, Vec3::Z, &mut out);
        assert_eq!(out.len(), 2);
        assert!(h.stats().lookups > 0, "the lookup was counted");
        assert_eq!(
            h.remove(&Selection::older_than(0)),
            2,
            "frame 0's two records"
        );
    }

    #[test]
    fn the_sending_handle_passes_calls_through_and_says_when_a_batch_is_full() {
        let mut cache = cache_in_frame_2();
        cache.frame().run(1, |h, worker| {
            let (events, heard) = mpsc::channel();
            let outbox = Mutex::new(Vec::new());
            let mut sending = Sending {
                inner: h,
                outbox: &outbox,
                batch: 2,
                events,
            };
            passes_through(&mut sending, worker);
            sending.insert(at(3.0)).unwrap();
            assert!(heard.try_recv().is_err(), "one record: no batch yet");
            sending.insert(at(2.0)).unwrap();
            assert_eq!(heard.try_recv(), Ok(Event::Batch));
            sending.insert(at(0.5)).unwrap();
            assert!(heard.try_recv().is_err(), "a batch is said once");
            assert_eq!(wfic::sync::unpoison(outbox.lock()).len(), 3);
        });
    }

    #[test]
    fn the_keeping_handle_passes_calls_through_and_keeps_what_it_stores() {
        let mut cache = cache_in_frame_2();
        cache.frame().run(1, |h, worker| {
            let mut keeping = Keeping {
                inner: h,
                kept: Vec::new(),
            };
            passes_through(&mut keeping, worker);
            let Inserted::Stored(id) = keeping.insert(at(3.0)).unwrap() else {
                panic!("stored")
            };
            assert_eq!(keeping.kept.len(), 1);
            assert_eq!(keeping.kept[0].id(), id);
        });
    }

    #[test]
    fn tiles_go_to_the_ranks_short_of_work_in_rank_order() {
        let mut plan = TilePlan::new(10);
        // Both ranks empty: rank 0 (2 threads: wants 4) gets 0..4, rank 1 (1 thread) 4..6.
        assert_eq!(plan.hand_out(&[0, 0], &[4, 2]), vec![0..4, 4..6]);
        // Rank 0 still has 4 (not below its 4), rank 1 has 1: only rank 1 gets more.
        assert_eq!(plan.hand_out(&[4, 1], &[4, 2]), vec![6..6, 6..8]);
        assert!(!plan.exhausted());
        // The last chunk is short; then nothing is left.
        assert_eq!(plan.hand_out(&[0, 0], &[4, 2]), vec![8..10, 10..10]);
        assert!(plan.exhausted());
        assert_eq!(plan.hand_out(&[0, 0], &[4, 2]), vec![10..10, 10..10]);
    }

    #[test]
    fn duplicates_are_records_another_rank_covered() {
        let at = |x: f32| Record::new(Vec3::new(x, 0.0, 0.0), Vec3::Z, Vec3::ONE, 1.0);
        // Ranks 0 and 1 at almost the same place: both duplicates; rank 1's far record is not.
        let records = vec![(0, at(0.0)), (1, at(0.01)), (1, at(50.0))];
        assert_eq!(count_duplicates(&records, 0.25), 2);
        // The same two points from one rank: not duplicates.
        let records = vec![(0, at(0.0)), (0, at(0.01))];
        assert_eq!(count_duplicates(&records, 0.25), 0);
    }
}
