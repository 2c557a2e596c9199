//! WF's own accessors, counted exactly on a tree whose shape is known: the policy, the `Debug`
//! output, and `stats`, `snapshot` and the frame report after a few inserts. (The model checkers
//! cover WF's concurrency; these pin what a single thread reads back.)
#![cfg(not(checker))]

use glam::Vec3;
use std::collections::HashSet;
use wfic::cache::{
    CacheConfig, CacheHandle, CasFailure, Inserted, IrradianceCache, Scheme, WaitFree,
};
use wfic::ic::Record;

fn config() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 1.0).unwrap()
}

#[test]
fn the_constructors_set_the_policy() {
    assert_eq!(WaitFree::adopt(config()).policy(), CasFailure::Adopt);
    assert_eq!(WaitFree::discard(config()).policy(), CasFailure::Discard);
    assert_eq!(WaitFree::adopt(config()).scheme(), Scheme::Wf);
    assert_eq!(WaitFree::discard(config()).scheme(), Scheme::WfDiscard);
}

#[test]
fn debug_names_the_orderings_and_the_policy() {
    let text = format!("{:?}", WaitFree::discard(config()));
    assert!(text.starts_with("WaitFree"), "{text}");
    assert!(text.contains("Discard"), "{text}");
    assert!(text.contains("minimal"), "{text}");
}

#[test]
fn stats_snapshot_and_report_count_exactly() {
    let mut cache = WaitFree::adopt(config());
    // Two root records (influence larger than the root), one at depth 1 and two sharing a depth-2
    // node below it: root + 1 + 1 nodes.
    let records = [
        Record::new(Vec3::splat(2.0), Vec3::Z, Vec3::ONE, 10.0),
        Record::new(Vec3::splat(2.5), Vec3::Z, Vec3::ONE, 10.0),
        Record::new(Vec3::splat(1.0), Vec3::Z, Vec3::ONE, 0.8),
        Record::new(Vec3::splat(0.5), Vec3::Z, Vec3::ONE, 0.35),
        Record::new(Vec3::splat(0.6), Vec3::Z, Vec3::ONE, 0.35),
    ];
    let frame = cache.frame();
    let mut ids = HashSet::new();
    {
        let mut h = frame.handle();
        for r in records {
            match h.insert(r).unwrap() {
                Inserted::Stored(id) => assert!(ids.insert(id)),
                other => panic!("{other:?}"),
            }
        }
    }
    let report = frame.close();
    assert_eq!(report.workers.inserts, 5);
    assert_eq!(report.workers.stored, 5);
    let stats = cache.stats();
    assert_eq!(stats.records, 5);
    assert_eq!(stats.nodes, 3);
    assert_eq!(stats.frames, 1);
    let seen: HashSet<_> = cache.snapshot().iter().map(Record::id).collect();
    assert_eq!(seen, ids);
}
