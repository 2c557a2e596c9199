//! LW: the local-write cache (paper §3.2, Listing 5).
//!
//! A global octree that nobody writes during a frame, plus one local octree per worker. A worker
//! reads both and writes only its own; at the frame barrier [`IrradianceCache::end_frame`] merges
//! every local octree into the global one, one after another, and times it.
//!
//! The "no write to the global cache during a frame" rule is the borrow checker's: handles borrow
//! the cache shared (`&self`), the global octree is only reachable through that shared borrow, and
//! merging needs `&mut self`, which cannot coexist with a live handle:
//!
//! ```compile_fail,E0502
//! use wfic::cache::{CacheConfig, CacheHandle, IrradianceCache, LocalWrite};
//! use wfic::ic::WorkerId;
//! use glam::Vec3;
//! let mut lw = LocalWrite::new(CacheConfig::new(Vec3::ZERO, Vec3::ONE, 0.3).unwrap());
//! let handle = lw.handle(WorkerId::new(0));
//! lw.end_frame(); // error: `lw` is borrowed by `handle`
//! drop(handle);
//! ```
//!
//! Removal ([`CacheHandle::remove`]) follows the same rule: a worker removes its own local records
//! at once, and the global octree's at the merge, before the frame's local records join it.
//!
//! A worker's local records reach the merge however its handle ends: dropped at the end of its
//! work, or unwound by a panic (the records it holds were each inserted whole).
//!
//! Deviations from Listing 5 (`paper-notes.md` lists them all): the listing consults the local cache only when
//! the global one *found* something (`if (inIC)`, a slip for `if (!inIC)`); and even corrected it
//! would answer from one of the two caches. Here one lookup averages the valid records of both,
//! which is exactly what a single merged cache would answer.

use super::deterministic::Visibility;
use super::frame::{collect_valid, HandleCore, Ledger, Local};
use super::{
    CacheConfig, CacheHandle, CacheStats, FrameReport, Inserted, IrradianceCache, Octree, Scheme,
    WorkerStats,
};
use crate::ic::{InsertError, Interpolated, Record, Selection, WorkerId};
use glam::Vec3;
use std::time::Instant;

/// LW: a global octree read-only during a frame, and local octrees merged at its end.
#[derive(Debug)]
pub struct LocalWrite {
    global: Octree,
    ledger: Ledger<Pending>,
    stats: CacheStats,
}

/// What an LW worker keeps for the merge: its local octree and the removals it asked for.
#[derive(Debug)]
pub(crate) struct Pending {
    tree: Octree,
    removals: Vec<(Selection, u64)>,
}

impl Local for Pending {
    fn take(&mut self) -> Self {
        Self {
            tree: self.tree.take(),
            removals: std::mem::take(&mut self.removals),
        }
    }
}

impl LocalWrite {
    /// An empty cache.
    pub fn new(config: CacheConfig) -> Self {
        Self {
            global: Octree::new(config),
            ledger: Ledger::new(),
            stats: CacheStats::default(),
        }
    }
}

/// An LW worker: the shared global octree and the worker's own local one (in its core, which
/// hands it to the merge when the handle is dropped).
#[derive(Debug)]
#[must_use = "a handle does nothing unless it is used"]
pub struct LwHandle<'c> {
    global: &'c Octree,
    core: HandleCore<'c, Pending>,
}

impl IrradianceCache for LocalWrite {
    type Handle<'c> = LwHandle<'c>;

    fn scheme(&self) -> Scheme {
        Scheme::Lw
    }

    fn config(&self) -> &CacheConfig {
        self.global.config()
    }

    fn handle(&self, worker: WorkerId) -> LwHandle<'_> {
        LwHandle {
            global: &self.global,
            core: HandleCore::new(
                &self.ledger,
                worker,
                Pending {
                    tree: Octree::new(*self.global.config()),
                    removals: Vec::new(),
                },
            ),
        }
    }

    fn end_frame(&mut self) -> FrameReport {
        let (deposits, mut report) = self.ledger.close_frame(&mut self.stats);
        let start = Instant::now();
        // The removals first: they were asked for before (or while) the frame's local records
        // were computed, and each worker already applied its own to its local octree.
        let mut removed = 0;
        for deposit in &deposits {
            for (selection, frame) in &deposit.local.removals {
                let (taken, work) = self.global.remove(selection, *frame);
                report.workers.count_removal(taken, work);
                self.stats.totals.count_removal(taken, work);
                removed += taken;
            }
        }
        if removed > 0 {
            self.global.prune();
        }
        for deposit in &deposits {
            for record in deposit.local.tree.records() {
                // Admitted by the handle already: same bounds, validated and sealed.
                self.global.insert_admitted(*record);
            }
        }
        report.merge = start.elapsed();
        self.stats.merge += report.merge;
        report
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let (removed, work) = self.global.remove(selection, self.stats.frames);
        if removed > 0 {
            self.global.prune();
        }
        self.stats.totals.count_removal(removed, work)
    }

    fn snapshot(&mut self) -> Vec<Record> {
        self.global.records().copied().collect()
    }

    fn stats(&mut self) -> CacheStats {
        CacheStats {
            records: self.global.len(),
            nodes: self.global.node_count(),
            ..self.stats
        }
    }
}

impl CacheHandle for LwHandle<'_> {
    fn worker(&self) -> WorkerId {
        self.core.worker
    }

    fn frame(&self) -> u64 {
        self.core.frame
    }

    #[inline]
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        let mut acc = self
            .core
            .begin_lookup(self.global.config(), point, normal)?;
        let pre = *acc.prefilter();
        let mut add = |r: &Record| {
            acc.add(r);
        };
        let mut work = self.global.walk(point, |k| pre.admits(k), &mut add);
        if !self.core.local.tree.is_empty() {
            work += self
                .core
                .local
                .tree
                .walk(point, |k| pre.admits(k), &mut add);
        }
        self.core.end_lookup(&acc, work)
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
    ) -> Option<Interpolated> {
        let global = self.global;
        // As a lookup does: the local octree only once it holds a record.
        self.core
            .lookup_visible(global.config(), point, normal, visible, |pre, local, f| {
                let mut work = global.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r));
                if !local.tree.is_empty() {
                    work += local
                        .tree
                        .walk(pre.point(), |k| pre.admits(k), &mut |r| f(r));
                }
                work
            })
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        let record = self.core.admit(self.global.config(), record)?;
        let steps = self.core.local.tree.insert_admitted(record);
        Ok(self.core.inserted(Inserted::Stored(record.id()), steps))
    }

    fn remove(&mut self, selection: &Selection) -> usize {
        let frame = self.core.frame;
        let local = &mut self.core.local;
        let (removed, work) = local.tree.remove(selection, frame);
        local.removals.push((*selection, frame));
        self.core.stats.count_removal(removed, work)
    }

    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        let (global, local) = (self.global, &self.core.local.tree);
        // As a lookup does: the local octree only once it holds a record.
        let work = collect_valid(global.config(), point, normal, out, |pre, f| {
            let mut work = global.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r));
            if !local.is_empty() {
                work += local.walk(pre.point(), |k| pre.admits(k), &mut |r| f(r));
            }
            work
        });
        self.core.traversed(work);
    }

    fn stats(&self) -> &WorkerStats {
        &self.core.stats
    }
}
