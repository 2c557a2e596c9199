//! Deterministic frames: the same records and the same answers whatever the thread count, the
//! pool or the schedule.
//!
//! In an ordinary frame a lookup uses whatever the other workers have inserted so far, and sums
//! the records in the order the cache holds them; both depend on the schedule. A deterministic
//! frame cuts its work into *tiles*, numbered `0..tiles`, and changes two things:
//!
//! * **Which records a lookup may use** ([`Visibility`]): the records of earlier frames, and the
//!   records its own tile inserted in this frame, never another tile's records of this frame.
//!   Each tile runs through its own handle whose worker id is the tile's number
//!   ([`Frame::run_tiles`]), so a record's id says which tile of which frame made it.
//! * **The order in which a lookup sums them**: by record id
//!   ([`CacheHandle::lookup_visible`]), whatever order the octree's lists hold them in.
//!
//! Then, by induction over frames and, within a frame, over each tile's own sequence of
//! operations: what a tile's lookup returns is a function of the records the cache held when the
//! frame opened and of the tile's own earlier inserts, so the tile's inserts (their contents and
//! their ids: worker = tile, frame, the tile's own count) are too; the frame's record set is the
//! union over the tiles, whichever thread ran each. The records are still shared through the
//! cache's own structure while the frame runs (WF's wait-free octree, LCK's lock, TRA's tree):
//! what changes is only which of them a lookup takes. Removal belongs between frames
//! ([`IrradianceCache::remove`]); a [`TileHandle`] refuses it, because what a removal during a
//! frame takes depends on which other tiles' inserts came first.
//!
//! The argument needs three things of the cache: that a lookup finds every record of earlier
//! frames that is valid at the point (true of every scheme: a closed frame's records are all
//! published), that records are never lost (WF `Discard` drops a record when it loses a race,
//! so only `Adopt` qualifies; [`Scheme::is_deterministic`](super::Scheme::is_deterministic)),
//! and that no removal runs inside the frame.

use super::{CacheHandle, Frame, Inserted, IrradianceCache, WorkerStats};
use crate::ic::{InsertError, Interpolated, Record, RecordId, Selection, WorkerId};
use glam::Vec3;

/// Which records a deterministic lookup may use: those of other frames, and those of this
/// frame that its own tile inserted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Visibility {
    /// The open frame, modulo 2^16 as record ids carry it.
    frame: u64,
    /// The tile asking.
    tile: WorkerId,
}

impl Visibility {
    /// The rule for tile `tile` of frame `frame`.
    pub const fn new(frame: u64, tile: WorkerId) -> Self {
        Self {
            frame: frame & 0xffff,
            tile,
        }
    }

    /// Whether a lookup of this tile may use the record with id `id`: one of another frame, or
    /// one this tile inserted. (A record 2^16 frames old carries this frame's number again; it is
    /// then used only by the tile with its worker number. That costs some reuse in so long an
    /// animation, never determinism: the rule is still a function of the id.)
    #[inline]
    pub const fn admits(&self, id: RecordId) -> bool {
        id.frame() != self.frame || id.worker().index() == self.tile.index()
    }
}

/// A tile's access to a cache in a deterministic frame: a [`CacheHandle`] whose lookups use only
/// the records [`Visibility`] admits, summed in id order. Made by [`Frame::run_tiles`] (or
/// [`TileHandle::new`] over a handle whose worker id is the tile's number).
#[derive(Debug)]
pub struct TileHandle<H> {
    inner: H,
    visible: Visibility,
}

impl<H: CacheHandle> TileHandle<H> {
    /// The tile whose number is `inner`'s worker id, in `inner`'s frame.
    pub fn new(inner: H) -> Self {
        let visible = Visibility::new(inner.frame(), inner.worker());
        Self { inner, visible }
    }

    /// The rule its lookups follow.
    pub fn visibility(&self) -> Visibility {
        self.visible
    }
}

