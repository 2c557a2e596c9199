//! The frame protocol, as types.
//!
//! A renderer uses a cache in frames: workers share it by reference while the frame runs, each
//! through its own handle, and the frame is closed with `&mut` access (LW merges there). The rules
//! that keep record ids unique and keep every worker's records and counters are enforced here,
//! not written in prose:
//!
//! | misuse | what happens |
//! |---|---|
//! | two handles with one worker id in a frame | panic at the second [`IrradianceCache::handle`], naming the id and the frame |
//! | a handle dropped without "finishing" | nothing is lost: a handle leaves its counters (and LW's local records) in the cache's ledger when it is dropped, also when its worker unwinds from a panic |
//! | a residue given to the wrong cache | impossible: there are no residues to pass; each cache collects its own handles' deposits |
//! | closing a frame while a handle is alive | a compile error: handles borrow the cache, [`IrradianceCache::end_frame`] takes `&mut self` |
//! | a skipped `end_frame` | with [`Frame`], impossible (dropping a frame closes it); with the low-level API, a worker id reused in the still-open frame panics, so record ids never repeat |
//! | a leaked handle (`mem::forget`) | `end_frame` panics naming the workers whose handles never came back |
//!
//! [`Frame`] (from [`IrradianceCache::frame`]) is the entry point for callers: it hands out
//! handles with distinct worker ids, runs workers on scoped threads ([`Frame::run`]) or on a rayon
//! pool (`Frame::run_on_pool`, feature `rayon`), and closes the frame. [`run_frame`] is the one-call form.
//!
//! The low-level [`IrradianceCache::handle`] and [`IrradianceCache::end_frame`] stay for the loom
//! and shuttle models (which spawn the checkers' own threads) and for benchmarks whose worker
//! threads outlive a frame; the ledger makes their misuse loud as well.
//!
//! A frame may be dropped without [`Frame::close`]; it closes itself then (the report is lost):
//!
//! ```compile_fail
//! #![deny(unused_must_use)]
//! use glam::Vec3;
//! use wfic::cache::{CacheConfig, IrradianceCache, Sequential};
//! let mut cache = Sequential::new(CacheConfig::new(Vec3::ZERO, Vec3::ONE, 0.3).unwrap());
//! cache.frame(); // error: unused `Frame` that must be used
//! ```
//!
//! and a handle that is made and never used is a warning too (an error here):
//!
//! ```compile_fail
//! #![deny(unused_must_use)]
//! use glam::Vec3;
//! use wfic::cache::{CacheConfig, IrradianceCache, LocalWrite};
//! let mut cache = LocalWrite::new(CacheConfig::new(Vec3::ZERO, Vec3::ONE, 0.3).unwrap());
//! let frame = cache.frame();
//! frame.handle(); // error: unused `LwHandle` that must be used
//! frame.close();
//! ```
//!
//! A handle cannot outlive its frame:
//!
//! ```compile_fail,E0505
//! use glam::Vec3;
//! use wfic::cache::{CacheConfig, IrradianceCache, WaitFree};
//! let mut cache = WaitFree::adopt(CacheConfig::new(Vec3::ZERO, Vec3::ONE, 0.3).unwrap());
//! let frame = cache.frame();
//! let handle = frame.handle();
//! frame.close(); // error: `frame` is borrowed by `handle`
//! drop(handle);
//! ```
//!
//! and no frame can be closed while a low-level handle is alive:
//!
//! ```compile_fail,E0502
//! use glam::Vec3;
//! use wfic::cache::{CacheConfig, IrradianceCache, Locked, MutexFlavour};
//! use wfic::ic::WorkerId;
//! let mut cache = Locked::<MutexFlavour>::new(CacheConfig::new(Vec3::ZERO, Vec3::ONE, 0.3).unwrap());
//! let handle = cache.handle(WorkerId::new(0));
//! cache.end_frame(); // error: `cache` is borrowed by `handle`
//! drop(handle);
//! ```

use super::{
    CacheConfig, CacheStats, FrameReport, Inserted, IrradianceCache, Visibility, WorkerStats,
};
use crate::ic::WorkerId;
use crate::ic::{self, Accumulator, InsertError, Interpolated, Record, RecordId};
use crate::sync::unchecked::{self, AtomicU32, AtomicU64};
use crate::sync::unpoison;
use glam::Vec3;
use std::collections::HashSet;
use std::fmt;

/// What a dropped handle leaves in its cache's ledger.
#[derive(Debug)]
pub(crate) struct Deposit<X> {
    /// The handle's worker.
    pub worker: WorkerId,
    /// Its counters.
    pub stats: WorkerStats,
    /// The scheme's own part: nothing, or LW's local octree.
    pub local: X,
}

/// The part of a handle's state that is the scheme's own and goes to `end_frame`.
pub(crate) trait Local: Send {
    /// Moves the contents out, leaving something that is only dropped.
    fn take(&mut self) -> Self;
}

impl Local for () {
    fn take(&mut self) {}
}

/// Per-cache bookkeeping of the open frame: which worker ids have a handle, and what the dropped
/// handles left. Locked when a handle is made and when it is dropped, never on a lookup or an
/// insert.
pub(crate) struct Ledger<X> {
    /// A number for this cache, for messages.
    cache: u64,
    state: unchecked::Mutex<LedgerState<X>>,
}

