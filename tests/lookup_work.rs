//! A lookup and `valid_records` at the same point walk the same nodes and examine the same
//! records, in every scheme (LW's local octree included), and each counts its walk once: the work counters the model checkers
//! bound (`verify/tree_shape.rs`) are the ones `lookup` itself keeps on the renderer's path.
#![cfg(not(checker))]

use glam::Vec3;
use wfic::cache::{CacheConfig, CacheHandle, CacheJob, IrradianceCache, Scheme, WorkerStats};
use wfic::ic::Record;

fn config() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 1.0).unwrap()
}

/// Records at the root, at depth 1 and at depth 2, spread over two corners of the box.
fn records() -> Vec<Record> {
    let mut out = Vec::new();
    for (i, radius) in [10.0, 0.8, 0.35, 0.35, 0.8, 0.35].into_iter().enumerate() {
        for corner in [Vec3::splat(1.0), Vec3::new(3.0, 1.0, 1.0)] {
            let p = corner + Vec3::new(0.05 * i as f32, 0.03 * i as f32, 0.0);
            out.push(Record::new(p, Vec3::Z, Vec3::ONE, radius));
        }
    }
    out
}

fn walked(s: &WorkerStats) -> (u64, u64) {
    (s.lookup_nodes, s.lookup_records)
}

struct SameWork;

impl CacheJob for SameWork {
    /// Total (nodes, records) the lookups walked.
    type Output = (u64, u64);

    fn run<C: IrradianceCache>(self, mut cache: C) -> (u64, u64) {
        let scheme = cache.scheme().name();
        {
            let frame = cache.frame();
            let mut h = frame.handle();
            for r in records() {
                h.insert(r).unwrap();
            }
        }
        // A second frame: LW's records are in the global cache now, as everyone else's.
        let frame = cache.frame();
        let mut h = frame.handle();
        // And some of this frame's own near the same corners: LW walks its local octree too,
        // after the global one, and both walks count.
        for r in records().iter().step_by(3) {
            let p = r.position + Vec3::new(0.1, 0.1, 0.0);
            h.insert(Record::new(p, Vec3::Z, Vec3::ONE, r.radius))
                .unwrap();
        }
        let mut found = Vec::new();
        for q in records()
            .iter()
            .map(|r| r.position + Vec3::new(0.02, -0.01, 0.0))
        {
            let before = *h.stats();
            h.lookup(q, Vec3::Z);
            let after_lookup = *h.stats();
            found.clear();
            h.valid_records(q, Vec3::Z, &mut found);
            let after_valid = *h.stats();
            let by_lookup = (
                after_lookup.lookup_nodes - before.lookup_nodes,
                after_lookup.lookup_records - before.lookup_records,
            );
            let by_valid = (
                after_valid.lookup_nodes - after_lookup.lookup_nodes,
                after_valid.lookup_records - after_lookup.lookup_records,
            );
            assert_eq!(
                by_lookup, by_valid,
                "{scheme}: lookup and valid_records at {q}"
            );
            assert_eq!(after_lookup.lookups, before.lookups + 1, "{scheme}");
            assert_eq!(after_valid.lookups, after_lookup.lookups, "{scheme}");
            assert!(
                after_lookup.max_lookup_nodes as u64 >= by_lookup.0,
                "{scheme}"
            );
            assert!(
                after_lookup.max_lookup_records as u64 >= by_lookup.1,
                "{scheme}"
            );
        }
        let totals = walked(h.stats());
        (totals.0 / 2, totals.1 / 2)
    }
}

#[test]
fn lookup_and_valid_records_count_the_same_walk() {
    for scheme in Scheme::ALL {
        let (nodes, records) = scheme.build(config(), SameWork);
        if scheme == Scheme::None {
            assert_eq!(
                (nodes, records),
                (0, 0),
                "the reference keeps nothing to walk"
            );
        } else {
            // 12 queries, each at least the root and one record in it.
            assert!(
                nodes >= 12 && records >= 12,
                "{scheme}: ({nodes}, {records})"
            );
        }
    }
}

#[path = "../verify/tree_shape.rs"]
mod tree_shape;

/// Every scheme counts a removal's work as the loom models bound it: a removal through a handle
/// and one through the cache visit exactly the nodes the selection may reach and examine the
/// records those nodes hold (`TreeShape::removal_reach`), nothing beside them running. The
/// selection meets one corner of the box, so a removal that did not prune would visit more.
struct RemovalWork;

impl CacheJob for RemovalWork {
    /// (handle removals' (nodes, records), cache removals' (nodes, records)), summed.
    type Output = ((u64, u64), (u64, u64));

    fn run<C: IrradianceCache>(self, mut cache: C) -> Self::Output {
        use tree_shape::{TreeShape, Work};
        let scheme = cache.scheme().name();
        let near = wfic::ic::Selection::touching(Vec3::splat(0.9), Vec3::splat(1.1)).unwrap();
        let all = records();
        let shape = TreeShape::of(&config(), &all);
        let allowed = shape.removal_reach(&near);
        let totals = |c: &mut C| {
            let t = c.stats().totals;
            (t.removal_nodes, t.removal_records, t.removed)
        };
        {
            let frame = cache.frame();
            let mut h = frame.handle();
            for r in &all {
                h.insert(*r).unwrap();
            }
        }
        let mut by_handle = (0, 0);
        if scheme != Scheme::Lw.name() && scheme != Scheme::None.name() {
            // LW's handles remove from their own frame's records; the global octree's removal is
            // the merge's, counted below with the cache's own. The reference keeps nothing.
            let frame = cache.frame();
            let mut h = frame.handle();
            let (removed, did) = tree_shape::counted_removal(&mut h, &near);
            assert!(removed > 0, "{scheme}: the selection took nothing");
            assert_eq!(did, allowed, "{scheme}: a handle's removal");
            by_handle = (did.nodes, did.records);
        }
        // The same selection again through the cache: the records are gone, but their slots
        // and nodes too (the removal above closed its frame, which reclaims them), so the shape
        // is the survivors'.
        let left: Vec<Record> = cache.snapshot();
        let expected = if scheme == Scheme::None.name() {
            Work::default()
        } else {
            TreeShape::of(&config(), &left).removal_reach(&near)
        };
        let before = totals(&mut cache);
        let removed = cache.remove(&near);
        let after = totals(&mut cache);
        assert_eq!(after.2 - before.2, removed as u64, "{scheme}");
        let did = Work {
            nodes: after.0 - before.0,
            records: after.1 - before.1,
        };
        assert_eq!(did, expected, "{scheme}: the cache's removal");
        assert!(
            scheme == Scheme::None.name() || did.nodes < shape.nodes() as u64,
            "{scheme}: the selection reaches every node, so the test cannot tell pruning apart"
        );
        (by_handle, (did.nodes, did.records))
    }
}

#[test]
fn removal_work_is_what_the_selection_may_reach() {
    for scheme in Scheme::ALL {
        let (by_handle, by_cache) = scheme.build(config(), RemovalWork);
        eprintln!("{scheme}: handle removal {by_handle:?}, cache removal {by_cache:?}");
        if scheme != Scheme::None {
            assert!(by_cache.0 >= 1, "{scheme}: the root is always visited");
        }
    }
}