impl<H: CacheHandle> CacheHandle for TileHandle<H> {
    fn worker(&self) -> WorkerId {
        self.inner.worker()
    }

    fn frame(&self) -> u64 {
        self.inner.frame()
    }

    #[inline]
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        self.inner.lookup_visible(point, normal, self.visible)
    }

    /// Narrows `visible` to what this tile may see as well.
    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
    ) -> Option<Interpolated> {
        if visible == self.visible {
            self.lookup(point, normal)
        } else {
            // Two rules at once are not one `Visibility`; no caller needs them.
            panic!(
                "a TileHandle looks up with its own tile's visibility only ({:?}, asked {visible:?})",
                self.visible
            )
        }
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        self.inner.insert(record)
    }

    /// # Panics
    /// Always: what a removal during a deterministic frame takes would depend on which other
    /// tiles' inserts came first. Remove between frames, with [`IrradianceCache::remove`].
    fn remove(&mut self, selection: &Selection) -> usize {
        panic!(
            "a deterministic frame cannot remove ({selection:?}): what it took would depend on the \
             schedule; remove between frames with IrradianceCache::remove"
        )
    }

    /// The records this tile's lookup would use, in the order it sums them.
    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        let start = out.len();
        self.inner.valid_records(point, normal, out);
        let mut kept: Vec<Record> = out
            .drain(start..)
            .filter(|r| self.visible.admits(r.id()))
            .collect();
        kept.sort_unstable_by_key(Record::canonical_key);
        out.extend(kept);
    }

    fn stats(&self) -> &WorkerStats {
        self.inner.stats()
    }
}

/// Tiles a deterministic frame can number: a tile's number is its handle's worker id, which a
/// record id holds in 16 bits.
pub const MAX_TILES: usize = WorkerId::MAX as usize + 1;

