//! LCK: the lock-based shared cache (paper §3.1, Listing 4).
//!
//! The sequential [`Octree`] behind one lock, taken separately for each lookup and each insert, so
//! hemisphere sampling between them runs in parallel. Two flavours: a `Mutex` (the paper) and an
//! `RwLock` (readers in parallel, as pbrt-v2's irradiance cache did). Every acquisition first tries
//! the lock; only when that fails is the wait timed, so an uncontended acquisition costs no clock
//! reads. The time spent waiting is summed over workers (the paper's LCK overhead in Table 1).

use super::deterministic::Visibility;
use super::frame::{collect_valid, HandleCore, Ledger};
use super::{
    CacheConfig, CacheHandle, CacheStats, FrameReport, Inserted, IrradianceCache, Octree, Scheme,
    WorkerStats,
};
use crate::ic::{InsertError, Interpolated, Record, Selection, WorkerId};
use crate::sync::{
    try_unpoison, unpoison, Mutex, MutexGuard, RwLock, RwLockReadGuard, RwLockWriteGuard,
};
use glam::Vec3;
use std::ops::{Deref, DerefMut};
use std::time::{Duration, Instant};

mod sealed {
    pub trait Sealed {}
}

/// The lock LCK puts around its octree.
pub trait LockFlavour: sealed::Sealed + Send + Sync {
    /// Guard for a lookup.
    type Read<'a>: Deref<Target = Octree>
    where
        Self: 'a;
    /// Guard for an insert.
    type Write<'a>: DerefMut<Target = Octree>
    where
        Self: 'a;
    /// The scheme name.
    /// The scheme this flavour is.
    const SCHEME: super::Scheme;
    /// Wraps `tree`.
    fn new(tree: Octree) -> Self;
    /// Takes the lock for reading if it is free now.
    fn try_read(&self) -> Option<Self::Read<'_>>;
    /// Takes the lock for reading, waiting as long as needed.
    fn read(&self) -> Self::Read<'_>;
    /// Takes the lock for writing if it is free now.
    fn try_write(&self) -> Option<Self::Write<'_>>;
    /// Takes the lock for writing, waiting as long as needed.
    fn write(&self) -> Self::Write<'_>;
    /// The octree, when nobody else can hold the lock.
    fn get_mut(&mut self) -> &mut Octree;
}

/// One `Mutex` for lookups and inserts alike (Listing 4).
#[derive(Debug)]
pub struct MutexFlavour(Mutex<Octree>);

/// An `RwLock`: lookups share it, inserts take it alone.
#[derive(Debug)]
pub struct RwLockFlavour(RwLock<Octree>);

impl sealed::Sealed for MutexFlavour {}
impl sealed::Sealed for RwLockFlavour {}

// Poisoning: a worker that panics while holding the lock leaves the octree whole (a record is
// pushed in one step), so every acquisition recovers a poisoned guard and goes on.
impl LockFlavour for MutexFlavour {
    type Read<'a> = MutexGuard<'a, Octree>;
    type Write<'a> = MutexGuard<'a, Octree>;
    const SCHEME: super::Scheme = super::Scheme::Lck;
    fn new(tree: Octree) -> Self {
        Self(Mutex::new(tree))
    }
    fn try_read(&self) -> Option<Self::Read<'_>> {
        try_unpoison(self.0.try_lock())
    }
    fn read(&self) -> Self::Read<'_> {
        unpoison(self.0.lock())
    }
    fn try_write(&self) -> Option<Self::Write<'_>> {
        try_unpoison(self.0.try_lock())
    }
    fn write(&self) -> Self::Write<'_> {
        unpoison(self.0.lock())
    }
    fn get_mut(&mut self) -> &mut Octree {
        unpoison(self.0.get_mut())
    }
}

impl LockFlavour for RwLockFlavour {
    type Read<'a> = RwLockReadGuard<'a, Octree>;
    type Write<'a> = RwLockWriteGuard<'a, Octree>;
    const SCHEME: super::Scheme = super::Scheme::LckRw;
    fn new(tree: Octree) -> Self {
        Self(RwLock::new(tree))
    }
    fn try_read(&self) -> Option<Self::Read<'_>> {
        try_unpoison(self.0.try_read())
    }
    fn read(&self) -> Self::Read<'_> {
        unpoison(self.0.read())
    }
    fn try_write(&self) -> Option<Self::Write<'_>> {
        try_unpoison(self.0.try_write())
    }
    fn write(&self) -> Self::Write<'_> {
        unpoison(self.0.write())
    }
    fn get_mut(&mut self) -> &mut Octree {
        unpoison(self.0.get_mut())
    }
}

