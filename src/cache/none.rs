//! The no-cache reference: a backend that stores nothing, so a renderer computes the indirect
//! term at every shading point through the same code path as with a cache (lookup, miss,
//! estimate, insert). Rendered with it, a frame is the reference the cached schemes are measured
//! against.

use super::deterministic::Visibility;
use super::frame::{HandleCore, Ledger, Work};
use super::{
    CacheConfig, CacheHandle, CacheStats, FrameReport, Inserted, IrradianceCache, Scheme,
    WorkerStats,
};
use crate::ic::{InsertError, Interpolated, Record, Selection, WorkerId};
use glam::Vec3;

/// A cache that keeps nothing: every lookup misses, every valid insert is
/// [`Inserted::NotCached`].
#[derive(Debug)]
pub struct NoCache {
    config: CacheConfig,
    ledger: Ledger<()>,
    stats: CacheStats,
}

impl NoCache {
    /// The reference for a scene whose cache would be `config` (bad records are still refused,
    /// as a real cache would refuse them).
    pub fn new(config: CacheConfig) -> Self {
        Self {
            config,
            ledger: Ledger::new(),
            stats: CacheStats::default(),
        }
    }
}

/// A worker of the reference: counters only.
#[derive(Debug)]
#[must_use = "a handle does nothing unless it is used"]
pub struct NoCacheHandle<'c> {
    config: &'c CacheConfig,
    core: HandleCore<'c, ()>,
}

impl IrradianceCache for NoCache {
    type Handle<'c> = NoCacheHandle<'c>;

    fn scheme(&self) -> Scheme {
        Scheme::None
    }

    fn config(&self) -> &CacheConfig {
        &self.config
    }

    fn handle(&self, worker: WorkerId) -> NoCacheHandle<'_> {
        NoCacheHandle {
            config: &self.config,
            core: HandleCore::new(&self.ledger, worker, ()),
        }
    }

    fn end_frame(&mut self) -> FrameReport {
        self.ledger.close_frame(&mut self.stats).1
    }

    fn remove(&mut self, _selection: &Selection) -> usize {
        0
    }

    fn snapshot(&mut self) -> Vec<Record> {
        Vec::new()
    }

    fn stats(&mut self) -> CacheStats {
        self.stats
    }
}

impl CacheHandle for NoCacheHandle<'_> {
    fn worker(&self) -> WorkerId {
        self.core.worker
    }

    fn frame(&self) -> u64 {
        self.core.frame
    }

    #[inline]
    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<Interpolated> {
        let acc = self.core.begin_lookup(self.config, point, normal)?;
        self.core.end_lookup(&acc, Work::default())
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: Visibility,
    ) -> Option<Interpolated> {
        self.core
            .lookup_visible(self.config, point, normal, visible, |_, _, _| {
                Work::default()
            })
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, InsertError> {
        let record = self.core.admit(self.config, record)?;
        Ok(self.core.inserted(Inserted::NotCached(record.id()), 0))
    }

    fn remove(&mut self, _selection: &Selection) -> usize {
        0
    }

    fn valid_records(&mut self, _point: Vec3, _normal: Vec3, _out: &mut Vec<Record>) {}

    fn stats(&self) -> &WorkerStats {
        &self.core.stats
    }
}

#[cfg(all(test, not(checker)))]
mod tests {
    use super::*;
    use crate::cache::run_frame;

    #[test]
    fn the_reference_keeps_nothing_but_counts_and_refuses_bad_records() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.3).unwrap();
        let mut cache = NoCache::new(config);
        let (outcomes, report) = run_frame(&mut cache, 2, |h, _| {
            let p = Vec3::splat(2.0);
            let stored = h.insert(Record::new(p, Vec3::Z, Vec3::ONE, 1.0));
            let outside = h.insert(Record::new(Vec3::splat(9.0), Vec3::Z, Vec3::ONE, 1.0));
            (
                matches!(stored, Ok(Inserted::NotCached(_))),
                outside.is_err(),
                h.lookup(p, Vec3::Z).is_none(),
                // The handle's own counters, before the frame sums them.
                (h.stats().lookups, h.stats().inserts, h.stats().rejected),
            )
        });
        assert_eq!(outcomes, [(true, true, true, (1, 1, 1)); 2]);
        assert_eq!(report.workers.lookups, 2);
        assert_eq!(report.workers.inserts, 2);
        assert_eq!(report.workers.rejected, 2);
        assert_eq!(report.workers.stored, 0);
        assert_eq!(report.workers.hits, 0);
        assert_eq!(cache.stats().records, 0);
        assert!(cache.snapshot().is_empty());
    }

    #[test]
    fn the_reference_has_nothing_to_remove() {
        let config = CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 0.3).unwrap();
        let mut cache = NoCache::new(config);
        let everything = Selection::touching(Vec3::ZERO, Vec3::splat(4.0)).unwrap();
        let (removed, report) = run_frame(&mut cache, 1, |h, _| {
            h.insert(Record::new(Vec3::splat(2.0), Vec3::Z, Vec3::ONE, 1.0))
                .unwrap();
            h.remove(&everything)
        });
        assert_eq!(removed, [0]);
        assert_eq!(report.workers.removed, 0);
        assert_eq!(cache.remove(&everything), 0);
        assert_eq!(cache.stats().totals.removed, 0);
    }
}