impl<C: IrradianceCache> Frame<'_, C> {
    /// Runs a deterministic frame's tiles `0..tiles` on `threads` scoped threads: each thread
    /// takes the next tile from a shared counter and runs `work(handle, tile)` through a
    /// [`TileHandle`] of its own for that tile (worker id = tile number). Returns the results in
    /// tile order, so nothing the caller sees depends on which thread ran which tile.
    ///
    /// # Panics
    /// If `threads` is 0, `tiles` exceeds [`MAX_TILES`], a tile's work panics (resumed after every
    /// thread has joined), or a tile number already has a handle in this frame (the frame was
    /// already run: open a new frame for the next pass).
    #[cfg(not(checker))]
    pub fn run_tiles<'f, T, F>(&'f self, threads: usize, tiles: usize, work: F) -> Vec<T>
    where
        T: Send,
        F: Fn(&mut TileHandle<C::Handle<'f>>, usize) -> T + Sync,
    {
        assert!(tiles <= MAX_TILES, "{tiles} tiles: at most {MAX_TILES}");
        let all: Vec<usize> = (0..tiles).collect();
        self.run_tile_list(threads, &all, work)
    }

    /// [`Frame::run_tiles`] over the tiles `tiles` lists only (distinct numbers below
    /// [`MAX_TILES`]): for a renderer that shares a frame's tiles between processes, each running
    /// its own. Returns the results in the list's order.
    ///
    /// # Panics
    /// As [`Frame::run_tiles`], and if a number repeats or is not below [`MAX_TILES`].
    #[cfg(not(checker))]
    pub fn run_tile_list<'f, T, F>(&'f self, threads: usize, tiles: &[usize], work: F) -> Vec<T>
    where
        T: Send,
        F: Fn(&mut TileHandle<C::Handle<'f>>, usize) -> T + Sync,
    {
        assert!(threads > 0, "a frame needs at least one worker thread");
        let next = crate::sync::AtomicUsize::new(0);
        let take = || {
            // Relaxed: the counter only hands out distinct places in the list, which
            // `fetch_add`'s atomicity guarantees; what a tile computed comes back through the join.
            let at = next.fetch_add(1, crate::sync::Ordering::Relaxed);
            (at < tiles.len()).then_some(at)
        };
        let (work, take) = (&work, &take);
        let outputs = crate::sync::thread::scope(|s| {
            let threads: Vec<_> = (0..threads)
                .map(|_| {
                    s.spawn(move || {
                        let mut done = Vec::new();
                        while let Some(at) = take() {
                            done.push((at, self.run_tile(tiles[at], work)));
                        }
                        done
                    })
                })
                .collect();
            let (mut out, mut panic) = (Vec::new(), None);
            for thread in threads {
                match thread.join() {
                    Ok(done) => out.extend(done),
                    Err(payload) => {
                        panic.get_or_insert(payload);
                    }
                }
            }
            if let Some(payload) = panic {
                std::panic::resume_unwind(payload);
            }
            out
        });
        in_list_order(tiles.len(), outputs.into_iter())
    }

    /// [`Frame::run_tiles`] on the threads of `pool`: every tile is a task of the pool (work
    /// stealing decides which thread runs it). Needs the `rayon` feature.
    ///
    /// # Panics
    /// As [`Frame::run_tiles`].
    #[cfg(all(feature = "rayon", not(checker)))]
    pub fn run_tiles_on_pool<'f, T, F>(
        &'f self,
        pool: &rayon::ThreadPool,
        tiles: usize,
        work: F,
    ) -> Vec<T>
    where
        T: Send,
        F: Fn(&mut TileHandle<C::Handle<'f>>, usize) -> T + Sync,
    {
        use rayon::prelude::*;
        assert!(tiles <= MAX_TILES, "{tiles} tiles: at most {MAX_TILES}");
        pool.install(|| {
            (0..tiles)
                .into_par_iter()
                .map(|tile| self.run_tile(tile, &work))
                .collect()
        })
    }

    /// Runs `work` for tile `tile` through a fresh [`TileHandle`] (dropped, and so deposited in
    /// the frame's ledger, when `work` returns).
    #[cfg(not(checker))]
    fn run_tile<'f, T>(
        &'f self,
        tile: usize,
        work: &impl Fn(&mut TileHandle<C::Handle<'f>>, usize) -> T,
    ) -> T {
        let id = WorkerId::new(u32::try_from(tile).unwrap_or(u32::MAX));
        let mut handle = TileHandle::new(self.handle_for(id));
        work(&mut handle, tile)
    }
}

