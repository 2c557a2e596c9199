//! The bodies of the WF models, generic over the ordering policy so that the same model proves the
//! shipped policy right (`verify/loom_wf.rs`) and refutes each weakening
//! (`verify/loom_orderings.rs`). Each body runs once per loom execution and returns what it
//! observed, so the caller can check, across executions, that the interesting schedule was reached.

use super::tree_shape::check_lookup;
use super::*;
use std::collections::HashSet;
use wfic::cache::wf::{Orderings, RecordList};
use wfic::cache::{CasFailure, Inserted, IrradianceCache, WaitFree};
use wfic::sync::thread;

fn wf<O: Orderings>(policy: CasFailure) -> Arc<WaitFree<O>> {
    Arc::new(WaitFree::<O>::new(config(), policy))
}

/// Two threads append to one node's list (the root). Both stored, distinct, whole; no level
/// descended, no compare-and-swap.
pub fn two_inserts_into_one_list<O: Orderings>() {
    let cache = wf::<O>(CasFailure::Adopt);
    let c = cache.clone();
    let t = thread::spawn(move || insert_one(&*c, 1, root_record(0.5)));
    let mine = insert_one(&*cache, 0, root_record(-0.5));
    let theirs = t.join().unwrap();
    assert!(matches!(mine.0, Inserted::Stored(_)) && matches!(theirs.0, Inserted::Stored(_)));
    let found = valid_at(&*cache, 9, Vec3::splat(2.0));
    assert_eq!(found.len(), 2, "both records must be found");
    let ids: HashSet<_> = found.iter().map(|r| r.id()).collect();
    assert_eq!(ids.len(), 2, "duplicated record");
    assert!(found.iter().all(|r| r.is_intact()), "torn record");
    assert_eq!((mine.1, theirs.1), (0, 0), "root inserts take no step down");
}

/// Two inserts need the same missing child and race to publish it. Returns whether a
/// compare-and-swap was lost in this execution.
///
/// `Adopt`: both records found, each insert within `2 * depth` steps, and the loser's private
/// child never linked. `Discard`: the records found are exactly the ones reported stored, and a
/// lost race discards exactly one.
pub fn two_inserts_race_to_create_one_child<O: Orderings>(policy: CasFailure) -> bool {
    let cache = wf::<O>(policy);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, child_record(0.0)));
    let mine = insert_one(&*cache, 0, child_record(0.2));
    let theirs = t.join().unwrap();
    let lost = mine.2 + theirs.2;
    assert!(lost <= 1, "two compare-and-swaps lost on one pointer");
    let bound = 2 * CHILD_DEPTH;
    assert!(
        mine.1 <= bound && theirs.1 <= bound,
        "steps {} {} > {bound}",
        mine.1,
        theirs.1
    );
    let stored = [mine.0, theirs.0]
        .iter()
        .filter(|o| matches!(o, Inserted::Stored(_)))
        .count();
    let mut cache = Arc::try_unwrap(cache).expect("threads joined");
    let shape = settled_shape(&mut cache);
    let p = child_record(0.1).position;
    let (found, did) = lookup_at(&cache, 9, p);
    assert!(found.iter().all(|r| r.is_intact()), "torn record");
    assert_eq!(
        found.len(),
        stored,
        "stored records must be found, discarded ones not"
    );
    check_lookup("child race", p, did, shape.reach(p), true);
    match policy {
        CasFailure::Adopt => assert_eq!(stored, 2, "Adopt must keep both samples"),
        CasFailure::Discard => assert_eq!(stored as u64, 2 - lost, "a lost race discards one"),
    }
    assert_eq!(
        cache.stats().nodes,
        2,
        "the loser's private child must not be linked"
    );
    lost > 0
}