struct LedgerState<X> {
    /// The open frame's number (frames closed so far).
    frame: u64,
    /// Worker ids given a handle in the open frame (a set: a deterministic frame gives every tile
    /// its own handle, thousands a frame).
    issued: HashSet<WorkerId>,
    /// What the dropped handles of the open frame left.
    deposits: Vec<Deposit<X>>,
}

impl<X> fmt::Debug for Ledger<X> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Ledger(cache #{})", self.cache)
    }
}

/// Numbers the caches of this process, for messages.
static NEXT_CACHE: AtomicU64 = AtomicU64::new(0);

impl<X: Local> Ledger<X> {
    pub fn new() -> Self {
        Self {
            // Relaxed: the number only has to be unique, which `fetch_add`'s atomicity gives; it
            // publishes nothing.
            cache: NEXT_CACHE.fetch_add(1, unchecked::Ordering::Relaxed),
            state: unchecked::Mutex::new(LedgerState {
                frame: 0,
                issued: HashSet::new(),
                deposits: Vec::new(),
            }),
        }
    }

    /// Registers a handle for `worker` in the open frame and returns the frame's number.
    ///
    /// # Panics
    /// If `worker` already has a handle in the open frame.
    pub fn issue(&self, worker: WorkerId) -> u64 {
        let mut state = unpoison(self.state.lock());
        let frame = state.frame;
        if !state.issued.insert(worker) {
            drop(state);
            panic!(
                "{worker} already has a handle in frame {frame} of cache #{}: one handle per \
                 worker id per frame (ids come from `Frame`; with the low-level API, was \
                 `end_frame` skipped?)",
                self.cache
            );
        }
        frame
    }

    /// Closes the open frame for an `end_frame`: returns what its handles left and the frame's
    /// report (their counters summed), and adds the frame to `stats` (totals, frame count).
    /// A scheme with work of its own at the barrier (LW's merge) adds it to the report.
    pub fn close_frame(&mut self, stats: &mut CacheStats) -> (Vec<Deposit<X>>, FrameReport) {
        let deposits = self.close();
        let mut report = FrameReport::default();
        deposits.iter().for_each(|d| report.workers += &d.stats);
        stats.totals += &report.workers;
        stats.frames += 1;
        (deposits, report)
    }

    /// Keeps what a dropped handle left, for `end_frame`.
    pub fn deposit(&self, deposit: Deposit<X>) {
        unpoison(self.state.lock()).deposits.push(deposit);
    }

    /// Closes the open frame and returns what its handles left.
    ///
    /// # Panics
    /// If a handle of the frame was never dropped (leaked): its counters, and LW's records, would
    /// be lost. (Not while the thread is already unwinding: then the frame is closed with what
    /// came back, and the loss is printed.)
    pub fn close(&mut self) -> Vec<Deposit<X>> {
        let cache = self.cache;
        let state = unpoison(self.state.get_mut());
        let back: HashSet<WorkerId> = state.deposits.iter().map(|d| d.worker).collect();
        let mut missing: Vec<WorkerId> = state.issued.difference(&back).copied().collect();
        missing.sort_unstable();
        let missing: Vec<String> = missing.iter().map(WorkerId::to_string).collect();
        let frame = state.frame;
        state.issued.clear();
        state.frame += 1;
        let deposits = std::mem::take(&mut state.deposits);
        if !missing.is_empty() {
            let message = format!(
                "end_frame of frame {frame} of cache #{cache}: the handle(s) of {} never came \
                 back (leaked, e.g. with `mem::forget`): their counters and unmerged records are lost",
                missing.join(", ")
            );
            if std::thread::panicking() {
                eprintln!("{message}");
            } else {
                panic!("{message}");
            }
        }
        deposits
    }
}

/// One frame of a cache: hands out handles with distinct worker ids, runs workers, closes.
///
/// Made by [`IrradianceCache::frame`]; it borrows the cache mutably for the frame's whole life, so
/// nothing else can close the frame or reach the cache's `&mut` operations meanwhile. Dropping it
/// closes the frame; [`Frame::close`] closes it and returns the report.
#[must_use = "a frame is used through its handles; dropping it at once closes an empty frame"]
pub struct Frame<'c, C: IrradianceCache> {
    cache: &'c mut C,
    /// The next worker id [`Frame::handle`] gives out.
    next_worker: AtomicU32,
    /// Set by [`Frame::close`], so that `Drop` does not close the frame again.
    closed: bool,
}

impl<'c, C: IrradianceCache> Frame<'c, C> {
    /// The most worker threads [`Frame::run`] starts: one per worker id ([`WorkerId::MAX`] + 1).
    pub const MAX_THREADS: usize = WorkerId::MAX as usize + 1;

    /// Opens a frame of `cache` (the same as [`IrradianceCache::frame`]).
    pub fn new(cache: &'c mut C) -> Self {
        Self {
            cache,
            next_worker: AtomicU32::new(0),
            closed: false,
        }
    }

    /// The cache, shared.
    pub fn cache(&self) -> &C {
        self.cache
    }