/// Takes a lock through `try_`, or, if it is busy, through `block`, adding the wait to `wait`.
#[inline]
fn acquire<G>(
    wait: &mut Duration,
    try_: impl FnOnce() -> Option<G>,
    block: impl FnOnce() -> G,
) -> G {
    if let Some(guard) = try_() {
        return guard;
    }
    contended(wait, block)
}

#[cold]
fn contended<G>(wait: &mut Duration, block: impl FnOnce() -> G) -> G {
    let start = Instant::now();
    let guard = block();
    *wait += start.elapsed();
    guard
}

/// LCK: the octree behind a lock of flavour `F`.
#[derive(Debug)]
pub struct Locked<F: LockFlavour = MutexFlavour> {
    config: CacheConfig,
    tree: F,
    ledger: Ledger<()>,
    stats: CacheStats,
}

impl<F: LockFlavour> Locked<F> {
    /// An empty cache.
    pub fn new(config: CacheConfig) -> Self {
        Self {
            config,
            tree: F::new(Octree::new(config)),
            ledger: Ledger::new(),
            stats: CacheStats::default(),
        }
    }
}

/// An LCK worker.
#[derive(Debug)]
#[must_use = "a handle does nothing unless it is used"]
pub struct LckHandle<'c, F: LockFlavour> {
    cache: &'c Locked<F>,
    core: HandleCore<'c, ()>,
}

impl<F: LockFlavour> IrradianceCache for Locked<F> {
    type Handle<'c>
        = LckHandle<'c, F>
    where
        F: 'c;

    fn scheme(&self) -> Scheme {
        F::SCHEME
    }

    fn config(&self) -> &CacheConfig {
        &self.config
    }

    fn handle(&self, worker: WorkerId) -> LckHandle<'_, F> {
        LckHandle {
            cache: self,
            core: HandleCore::new(&self.ledger, worker, ()),
        }
    }

    fn end_frame(&mut self) -> FrameReport {
        let report = self.ledger.close_frame(&mut self.stats).1;
        if report.workers.removed > 0 {
            self.tree.get_mut().prune();
        }
        report
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let now = self.stats.frames;
        let tree = self.tree.get_mut();
        let (removed, work) = tree.remove(selection, now);
        if removed > 0 {
            tree.prune();
        }
        self.stats.totals.count_removal(removed, work)
    }

    fn snapshot(&mut self) -> Vec<Record> {
        self.tree.get_mut().records().copied().collect()
    }

    fn stats(&mut self) -> CacheStats {
        let tree = self.tree.get_mut();
        CacheStats {
            records: tree.len(),
            nodes: tree.node_count(),
            ..self.stats
        }
    }
}