/// A lookup races with an insert that publishes a new child. It finds nothing or exactly the
/// record, whole: never a half-built subtree. Returns whether it found the record.
pub fn insert_races_lookup_through_a_new_child<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let c = cache.clone();
    let p = child_record(0.0).position;
    let t = Go::race(move || insert_one(&*c, 1, child_record(0.0)));
    let (found, did) = lookup_at(&*cache, 0, p);
    assert!(found.len() <= 1);
    let saw = found.first().is_some_and(|r| {
        assert!(r.is_intact(), "torn record");
        assert_eq!(r.position, child_record(0.0).position, "phantom record");
        true
    });
    t.join().unwrap();
    let mut cache = Arc::try_unwrap(cache).expect("threads joined");
    let shape = settled_shape(&mut cache);
    check_lookup("new child", p, did, shape.reach(p), false);
    saw
}

/// A lookup races with an insert into an existing node's list (the slot-publication path).
/// Returns whether it found the record.
pub fn insert_races_lookup_in_one_list<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, root_record(0.0)));
    let found = valid_at(&*cache, 0, Vec3::splat(2.0));
    assert!(found.len() <= 1);
    assert!(found
        .iter()
        .all(|r| r.is_intact() && r.position == root_record(0.0).position));
    t.join().unwrap();
    !found.is_empty()
}

/// Two appends to a bare list race with a scan. Returns whether the scan saw the record of the
/// *second* reserved slot without the first: slot k+1 published before slot k.
pub fn a_later_slot_can_be_published_before_an_earlier_one<O: Orderings>() -> bool {
    let list = Arc::new(RecordList::<O>::new());
    let (l1, l2) = (list.clone(), list.clone());
    let a = thread::spawn(move || l1.push(sealed(1.0)).unwrap());
    let b = thread::spawn(move || l2.push(sealed(2.0)).unwrap());
    let mut seen = Vec::new();
    list.for_each(&mut |r| {
        assert!(r.is_intact(), "torn record");
        seen.push(r.position.x);
    });
    let (ia, ib) = (a.join().unwrap(), b.join().unwrap());
    assert_eq!(ia + ib, 1, "indices 0 and 1");
    let later = if ia == 1 { 1.0 } else { 2.0 };
    seen == [later]
}

/// The list grows a second segment (slots 2..6) while another thread appends and the main thread
/// scans: everything found is whole, a record published before the threads started is never
/// missed, and the final list holds exactly the three records.
pub fn a_segment_grows_while_another_thread_inserts_and_a_third_reads<O: Orderings>() {
    let list = Arc::new(RecordList::<O>::new());
    list.push(sealed(0.0)).unwrap();
    let (l1, l2) = (list.clone(), list.clone());
    let a = thread::spawn(move || l1.push(sealed(1.0)).unwrap());
    let b = thread::spawn(move || l2.push(sealed(2.0)).unwrap());
    let mut seen = Vec::new();
    list.for_each(&mut |r| {
        assert!(r.is_intact(), "torn record");
        seen.push(r.position.x);
    });
    assert!(
        seen.contains(&0.0),
        "a record published before the threads started was missed"
    );
    let mut idx = [a.join().unwrap(), b.join().unwrap()];
    idx.sort_unstable();
    assert_eq!(idx, [1, 2]);
    let mut list = Arc::try_unwrap(list).unwrap_or_else(|_| panic!("threads joined"));
    assert_eq!(list.published(), 3);
}

/// Two appends race to install the same missing segment (slots 2 and 3 are segment 1): one
/// compare-and-swap wins, the loser frees its own segment and writes into the winner's.
pub fn two_inserts_race_to_install_one_segment<O: Orderings>() {
    let list = Arc::new(RecordList::<O>::new());
    list.push(sealed(0.0)).unwrap();
    list.push(sealed(1.0)).unwrap(); // segment 0 (2 slots) is full
    let (l1, l2) = (list.clone(), list.clone());
    let a = thread::spawn(move || l1.push(sealed(2.0)).unwrap());
    let b = thread::spawn(move || l2.push(sealed(3.0)).unwrap());
    let mut idx = [a.join().unwrap(), b.join().unwrap()];
    idx.sort_unstable();
    assert_eq!(idx, [2, 3]);
    let mut seen = Vec::new();
    list.for_each(&mut |r| {
        assert!(r.is_intact(), "torn record");
        seen.push(r.position.x);
    });
    seen.sort_by(f32::total_cmp);
    assert_eq!(seen, [0.0, 1.0, 2.0, 3.0]);
}