/// The results of the `n` places of a tile list, given as `(place, result)` in any order, in
/// the list's order.
#[cfg(not(checker))]
fn in_list_order<T>(n: usize, done: impl Iterator<Item = (usize, T)>) -> Vec<T> {
    let mut slots: Vec<Option<T>> = (0..n).map(|_| None).collect();
    for (at, value) in done {
        slots[at] = Some(value);
    }
    slots
        .into_iter()
        .map(|s| s.expect("every tile ran once"))
        .collect()
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::cache::{CacheConfig, CacheJob, Scheme};

    fn config() -> CacheConfig {
        CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), 0.6).unwrap()
    }

    /// Four records at one point whose sum, at [`QUERY`], rounds differently by order. The query
    /// gives each the Ward weight 2 exactly (distance 0.75, radius 1.5, the same normal), so the
    /// weighted terms are 2, 2^-23, 2^-52 and 2^-52 and the total weight 8. Summed big first, each
    /// tiny term is half an ulp of the running sum and rounds away (to even): `(2 + 2^-23) / 8`, a
    /// tie in `f32` that rounds down to 0.25. Summed small first, the tiny terms add up to one ulp
    /// that stays: just above the tie, rounded up to `0.25 + 2^-25`.
    fn records() -> Vec<Record> {
        [1.0, 2f32.powi(-24), 2f32.powi(-53), 2f32.powi(-53)]
            .map(|e| Record::new(Vec3::new(4.0, 5.0, 5.0), Vec3::Z, Vec3::splat(e), 1.5))
            .to_vec()
    }

    const QUERY: Vec3 = Vec3::new(4.75, 5.0, 5.0);

    /// Inserts `records` in the order `order` gives, record `i` through a handle of its own with
    /// worker id `i` (so its id does not depend on the order), in one frame; then answers every query in the next frame with `lookup` and
    /// `lookup_visible` (everything visible), as bit patterns.
    struct Answers<'a> {
        records: &'a [Record],
        order: &'a [usize],
    }

    type Bits = Option<[u32; 3]>;

    impl CacheJob for Answers<'_> {
        type Output = (Bits, Bits);
        fn run<C: IrradianceCache>(self, mut cache: C) -> Self::Output {
            let frame = cache.frame();
            for &i in self.order {
                let mut handle = frame.handle_for(WorkerId::new(i as u32));
                handle.insert(self.records[i]).unwrap();
            }
            frame.close();
            let frame = cache.frame();
            let mut handle = frame.handle();
            let everything = Visibility::new(handle.frame() + 1, WorkerId::new(0));
            let bits =
                |i: Option<Interpolated>| i.map(|i| i.irradiance.to_array().map(f32::to_bits));
            let plain = bits(handle.lookup(QUERY, Vec3::Z));
            let canonical = bits(handle.lookup_visible(QUERY, Vec3::Z, everything));
            (plain, canonical)
        }
    }

    /// The canonical sum is the same bit for bit whatever order the records were inserted in, for
    /// every scheme; the plain lookup's is not (the negative control: the same comparison fails
    /// without the sort).
    #[test]
    fn a_visible_lookup_sums_in_id_order_whatever_the_insertion_order() {
        let records = records();
        let forward: Vec<usize> = (0..records.len()).collect();
        let backward: Vec<usize> = forward.iter().rev().copied().collect();
        for scheme in Scheme::CACHED {
            let a = scheme.build(
                config(),
                Answers {
                    records: &records,
                    order: &forward,
                },
            );
            let b = scheme.build(
                config(),
                Answers {
                    records: &records,
                    order: &backward,
                },
            );
            let quarter = 0.25f32.to_bits();
            assert_eq!(
                a.1,
                Some([quarter; 3]),
                "{scheme}: summed in id order, big first"
            );
            assert_eq!(
                a.1, b.1,
                "{scheme}: the canonical sums differ with the insertion order"
            );
            assert_ne!(
                a.0, b.0,
                "{scheme}: the plain sums should depend on the order"
            );
        }
    }

    #[test]
    fn a_tile_sees_earlier_frames_and_its_own_records_only() {
        let r = Record::new(Vec3::new(4.0, 5.0, 5.0), Vec3::Z, Vec3::ONE, 1.5);
        let mut cache = crate::cache::WaitFree::adopt(config());
        let frame = cache.frame();
        let mut zero = TileHandle::new(frame.handle_for(WorkerId::new(0)));
        let mut one = TileHandle::new(frame.handle_for(WorkerId::new(1)));
        assert_eq!((zero.frame(), zero.worker()), (0, WorkerId::new(0)));
        zero.insert(r).unwrap();
        assert!(zero.lookup(QUERY, Vec3::Z).is_some(), "its own record");
        assert!(
            one.lookup(QUERY, Vec3::Z).is_none(),
            "another tile's, this frame"
        );
        let mut found = Vec::new();
        one.valid_records(QUERY, Vec3::Z, &mut found);
        assert!(found.is_empty(), "valid_records follows the rule too");
        zero.valid_records(QUERY, Vec3::Z, &mut found);
        assert_eq!(found.len(), 1);
        let stats = *one.stats();
        assert_eq!((stats.lookups, stats.hits), (1, 0), "counted as a lookup");
        drop((zero, one));
        frame.close();
        let frame = cache.frame();
        let mut one = TileHandle::new(frame.handle_for(WorkerId::new(1)));
        assert_eq!(one.frame(), 1);
        let hit = one
            .lookup(QUERY, Vec3::Z)
            .expect("an earlier frame's record");
        assert_eq!(hit.foreign, 1, "another tile's record counts as foreign");
        // Its own rule, asked for by name, is its lookup; another rule is refused.
        let own = one.lookup_visible(QUERY, Vec3::Z, one.visibility());
        assert_eq!(own.map(|i| i.records), Some(1));
        let other = Visibility::new(1, WorkerId::new(0));
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            one.lookup_visible(QUERY, Vec3::Z, other)
        }));
        assert!(
            caught.is_err(),
            "another tile's rule through this tile's handle"
        );
    }

    #[test]
    fn the_rule_is_a_function_of_the_id_even_when_the_frame_number_wraps() {
        let rule = Visibility::new(3 + (1 << 16), WorkerId::new(7));
        let id = |worker, frame| RecordId::new(WorkerId::new(worker), frame, 0);
        assert!(rule.admits(id(7, 3)), "its own");
        assert!(!rule.admits(id(8, 3)), "another tile's, this frame");
        assert!(rule.admits(id(8, 2)), "an earlier frame's");
        assert!(rule.admits(id(8, 4)), "any other frame's");
    }

    #[test]
    fn a_tile_handle_refuses_to_remove_by_name() {
        let mut cache = crate::cache::WaitFree::adopt(config());
        let frame = cache.frame();
        let mut tile = TileHandle::new(frame.handle());
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            tile.remove(&Selection::older_than(0))
        }));
        let message = caught.expect_err("refused");
        let message = message
            .downcast_ref::<String>()
            .expect("a formatted message");
        assert!(
            message.contains("a deterministic frame cannot remove"),
            "{message}"
        );
    }

    /// A tile's work: at 16 points of its own strip, which overlaps both neighbours' strips, a
    /// lookup; on a miss a record whose irradiance depends on what the tile has found so far.
    fn tile_work<H: CacheHandle>(handle: &mut H, tile: usize) -> Vec<u32> {
        let mut seen = 1.0f32;
        let mut out = Vec::new();
        for i in 0..16 {
            let p = Vec3::new(0.5 + 0.1 * tile as f32 + 0.03 * i as f32, 5.0, 5.0);
            match handle.lookup(p, Vec3::Z) {
                Some(hit) => seen = 1.0 + (0.37 * seen + 0.61 * hit.irradiance.x) % 7.0,
                None => {
                    let r = Record::new(p, Vec3::Z, Vec3::splat(seen), 0.05 + 0.01 * i as f32);
                    handle.insert(r).unwrap();
                }
            }
            out.push(seen.to_bits());
        }
        out
    }

    /// How the tiles of [`Tiles`] run.
    #[derive(Clone)]
    enum Run {
        /// [`Frame::run_tiles`] on this many threads.
        Threads(usize),
        /// [`Frame::run_tiles_on_pool`] on a pool of this many threads.
        #[cfg(feature = "rayon")]
        Pool(usize),
        /// One thread, the tiles in this order.
        Order(Vec<usize>),
    }

    const TILES: usize = 80;

    /// Two frames of [`tile_work`] over [`TILES`] tiles; returns what every tile saw and the
    /// records, ordered by id, as bits.
    struct Tiles(Run);

    type Outcome = (Vec<Vec<u32>>, Vec<(u64, [u32; 4])>);

    impl CacheJob for Tiles {
        type Output = Outcome;
        fn run<C: IrradianceCache>(self, mut cache: C) -> Outcome {
            let mut seen = Vec::new();
            for _ in 0..2 {
                let frame = cache.frame();
                seen.extend(match &self.0 {
                    Run::Threads(n) => frame.run_tiles(*n, TILES, tile_work),
                    #[cfg(feature = "rayon")]
                    Run::Pool(n) => {
                        let pool = rayon::ThreadPoolBuilder::new().num_threads(*n).build();
                        frame.run_tiles_on_pool(&pool.unwrap(), TILES, tile_work)
                    }
                    Run::Order(order) => {
                        let mut out = vec![Vec::new(); TILES];
                        for &t in order {
                            let handle = frame.handle_for(WorkerId::new(t as u32));
                            out[t] = tile_work(&mut TileHandle::new(handle), t);
                        }
                        out
                    }
                });
                frame.close();
            }
            let mut records: Vec<(u64, [u32; 4])> = cache
                .snapshot()
                .iter()
                .map(|r| {
                    let p = r.position;
                    (
                        r.id().get(),
                        [p.x, p.y, r.irradiance.x, r.radius].map(f32::to_bits),
                    )
                })
                .collect();
            records.sort_unstable();
            (seen, records)
        }
    }

    /// The same answers and the same records, ids included, whatever order the tiles run in
    /// (forward, backward, shuffled; the order is what the rule must not depend on, and unlike a
    /// thread schedule it can be forced), at 1, 2, 3 and 8 threads and on rayon pools, for every
    /// scheme a deterministic frame can run.
    #[test]
    fn tiles_give_the_same_answers_and_records_in_any_order_and_at_any_thread_count() {
        let forward: Vec<usize> = (0..TILES).collect();
        let mut shuffled = forward.clone();
        let mut rng = crate::rng::Rng::new(11);
        for i in (1..TILES).rev() {
            shuffled.swap(i, rng.below(i as u64 + 1) as usize);
        }
        let runs = [
            Run::Order(forward.iter().rev().copied().collect()),
            Run::Order(shuffled),
            Run::Threads(1),
            Run::Threads(2),
            Run::Threads(3),
            Run::Threads(8),
            #[cfg(feature = "rayon")]
            Run::Pool(1),
            #[cfg(feature = "rayon")]
            Run::Pool(3),
        ];
        for scheme in Scheme::CACHED.into_iter().filter(|s| s.is_deterministic()) {
            let first = scheme.build(config(), Tiles(Run::Order(forward.clone())));
            assert!(first.1.len() > 40, "{scheme}: {} records", first.1.len());
            for (i, run) in runs.iter().enumerate() {
                let other = scheme.build(config(), Tiles(run.clone()));
                assert!(
                    first == other,
                    "{scheme}: run {i} differs from the forward order"
                );
            }
        }
    }

    #[test]
    fn a_frame_takes_as_many_tiles_as_a_record_id_can_number() {
        assert_eq!(MAX_TILES, 1 << 16, "a worker id's 16 bits");
        let mut cache = crate::cache::WaitFree::adopt(config());
        let frame = cache.frame();
        let tiles = frame.run_tiles(2, MAX_TILES, |h, t| (h.worker().index() as usize, t));
        assert!(tiles
            .iter()
            .enumerate()
            .all(|(i, &(w, t))| w == i && t == i));
        let report = frame.close();
        assert_eq!(report.workers.lookups, 0);
    }

    /// Two caches split each frame's tiles (even and odd, as two processes would) and, before
    /// closing the frame, insert each other's new records through the handles of the tiles that
    /// made them, in their order: every record comes back with the id it had, and both caches
    /// end each frame with the one-cache run's answers and records.
    #[test]
    fn tiles_split_between_caches_and_exchanged_give_the_one_cache_frames() {
        let one = Scheme::Wf.build(config(), Tiles(Run::Threads(2)));
        let mut caches = [
            crate::cache::WaitFree::adopt(config()),
            crate::cache::WaitFree::adopt(config()),
        ];
        let mut seen = vec![Vec::new(); 2 * TILES];
        for frame in 0..2 {
            let [a, b] = &mut caches;
            let (fa, fb) = (a.frame(), b.frame());
            let mut made = [Vec::new(), Vec::new()];
            for (k, f) in [&fa, &fb].into_iter().enumerate() {
                let mine: Vec<usize> = (k..TILES).step_by(2).collect();
                let done = f.run_tile_list(2, &mine, |h, t| {
                    let before = h.stats().stored;
                    let answers = tile_work(h, t);
                    (answers, h.stats().stored - before)
                });
                for (&t, (answers, _)) in mine.iter().zip(&done) {
                    seen[frame * TILES + t] = answers.clone();
                }
                made[k] = mine;
            }
            // Each cache's records of this frame, by tile, into the other.
            let records = |f: &Frame<'_, crate::cache::WaitFree>| {
                let mut out = Vec::new();
                let mut h = f.handle_for(WorkerId::new(WorkerId::MAX));
                for x in 0..400 {
                    h.valid_records(
                        Vec3::new(0.5 + 0.03 * x as f32, 5.0, 5.0),
                        Vec3::Z,
                        &mut out,
                    );
                }
                out.retain(|r| r.id().frame() == h.frame());
                out.sort_unstable_by_key(Record::id);
                out.dedup_by_key(|r| r.id());
                out
            };
            let (ra, rb) = (records(&fa), records(&fb));
            for (from, into, tiles) in [(&ra, &fb, &made[0]), (&rb, &fa, &made[1])] {
                for &t in tiles {
                    let mut h = into.handle_for(WorkerId::new(t as u32));
                    for r in from
                        .iter()
                        .filter(|r| r.id().worker().index() as usize == t)
                    {
                        let back = h.insert(*r).unwrap();
                        assert_eq!(back, Inserted::Stored(r.id()), "the same id again");
                    }
                }
            }
            drop((fa, fb));
        }
        assert_eq!(seen, one.0, "the answers of the one-cache run");
        for cache in &mut caches {
            let mut records: Vec<u64> = cache.snapshot().iter().map(|r| r.id().get()).collect();
            records.sort_unstable();
            let ids: Vec<u64> = one.1.iter().map(|(id, _)| *id).collect();
            assert_eq!(records, ids, "the one-cache run's records");
        }
    }

    /// Every backend: a handle knows its frame's number; a visible lookup is counted as a lookup
    /// and finds the tile's own record of this frame (LW's in its local octree), but not another
    /// tile's; which schemes a deterministic frame can run.
    #[test]
    fn every_backend_numbers_its_frames_and_looks_up_by_the_rule() {
        struct Check;
        impl CacheJob for Check {
            type Output = ();
            fn run<C: IrradianceCache>(self, mut cache: C) {
                let scheme = cache.scheme();
                let r = Record::new(Vec3::new(4.0, 5.0, 5.0), Vec3::Z, Vec3::ONE, 1.5);
                for k in 0..3 {
                    let frame = cache.frame();
                    let mut h = frame.handle_for(WorkerId::new(0));
                    assert_eq!(h.frame(), k, "{scheme}: frame {k}");
                    h.insert(r).unwrap();
                    let own =
                        h.lookup_visible(QUERY, Vec3::Z, Visibility::new(k, WorkerId::new(0)));
                    let other =
                        h.lookup_visible(QUERY, Vec3::Z, Visibility::new(k, WorkerId::new(1)));
                    assert_eq!(h.stats().lookups, 2, "{scheme}: counted as lookups");
                    if scheme != Scheme::None {
                        let k = k as u32;
                        assert_eq!(own.map(|i| i.records), Some(k + 1), "{scheme}: its own");
                        let earlier = (k > 0).then_some(k);
                        assert_eq!(other.map(|i| i.records), earlier, "{scheme}: not another's");
                    }
                }
            }
        }
        for scheme in Scheme::ALL {
            scheme.build(config(), Check);
        }
        let deterministic: Vec<Scheme> = Scheme::ALL
            .into_iter()
            .filter(|s| s.is_deterministic())
            .collect();
        assert_eq!(
            deterministic,
            [
                Scheme::Tra,
                Scheme::Lck,
                Scheme::LckRw,
                Scheme::Lw,
                Scheme::Wf,
                Scheme::None
            ]
        );
    }
}