    /// A handle with the next worker id (0, 1, 2, … in the order of the calls).
    ///
    /// # Panics
    /// If that id was already taken with [`Frame::handle_for`].
    pub fn handle(&self) -> C::Handle<'_> {
        // Relaxed: the counter only has to give each call a distinct number, which `fetch_add`'s
        // atomicity guarantees; nothing is published through it.
        let n = self.next_worker.fetch_add(1, unchecked::Ordering::Relaxed);
        self.cache.handle(WorkerId::new(n))
    }

    /// A handle for `worker`, for callers that number their own workers (a pool's thread index,
    /// a previous frame's worker).
    ///
    /// # Panics
    /// If `worker` already has a handle in this frame.
    pub fn handle_for(&self, worker: WorkerId) -> C::Handle<'_> {
        self.cache.handle(worker)
    }

    /// Runs `work` on `threads` scoped threads, worker `i` with worker id `i` and its own handle
    /// (made on the worker's thread, dropped when `work` returns); returns what each returned, in
    /// worker order. A worker's panic is resumed here after every worker has joined; the frame
    /// keeps what the panicked worker's handle left.
    ///
    /// # Panics
    /// - If `threads` is 0 (`a frame needs at least one worker thread`) or above
    ///   [`Frame::MAX_THREADS`] (`N worker threads: at most 65536`), before any thread starts.
    /// - If the operating system refuses to start a thread (`could not start worker thread I of
    ///   N: ...`), after the threads already started have finished their work. Near the system's
    ///   limits (memory maps, for tens of thousands of threads) the standard library may instead
    ///   abort the process while it sets up a started thread's signal stack, which no caller can
    ///   catch: a program that takes the count from its user bounds it well below (the `wfic`
    ///   command line allows 1024).
    /// - If a worker panics.
    /// - Calling `run` (or `Frame::run_on_pool`) a second time on the same frame panics too:
    ///   worker ids `0..threads` already have their handles in this frame, and a frame gives each
    ///   worker id one handle. Open a new frame for another pass.
    #[cfg(not(checker))]
    pub fn run<'f, T, F>(&'f self, threads: usize, work: F) -> Vec<T>
    where
        T: Send,
        F: Fn(&mut C::Handle<'f>, WorkerId) -> T + Sync,
    {
        assert!(threads > 0, "a frame needs at least one worker thread");
        assert!(
            threads <= Self::MAX_THREADS,
            "{threads} worker threads: at most {}",
            Self::MAX_THREADS
        );
        let work = &work;
        crate::sync::thread::scope(|s| {
            let workers: Vec<_> = (0..threads)
                .map(|i| {
                    let id = WorkerId::new(u32::try_from(i).unwrap_or(u32::MAX));
                    crate::sync::thread::Builder::new()
                        .spawn_scoped(s, move || {
                            let mut handle = self.handle_for(id);
                            work(&mut handle, id)
                        })
                        .unwrap_or_else(|e| {
                            panic!("could not start worker thread {i} of {threads}: {e}")
                        })
                })
                .collect();
            let mut out = Vec::with_capacity(threads);
            let mut panic = None;
            for worker in workers {
                match worker.join() {
                    Ok(value) => out.push(value),
                    Err(payload) => {
                        panic.get_or_insert(payload);
                    }
                }
            }
            if let Some(payload) = panic {
                std::panic::resume_unwind(payload);
            }
            out
        })
    }

    /// Runs `work` once on every thread of `pool` ([`rayon::ThreadPool::broadcast`]): the thread
    /// with index `i` gets worker id `i` and its own handle, so a renderer that lives on rayon
    /// shares the cache with exactly one handle per pool thread. Returns the results in thread
    /// index order. Needs the `rayon` feature.
    ///
    /// # Panics
    /// If a worker panics, or if a pool thread's worker id already has a handle in this frame
    /// (this frame was already run).
    #[cfg(all(feature = "rayon", not(checker)))]
    pub fn run_on_pool<'f, T, F>(&'f self, pool: &rayon::ThreadPool, work: F) -> Vec<T>
    where
        T: Send,
        F: Fn(&mut C::Handle<'f>, WorkerId) -> T + Sync,
    {
        pool.broadcast(|ctx| {
            let id = WorkerId::new(u32::try_from(ctx.index()).unwrap_or(u32::MAX));
            let mut handle = self.handle_for(id);
            work(&mut handle, id)
        })
    }

    /// Closes the frame ([`IrradianceCache::end_frame`]: LW merges there) and returns its report.
    pub fn close(mut self) -> FrameReport {
        self.closed = true;
        self.cache.end_frame()
    }
}

impl<C: IrradianceCache> Drop for Frame<'_, C> {
    fn drop(&mut self) {
        if !self.closed {
            self.cache.end_frame();
        }
    }
}