impl<F: LockFlavour> CacheHandle for LckHandle<'_, F> {
    fn worker(&self) -> WorkerId {
        self.core.worker
    }

    fn frame(&self) -> u64 {
        self.core.frame
    }

    #[inline]
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        let mut acc = self.core.begin_lookup(&self.cache.config, point, normal)?;
        let tree = &self.cache.tree;
        let pre = *acc.prefilter();
        let work = {
            let guard = acquire(
                &mut self.core.stats.lock_wait,
                || tree.try_read(),
                || tree.read(),
            );
            guard.walk(point, |k| pre.admits(k), &mut |r| {
                acc.add(r);
            })
        };
        self.core.end_lookup(&acc, work)
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
    ) -> Option<Interpolated> {
        let cache = self.cache;
        let guard = acquire(
            &mut self.core.stats.lock_wait,
            || cache.tree.try_read(),
            || cache.tree.read(),
        );
        self.core
            .lookup_visible(&cache.config, point, normal, visible, |pre, _, f| {
                guard.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r))
            })
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        let record = self.core.admit(&self.cache.config, record)?;
        let tree = &self.cache.tree;
        let steps = {
            let mut guard = acquire(
                &mut self.core.stats.lock_wait,
                || tree.try_write(),
                || tree.write(),
            );
            guard.insert_admitted(record)
        };
        Ok(self.core.inserted(Inserted::Stored(record.id()), steps))
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let tree = &self.cache.tree;
        let (removed, work) = {
            let mut guard = acquire(
                &mut self.core.stats.lock_wait,
                || tree.try_write(),
                || tree.write(),
            );
            guard.remove(selection, self.core.frame)
        };
        self.core.stats.count_removal(removed, work)
    }

    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        let work = {
            let guard = self.cache.tree.read();
            collect_valid(&self.cache.config, point, normal, out, |pre, f| {
                guard.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r))
            })
        };
        self.core.traversed(work);
    }

    fn stats(&self) -> &WorkerStats {
        &self.core.stats
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::ic::WorkerId;

    /// A panic *inside* the critical section poisons the lock; both flavours recover the guard and
    /// the cache keeps its records and keeps working.
    fn poisoned<F: LockFlavour>() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.5).unwrap();
        let cache = Locked::<F>::new(config);
        let mut h = cache.handle(WorkerId::new(0));
        h.insert(Record::new(Vec3::ONE, Vec3::Z, Vec3::ONE, 1.0))
            .unwrap();
        let hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        let died = crate::sync::thread::scope(|s| {
            s.spawn(|| {
                let _guard = cache.tree.write();
                panic!("dies holding the lock");
            })
            .join()
            .is_err()
        });
        std::panic::set_hook(hook);
        assert!(died);
        assert!(h.lookup(Vec3::ONE, Vec3::Z).is_some());
        h.insert(Record::new(Vec3::splat(2.0), Vec3::Z, Vec3::ONE, 1.0))
            .unwrap();
        assert_eq!(h.lookup(Vec3::splat(2.0), Vec3::Z).unwrap().records, 1);
        assert_eq!(h.stats().stored, 2);
    }

    #[test]
    fn mutex_recovers_from_poisoning() {
        poisoned::<MutexFlavour>();
    }

    #[test]
    fn rwlock_recovers_from_poisoning() {
        poisoned::<RwLockFlavour>();
    }

    #[test]
    fn contended_acquisitions_are_timed() {
        let mut wait = Duration::ZERO;
        let g: u32 = acquire(&mut wait, || Some(1), || 2);
        assert_eq!((g, wait), (1, Duration::ZERO));
        let g: u32 = acquire(
            &mut wait,
            || None,
            || {
                crate::sync::thread::sleep(Duration::from_millis(5));
                2
            },
        );
        assert_eq!(g, 2);
        assert!(wait >= Duration::from_millis(5));
    }

    /// Each flavour tries its lock before it times: one worker alone reports no wait at all, and a
    /// lookup and an insert that find the lock held report the time they waited for it.
    fn waits_are_reported_only_when_real<F: LockFlavour>() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.5).unwrap();
        let cache = Locked::<F>::new(config);
        let record = |x: f32| Record::new(Vec3::new(x, 1.0, 1.0), Vec3::Z, Vec3::ONE, 1.0);
        let mut alone = cache.handle(WorkerId::new(0));
        for k in 0..100 {
            alone.insert(record(0.5 + 0.03 * k as f32)).unwrap();
            alone.lookup(Vec3::new(1.0, 1.0, 1.0), Vec3::Z);
        }
        assert_eq!(alone.stats().lock_wait, Duration::ZERO, "{}", F::SCHEME);

        let held = Duration::from_millis(30);
        for insert in [false, true] {
            let guard = cache.tree.write();
            let started = std::sync::Barrier::new(2);
            let waited = crate::sync::thread::scope(|s| {
                let worker = s.spawn(|| {
                    let mut h = cache.handle(WorkerId::new(if insert { 2 } else { 1 }));
                    started.wait();
                    if insert {
                        h.insert(record(2.0)).unwrap();
                    } else {
                        h.lookup(Vec3::ONE, Vec3::Z);
                    }
                    h.stats().lock_wait
                });
                started.wait();
                crate::sync::thread::sleep(held);
                drop(guard);
                worker.join().unwrap()
            });
            // The worker reaches the lock within microseconds of the barrier; half the hold is
            // a margin no scheduler needs.
            assert!(
                waited >= held / 2,
                "{}: {} waited {waited:?} behind a lock held for {held:?}",
                F::SCHEME,
                if insert { "an insert" } else { "a lookup" }
            );
        }
    }

    #[test]
    fn mutex_waits_are_reported_only_when_real() {
        waits_are_reported_only_when_real::<MutexFlavour>();
    }

    #[test]
    fn rwlock_waits_are_reported_only_when_real() {
        waits_are_reported_only_when_real::<RwLockFlavour>();
    }
}