/// Runs one frame of `cache` on `threads` scoped threads ([`Frame::run`]) and closes it: the
/// results in worker order, and the frame's report.
///
/// ```
/// use glam::Vec3;
/// use wfic::cache::{run_frame, CacheConfig, CacheHandle, WaitFree};
/// use wfic::ic::Record;
///
/// let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), 0.3).unwrap();
/// let mut cache = WaitFree::adopt(config);
/// let (found, report) = run_frame(&mut cache, 2, |handle, worker| {
///     let p = Vec3::new(2.0 + 4.0 * worker.index() as f32, 5.0, 5.0);
///     handle.insert(Record::new(p, Vec3::Z, Vec3::ONE, 1.0)).unwrap();
///     handle.lookup(p, Vec3::Z).is_some()
/// });
/// assert_eq!(found, [true, true]);
/// assert_eq!(report.workers.stored, 2);
/// ```
#[cfg(not(checker))]
pub fn run_frame<C, T, F>(cache: &mut C, threads: usize, work: F) -> (Vec<T>, FrameReport)
where
    C: IrradianceCache,
    T: Send,
    F: for<'f> Fn(&mut C::Handle<'f>, WorkerId) -> T + Sync,
{
    let frame = cache.frame();
    let out = frame.run(threads, &work);
    (out, frame.close())
}

/// The bookkeeping every handle shares: identity, record numbering, counters, the scheme's own
/// part (`X`: LW's local octree), and the ledger it goes back to when the handle is dropped.
#[derive(Debug)]
pub(crate) struct HandleCore<'c, X: Local> {
    pub worker: WorkerId,
    pub frame: u64,
    pub next_seq: u64,
    pub stats: WorkerStats,
    pub local: X,
    /// What the valid records a [`HandleCore::lookup_visible`] met contribute, with their keys,
    /// collected before they are summed in order; kept so that a lookup does not allocate.
    found: Vec<((RecordId, u64), ic::Contribution)>,
    ledger: &'c Ledger<X>,
}

impl<X: Local> Drop for HandleCore<'_, X> {
    fn drop(&mut self) {
        self.ledger.deposit(Deposit {
            worker: self.worker,
            stats: self.stats,
            local: self.local.take(),
        });
    }
}

impl<'c, X: Local> HandleCore<'c, X> {
    /// Registers a handle for `worker` in `ledger`'s open frame.
    ///
    /// # Panics
    /// If `worker` already has a handle in that frame.
    pub fn new(ledger: &'c Ledger<X>, worker: WorkerId, local: X) -> Self {
        let frame = ledger.issue(worker);
        Self {
            worker,
            frame,
            next_seq: 0,
            stats: WorkerStats::default(),
            local,
            found: Vec::new(),
            ledger,
        }
    }

    /// Validates and seals a record for `config`, counting it.
    #[inline]
    pub fn admit(
        &mut self,
        config: &CacheConfig,
        mut record: Record,
    ) -> Result<Record, InsertError> {
        if let Err(e) = config.check(&record) {
            self.stats.rejected += 1;
            return Err(e);
        }
        let id = RecordId::new(self.worker, self.frame, self.next_seq);
        self.next_seq += 1;
        record.seal(id);
        self.stats.inserts += 1;
        Ok(record)
    }

    /// Counts an insert's outcome and steps.
    #[inline]
    pub fn inserted(&mut self, outcome: Inserted, steps: u32) -> Inserted {
        match outcome {
            Inserted::Stored(_) => self.stats.stored += 1,
            Inserted::Discarded(_) => self.stats.discarded += 1,
            Inserted::NotCached(_) => {}
        }
        self.stats.max_insert_steps = self.stats.max_insert_steps.max(steps);
        outcome
    }

    /// Counts one traversal's work: a lookup's, or a `valid_records` call's (which is not a lookup:
    /// `lookups` and `hits` are left alone).
    #[inline]
    pub fn traversed(&mut self, work: Work) {
        let s = &mut self.stats;
        s.max_lookup_nodes = s.max_lookup_nodes.max(work.nodes);
        s.max_lookup_records = s.max_lookup_records.max(work.records);
        s.lookup_nodes += u64::from(work.nodes);
        s.lookup_records += u64::from(work.records);
    }

    /// A fresh accumulator for a query by this worker, or `None` for a query that cannot be answered.
    #[inline]
    pub fn begin_lookup(
        &mut self,
        config: &CacheConfig,
        point: Vec3,
        normal: Vec3,
    ) -> Option<Accumulator> {
        self.stats.lookups += 1;
        ic::is_valid_query(point, normal)
            .then(|| Accumulator::new(point, normal, config.accuracy(), Some(self.worker)))
    }

    /// Counts a lookup's outcome and its work.
    #[inline]
    pub fn end_lookup(&mut self, acc: &Accumulator, work: Work) -> Option<Interpolated> {
        self.traversed(work);
        let out = acc.finish();
        if let Some(hit) = &out {
            self.stats.hits += 1;
            if hit.foreign > 0 {
                self.stats.shared_hits += 1;
            }
        }
        out
    }
}

impl<X: Local> HandleCore<'_, X> {
    /// [`CacheHandle::lookup_visible`](super::CacheHandle::lookup_visible) through a cache's
    /// `walk` (given the query's prefilter, the handle's own part and a visitor for the records
    /// it admits): weighs the valid records `visible` admits, sorts their contributions by
    /// [`Record::canonical_key`] and only then sums them, so the floating-point sum is the same
    /// whatever order the walk met them in.
    #[inline]
    pub fn lookup_visible(
        &mut self,
        config: &CacheConfig,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
        walk: impl FnOnce(&ic::Prefilter, &X, &mut dyn FnMut(&Record)) -> Work,
    ) -> Option<Interpolated> {
        let mut acc = self.begin_lookup(config, point, normal)?;
        let found = &mut self.found;
        found.clear();
        let work = walk(acc.prefilter(), &self.local, &mut |r: &Record| {
            if visible.admits(r.id()) {
                if let Some(c) = acc.weigh(r) {
                    found.push((r.canonical_key(), c));
                }
            }
        });
        found.sort_unstable_by_key(|(key, _)| *key);
        for &(_, c) in found.iter() {
            acc.take(c);
        }
        self.end_lookup(&acc, work)
    }
}

/// What one traversal of a cache did: the nodes it visited and the records it examined (read from
/// those nodes' lists, valid or not).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Work {
    pub nodes: u32,
    pub records: u32,
}

impl std::ops::AddAssign for Work {
    fn add_assign(&mut self, other: Work) {
        self.nodes += other.nodes;
        self.records += other.records;
    }
}

/// Collects the records a query would use, through any cache's walk (given the query's prefilter
/// and a visitor for the records it admits); returns the walk's work (none for a query that
/// cannot be answered).
pub(crate) fn collect_valid(
    config: &CacheConfig,
    point: Vec3,
    normal: Vec3,
    out: &mut Vec<Record>,
    walk: impl FnOnce(&ic::Prefilter, &mut dyn FnMut(&Record)) -> Work,
) -> Work {
    if !ic::is_valid_query(point, normal) {
        return Work::default();
    }
    let pre = ic::Prefilter::new(point, normal, config.accuracy());
    walk(&pre, &mut |r: &Record| {
        if ic::valid_weight(r, point, normal, config.accuracy()).is_some() {
            out.push(*r);
        }
    })
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::cache::{CacheHandle, CacheJob, Inserted, Scheme};
    use crate::ic::Record;
    use glam::Vec3;
    use std::panic::{catch_unwind, AssertUnwindSafe};

    fn config() -> crate::cache::CacheConfig {
        crate::cache::CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), 0.3).unwrap()
    }

    fn record(x: f32) -> Record {
        Record::new(Vec3::new(x, 5.0, 5.0), Vec3::Z, Vec3::ONE, 1.0)
    }

    /// The message of the panic `f` raises (`None` when it does not panic).
    fn panic_message(f: impl FnOnce()) -> Option<String> {
        let out = catch_unwind(AssertUnwindSafe(f));
        out.err().map(|p| {
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| (*s).to_owned()))
                .unwrap_or_default()
        })
    }

    /// Runs `job` on a fresh cache of every scheme, the reference included.
    fn for_every_scheme<J: CacheJob<Output = ()> + Copy>(job: J) {
        for scheme in Scheme::ALL {
            scheme.build(config(), job);
        }
    }

    /// A second handle for the same worker id in one frame panics, naming the id and the frame.
    #[derive(Clone, Copy)]
    struct DuplicateIds;
    impl CacheJob for DuplicateIds {
        type Output = ();
        fn run<C: IrradianceCache>(self, mut cache: C) {
            let scheme = cache.scheme();
            let frame = cache.frame();
            let first = frame.handle_for(WorkerId::new(3));
            // TRA: the check comes before the octree's lock, which `first` holds.
            let message = panic_message(|| drop(frame.handle_for(WorkerId::new(3))))
                .unwrap_or_else(|| panic!("{scheme}: a duplicate worker id was accepted"));
            assert!(
                message.contains("worker 3 already has a handle in frame 0"),
                "{scheme}: {message}"
            );
            drop(first);
            // Dropping the handle does not free its id within the frame.
            assert!(panic_message(|| drop(frame.handle_for(WorkerId::new(3)))).is_some());
            // `handle()` numbers from 0 and never repeats.
            let ids: Vec<WorkerId> = (0..2).map(|_| frame.handle().worker()).collect();
            assert_eq!(ids, [WorkerId::new(0), WorkerId::new(1)], "{scheme}");
            frame.close();
        }
    }

    #[test]
    fn duplicate_worker_ids_in_a_frame_are_refused_loudly() {
        for_every_scheme(DuplicateIds);
    }

    /// With the low-level API, a skipped `end_frame` shows as soon as a worker id comes back.
    #[derive(Clone, Copy)]
    struct SkippedEndFrame;
    impl CacheJob for SkippedEndFrame {
        type Output = ();
        fn run<C: IrradianceCache>(self, mut cache: C) {
            let scheme = cache.scheme();
            let mut h = cache.handle(WorkerId::new(0));
            let _ = h.insert(record(2.0));
            drop(h);
            // No `end_frame` here: the next "frame" reuses worker 0, whose records would get the
            // same ids as before.
            let message = panic_message(|| drop(cache.handle(WorkerId::new(0))))
                .unwrap_or_else(|| panic!("{scheme}: a skipped end_frame went unnoticed"));
            assert!(
                message.contains("was `end_frame` skipped?"),
                "{scheme}: {message}"
            );
            // Closing the frame makes the id free again.
            cache.end_frame();
            drop(cache.handle(WorkerId::new(0)));
            cache.end_frame();
            assert_eq!(cache.stats().frames, 2, "{scheme}");
        }
    }

    #[test]
    fn a_skipped_end_frame_is_caught_when_an_id_returns() {
        for_every_scheme(SkippedEndFrame);
    }

    /// A handle that is simply dropped loses nothing, and a frame that is simply dropped closes:
    /// LW's local records are merged, every counter arrives.
    #[derive(Clone, Copy)]
    struct DroppedHandlesAndFrames;
    impl CacheJob for DroppedHandlesAndFrames {
        type Output = ();
        fn run<C: IrradianceCache>(self, mut cache: C) {
            let scheme = cache.scheme();
            {
                let frame = cache.frame();
                for x in [2.0, 8.0] {
                    let mut h = frame.handle();
                    let _ = h.insert(record(x));
                    h.lookup(Vec3::splat(5.0), Vec3::Z);
                } // handles dropped here
            } // the frame is dropped here, unclosed
            let stats = cache.stats();
            assert_eq!(stats.frames, 1, "{scheme}: the dropped frame closed");
            assert_eq!(stats.totals.inserts, 2, "{scheme}: both handles' counters");
            assert_eq!(stats.totals.lookups, 2, "{scheme}");
            let kept = if scheme == Scheme::None { 0 } else { 2 };
            assert_eq!(stats.records, kept, "{scheme}: records");
            assert_eq!(cache.snapshot().len(), kept, "{scheme}: records");
        }
    }

    #[test]
    fn dropped_handles_and_frames_lose_nothing() {
        for_every_scheme(DroppedHandlesAndFrames);
    }

    /// `Frame::run` twice on one frame is refused: the second run's worker ids already have their
    /// handles in the frame (the panic its docs name), in every scheme.
    #[test]
    fn a_frame_runs_once() {
        #[derive(Clone, Copy)]
        struct RunTwice;
        impl CacheJob for RunTwice {
            type Output = ();
            fn run<C: IrradianceCache>(self, mut cache: C) {
                let scheme = cache.scheme();
                let frame = cache.frame();
                frame.run(2, |_, _| ());
                let second = catch_unwind(AssertUnwindSafe(|| frame.run(2, |_, _| ())));
                let payload = second
                    .err()
                    .unwrap_or_else(|| panic!("{scheme}: a second run of one frame was accepted"));
                let message = payload
                    .downcast_ref::<String>()
                    .map(String::as_str)
                    .unwrap_or_default();
                assert!(
                    message.contains("already has a handle"),
                    "{scheme}: {message}"
                );
            }
        }
        for_every_scheme(RunTwice);
    }

    /// A leaked handle (its drop never runs) is reported by name when the frame closes.
    #[derive(Clone, Copy)]
    struct LeakedHandle;
    impl CacheJob for LeakedHandle {
        type Output = ();
        fn run<C: IrradianceCache>(self, mut cache: C) {
            let scheme = cache.scheme();
            let frame = cache.frame();
            drop(frame.handle_for(WorkerId::new(1)));
            // (TRA's leaked handle keeps the octree's lock for ever: nothing else runs after it.)
            std::mem::forget(frame.handle_for(WorkerId::new(4)));
            let message = panic_message(|| {
                frame.close();
            })
            .unwrap_or_else(|| panic!("{scheme}: a leaked handle went unnoticed"));
            assert!(
                message.contains("the handle(s) of worker 4 never came back"),
                "{scheme}: {message}"
            );
        }
    }

    #[test]
    fn a_leaked_handle_is_reported_when_the_frame_closes() {
        for_every_scheme(LeakedHandle);
    }

    /// What a handle leaves goes to the cache it borrows, never to another one that happens to
    /// have a frame open at the same time.
    #[test]
    fn handles_report_to_their_own_cache() {
        let mut a = crate::cache::WaitFree::<crate::cache::wf::Minimal>::new(
            config(),
            crate::cache::CasFailure::Adopt,
        );
        let mut b = crate::cache::LocalWrite::new(config());
        let (fa, fb) = (a.frame(), b.frame());
        let mut ha = fa.handle();
        let mut hb = fb.handle();
        assert!(matches!(ha.insert(record(2.0)), Ok(Inserted::Stored(_))));
        for x in [3.0, 4.0, 6.0] {
            assert!(matches!(hb.insert(record(x)), Ok(Inserted::Stored(_))));
        }
        drop((ha, hb));
        let (ra, rb) = (fa.close(), fb.close());
        assert_eq!((ra.workers.inserts, rb.workers.inserts), (1, 3));
        assert_eq!((a.snapshot().len(), b.snapshot().len()), (1, 3));
    }

    /// `run` gives worker `i` the id `i`, returns results in worker order, and closes nothing
    /// itself; a worker's panic comes back after the others joined, with its records kept.
    #[test]
    fn run_numbers_workers_and_resumes_a_panic() {
        let mut cache = crate::cache::LocalWrite::new(config());
        let frame = cache.frame();
        let ids = frame.run(3, |h, worker| {
            assert_eq!(h.worker(), worker);
            h.insert(record(1.0 + 2.0 * worker.index() as f32)).unwrap();
            worker.index()
        });
        assert_eq!(ids, [0, 1, 2]);
        let message = panic_message(|| {
            frame.run(2, |h, worker| {
                // Another frame's ids are fresh, but this frame already gave 0 and 1 out: the
                // second `run` in one frame is refused.
                let _ = h.worker();
                let _ = worker;
            });
        })
        .expect("a second run in one frame reuses worker ids");
        assert!(
            message.contains("already has a handle in frame 0"),
            "{message}"
        );
        let report = frame.close();
        assert_eq!(report.workers.stored, 3);
        assert_eq!(cache.stats().records, 3);

        let frame = cache.frame();
        let message = panic_message(|| {
            frame.run(2, |h, worker| {
                h.insert(record(7.0)).unwrap();
                if worker.index() == 1 {
                    panic!("worker 1 gives up");
                }
            });
        });
        assert_eq!(message.as_deref(), Some("worker 1 gives up"));
        let report = frame.close();
        assert_eq!(
            report.workers.stored, 2,
            "the panicked worker's record is kept"
        );
        assert_eq!(cache.stats().records, 5);
    }

    #[test]
    #[cfg(feature = "rayon")]
    fn a_rayon_pool_gets_one_handle_per_thread() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let mut cache = crate::cache::WaitFree::<crate::cache::wf::Minimal>::new(
            config(),
            crate::cache::CasFailure::Adopt,
        );
        let frame = cache.frame();
        let workers = frame.run_on_pool(&pool, |h, worker| {
            h.insert(record(1.0 + worker.index() as f32)).unwrap();
            (h.worker(), rayon::current_thread_index())
        });
        assert_eq!(
            workers,
            (0..3)
                .map(|i| (WorkerId::new(i), Some(i as usize)))
                .collect::<Vec<_>>()
        );
        assert_eq!(frame.close().workers.stored, 3);
    }

    #[test]
    #[should_panic(expected = "at least one worker")]
    fn a_frame_of_no_threads_is_refused() {
        let mut cache = crate::cache::Sequential::new(config());
        let frame = cache.frame();
        frame.run(0, |_, _| ());
    }

    /// One thread beyond a worker id for each is refused, with the documented message, before
    /// any thread starts.
    #[test]
    fn more_threads_than_worker_ids_are_refused_before_any_starts() {
        let mut cache = crate::cache::Sequential::new(config());
        let frame = cache.frame();
        let started = AtomicU32::new(0);
        let refused = catch_unwind(AssertUnwindSafe(|| {
            frame.run(
                Frame::<crate::cache::Sequential>::MAX_THREADS + 1,
                |_, _| {
                    // Relaxed: read after the scope joined every thread, which orders it.
                    started.fetch_add(1, unchecked::Ordering::Relaxed);
                },
            )
        }))
        .expect_err("65537 threads must be refused");
        let message = refused
            .downcast_ref::<String>()
            .expect("a formatted message");
        assert_eq!(message, "65537 worker threads: at most 65536");
        assert_eq!(started.load(unchecked::Ordering::Relaxed), 0);
    }

    /// Frames are numbered 0, 1, 2, … as they close, and a worker's record ids carry the number,
    /// so the same worker's records of two frames never share an id.
    #[test]
    fn each_closed_frame_advances_the_frame_number() {
        let mut ledger = Ledger::<()>::new();
        let worker = WorkerId::new(0);
        for frame in 0..3 {
            assert_eq!(ledger.issue(worker), frame);
            ledger.deposit(Deposit {
                worker,
                stats: WorkerStats::default(),
                local: (),
            });
            assert_eq!(ledger.close().len(), 1);
        }
        let mut cache = crate::cache::Sequential::new(config());
        let ids: Vec<_> = (0..3)
            .map(|_| {
                let frame = cache.frame();
                let id = frame.handle().insert(record(1.0)).unwrap().id();
                frame.close();
                id
            })
            .collect();
        assert_eq!(
            ids.iter().map(|id| id.frame()).collect::<Vec<_>>(),
            [0, 1, 2]
        );
    }

    /// A record at `x` on the line y = z = 1, facing +z, of radius 1, sealed as `worker`'s `seq`.
    fn sealed_at(x: f32, worker: u32, seq: u64) -> Record {
        Record::new(Vec3::new(x, 1.0, 1.0), Vec3::Z, Vec3::ONE, 1.0).sealed(RecordId::new(
            WorkerId::new(worker),
            0,
            seq,
        ))
    }

    /// The bookkeeping every scheme's handle delegates to, counted by hand: record numbering,
    /// refusals, outcomes, step maxima, each traversal's work, hits and shared hits.
    #[test]
    fn a_handle_core_counts_what_its_worker_does() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.5).unwrap();
        let ledger = Ledger::<()>::new();
        let me = WorkerId::new(2);
        let mut core = HandleCore::new(&ledger, me, ());
        let fresh = |x: f32| Record::new(Vec3::new(x, 1.0, 1.0), Vec3::Z, Vec3::ONE, 1.0);

        // Admission numbers the worker's records 0, 1, 2 in this frame and refuses bad input.
        let ids: Vec<RecordId> = (0..3)
            .map(|k| core.admit(&config, fresh(1.0 + k as f32)).unwrap().id())
            .collect();
        let expected: Vec<RecordId> = (0..3).map(|k| RecordId::new(me, 0, k)).collect();
        assert_eq!(ids, expected);
        assert!(matches!(
            core.admit(&config, fresh(9.0)),
            Err(InsertError::OutOfBounds { .. })
        ));
        assert_eq!((core.stats.inserts, core.stats.rejected), (3, 1));

        // Outcomes: two stored, one discarded, one not cached (counted nowhere); the most steps.
        assert_eq!(
            core.inserted(Inserted::Stored(ids[0]), 3),
            Inserted::Stored(ids[0])
        );
        core.inserted(Inserted::Stored(ids[1]), 5);
        core.inserted(Inserted::Discarded(ids[2]), 4);
        core.inserted(Inserted::NotCached(ids[2]), 1);
        let s = core.stats;
        assert_eq!((s.stored, s.discarded, s.max_insert_steps), (2, 1, 5));

        // Traversals: maxima per field (from different traversals) and sums.
        core.traversed(Work {
            nodes: 3,
            records: 7,
        });
        core.traversed(Work {
            nodes: 5,
            records: 2,
        });
        let s = core.stats;
        assert_eq!(
            (
                s.max_lookup_nodes,
                s.max_lookup_records,
                s.lookup_nodes,
                s.lookup_records
            ),
            (5, 7, 8, 9)
        );
        assert_eq!(s.lookups, 0, "a traversal alone is not a lookup");

        // Lookups: one that cannot be answered, a miss, a hit on the worker's own records, a hit
        // that uses another worker's record.
        let q = Vec3::new(1.1, 1.0, 1.0);
        assert!(core.begin_lookup(&config, Vec3::NAN, Vec3::Z).is_none());
        let miss = core.begin_lookup(&config, q, Vec3::Z).unwrap();
        assert_eq!(miss.point(), q);
        assert_eq!(core.end_lookup(&miss, Work::default()), None);
        let mut own = core.begin_lookup(&config, q, Vec3::Z).unwrap();
        assert!(own.add(&sealed_at(1.0, 2, 0)) && own.add(&sealed_at(1.2, 2, 1)));
        let hit = core.end_lookup(&own, Work::default()).unwrap();
        assert_eq!((hit.records, hit.foreign), (2, 0));
        let mut shared = core.begin_lookup(&config, q, Vec3::Z).unwrap();
        assert!(shared.add(&sealed_at(1.0, 2, 0)) && shared.add(&sealed_at(1.2, 5, 0)));
        let hit = core.end_lookup(&shared, Work::default()).unwrap();
        assert_eq!((hit.records, hit.foreign), (2, 1));
        let s = core.stats;
        assert_eq!((s.lookups, s.hits, s.shared_hits), (4, 2, 1));
        // A second shared hit counts one more (not a doubling of the first).
        core.end_lookup(&shared, Work::default());
        core.end_lookup(&shared, Work::default());
        assert_eq!(core.stats.shared_hits, 3);
        // `end_lookup` counts its traversal too.
        core.end_lookup(
            &miss,
            Work {
                nodes: 1,
                records: 1,
            },
        );
        assert_eq!(core.stats.lookup_nodes, 9);
    }

    #[test]
    fn collect_valid_keeps_the_valid_records_and_counts_every_one_it_is_shown() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.5).unwrap();
        let (q, mut out) = (Vec3::new(1.1, 1.0, 1.0), Vec::new());
        // Valid, far (invalid), valid: three examined over two nodes, two kept in visit order.
        let shown = [
            sealed_at(1.0, 0, 0),
            sealed_at(3.5, 0, 1),
            sealed_at(1.2, 1, 0),
        ];
        let work = collect_valid(&config, q, Vec3::Z, &mut out, |pre, f| {
            assert_eq!(pre.point(), q);
            shown.iter().for_each(f);
            Work {
                nodes: 2,
                records: 3,
            }
        });
        assert_eq!(
            work,
            Work {
                nodes: 2,
                records: 3
            }
        );
        assert_eq!(out, vec![shown[0], shown[2]]);
        // A query that cannot be answered visits nothing.
        let work = collect_valid(&config, Vec3::NAN, Vec3::Z, &mut out, |_, _| {
            panic!("an unanswerable query must not be visited")
        });
        assert_eq!(work, Work::default());
        assert_eq!(out.len(), 2);
    }

    #[test]
    fn a_ledger_names_its_cache_in_debug_output() {
        let (a, b) = (Ledger::<()>::new(), Ledger::<()>::new());
        let (a, b) = (format!("{a:?}"), format!("{b:?}"));
        let number = |s: &str| -> u64 {
            s.strip_prefix("Ledger(cache #")
                .and_then(|r| r.strip_suffix(')'))
                .unwrap_or_else(|| panic!("unexpected Debug output {s:?}"))
                .parse()
                .unwrap()
        };
        assert_ne!(number(&a), number(&b), "each cache has its own number");
    }
}
