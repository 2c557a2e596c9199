//! The bodies of the WF models, generic over the ordering policy so that the same model proves the
//! shipped policy right (`verify/loom_wf.rs`) and refutes each weakening
//! (`verify/loom_orderings.rs`). Each body runs once per loom execution and returns what it
//! observed, so the caller can check, across executions, that the interesting schedule was reached.

use super::tree_shape::{check_lookup, check_removal, counted_removal, TreeShape, Work};
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

/// A list rebuilt as one block at the frame's close grows on in the next frame. Seven records in
/// the root's list fill segments of two and four slots and open a third (eight): the handle notes
/// the list, and the close finds seven of fourteen slots unused and rebuilds it as one block of
/// seven. In the next frame one append installs the directory and the first segment after that
/// block (slot 7) while another thread reads: the reader sees every record sealed before the
/// frame, whole, and the append whole or not at all. (Two appends racing for a directory and a
/// segment are `two_inserts_race_to_install_one_segment`; the block's length changes only where
/// the directory pointer lies.) A later append (slot 8) lands in the same segment; one segment past
/// the block is kept at the next close, and loom's leak check sees every block the rebuild
/// replaced freed.
pub fn a_sealed_list_grows_while_another_thread_reads<O: Orderings>() {
    let mut cache = WaitFree::<O>::new(config(), CasFailure::Adopt);
    let mut h = cache.handle(WorkerId::new(0));
    for k in 0..7 {
        assert!(matches!(
            h.insert(root_record(k as f32 * 0.01)),
            Ok(Inserted::Stored(_))
        ));
    }
    drop(h);
    cache.end_frame();
    assert_eq!(
        (cache.allocated_slots(), cache.stats().records),
        (7, 7),
        "the close did not rebuild the list at its length"
    );
    let cache = Arc::new(cache);
    let c = cache.clone();
    let writer = thread::spawn(move || insert_one(&*c, 1, root_record(0.3)));
    let found = valid_at(&*cache, 2, Vec3::splat(2.0));
    assert!(found.iter().all(|r| r.is_intact()), "torn record");
    assert!(
        found.len() >= 7,
        "a record sealed before the frame was missed: {} found",
        found.len()
    );
    assert!(matches!(writer.join().unwrap().0, Inserted::Stored(_)));
    assert!(matches!(
        insert_one(&*cache, 3, root_record(0.4)).0,
        Inserted::Stored(_)
    ));
    let mut cache = Arc::try_unwrap(cache).unwrap_or_else(|_| panic!("threads joined"));
    let found = valid_at(&cache, 0, Vec3::splat(2.0));
    let ids: HashSet<_> = found.iter().map(|r| r.id()).collect();
    assert_eq!(ids.len(), 9, "records lost or duplicated after the block");
    cache.end_frame();
    assert_eq!(
        (cache.allocated_slots(), cache.stats().records),
        (11, 9),
        "one segment past the block is kept"
    );
}

/// Nodes a frame's close moved into the slab are read, grown below and freed as boxed ones are.
/// Frame 1 stores a record at depth 2: the graft boxes two nodes, and the close moves both into
/// the slab. In frame 2 one thread grafts a depth-3 node below the slab's depth-2 node while
/// another reads there: the reader sees the frame-1 record whole, and the new one whole or not at
/// all. Frame 2's close moves all three nodes into a new slab (one new node against a slab of two
/// is past the quarter), freeing the old slab and the box. A removal of both records then frees
/// every node in place; loom's leak check sees every node and segment dropped.
pub fn a_relocated_tree_grows_while_another_thread_reads<O: Orderings>() -> bool {
    let (old, new) = (record_at_depth(2, 0.5), record_at_depth(3, 0.5));
    let mut cache = WaitFree::<O>::new(config(), CasFailure::Adopt);
    insert_one(&cache, 0, old);
    cache.end_frame();
    assert_eq!(
        cache.slab_len(),
        2,
        "the close did not move the path into the slab"
    );
    let cache = Arc::new(cache);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, new));
    let found = valid_at(&*cache, 2, new.position);
    assert!(found.iter().all(|r| r.is_intact()), "torn record");
    assert!(
        found
            .iter()
            .any(|r| r.position == old.position && r.radius == old.radius),
        "the record sealed before the frame was missed"
    );
    let saw = found.len() == 2;
    t.join().unwrap();
    let mut cache = Arc::try_unwrap(cache).unwrap_or_else(|_| panic!("threads joined"));
    cache.end_frame();
    assert_eq!(
        (cache.slab_len(), cache.stats().nodes, cache.stats().records),
        (3, 4, 2),
        "the close did not move the grown path"
    );
    let both = wfic::ic::Selection::touching(new.position, new.position).unwrap();
    assert_eq!(cache.remove(&both), 2);
    assert_eq!(
        (cache.slab_len(), cache.stats().nodes),
        (0, 1),
        "the removal did not free the slab's nodes"
    );
    saw
}

/// Two appends race to install the same missing segment (slots 2 and 3 are segment 1), and before
/// it the list's directory of later segments: each race is won by one compare-and-swap, and the
/// loser frees its own directory or segment and uses the winner's.
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

/// Two appends race to install segment 2 (slots 6 to 13) of a list whose first two segments, and
/// so its directory, already exist: the race is for the segment alone, not for the directory too
/// (which `two_inserts_race_to_install_one_segment` also races for).
pub fn two_inserts_race_to_install_a_later_segment<O: Orderings>() {
    let list = Arc::new(RecordList::<O>::new());
    for k in 0..6 {
        list.push(sealed(k as f32)).unwrap(); // segments 0 (2 slots) and 1 (4) are full
    }
    let (l1, l2) = (list.clone(), list.clone());
    let a = thread::spawn(move || l1.push(sealed(6.0)).unwrap());
    let b = thread::spawn(move || l2.push(sealed(7.0)).unwrap());
    let mut idx = [a.join().unwrap(), b.join().unwrap()];
    idx.sort_unstable();
    assert_eq!(idx, [6, 7]);
    let mut seen = 0;
    list.for_each(&mut |r| {
        assert!(r.is_intact(), "torn record");
        seen += 1;
    });
    assert_eq!(seen, 8);
}

/// An insert stores a record in a depth-1 node that another insert is publishing; the lookup that
/// follows the first insert (its thread joined, so the insert happens-before the lookup) must find
/// the record, whether or not the publisher has yet set the node's bit in the root's occupancy
/// mask. Returns whether, in this execution, the record's insert walked into the node the other
/// insert published (one step, no compare-and-swap): the case where only its own marking makes
/// the record visible.
pub fn an_insert_below_a_child_not_yet_marked_is_found<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let (c1, c2) = (cache.clone(), cache.clone());
    let mine = record_at_depth(1, 1.0);
    let publisher = thread::spawn(move || insert_one(&*c1, 1, deep_a()));
    let inserter = thread::spawn(move || insert_one(&*c2, 2, record_at_depth(1, 1.0)));
    let (outcome, steps, lost) = inserter.join().unwrap();
    assert!(matches!(outcome, Inserted::Stored(_)));
    let found = valid_at(&*cache, 0, mine.position);
    assert!(
        found
            .iter()
            .any(|r| r.position == mine.position && r.is_intact()),
        "a record whose insert happened-before the lookup was missed"
    );
    publisher.join().unwrap();
    steps == 1 && lost == 0
}

/// The depth of the deep models' records: a record's path below the root is three nodes, so a
/// graft at depth 1 publishes a private chain of three and a graft at depth 2 one of two.
pub const DEEP: u32 = 3;

/// The deep models' two records. Both are placed at depth [`DEEP`] under the same depth-1 node
/// ((-,-,-)), and their paths part just below it: `A` goes to the -x depth-2 child, `B` to the +x
/// one. Neither one's depth-2 or depth-3 loose cell holds the other's position, so a lookup at
/// either point must leave the other's branch out.
pub fn deep_a() -> Record {
    record_at_depth(DEEP, 0.2)
}

/// See [`deep_a`].
pub fn deep_b() -> Record {
    record_at_depth(DEEP, 1.7)
}

/// Two inserts at depth [`DEEP`] race to create the same missing depth-1 child; below it their
/// paths diverge. Returns whether a compare-and-swap was lost in this execution.
///
/// The winner publishes its whole path (three nodes) with one compare-and-swap. With `Adopt` the
/// loser frees its private three-node chain, walks into the winner's depth-1 node and grafts its
/// own two-node chain below it: the loser's insert then took exactly 4 steps (descend, lost
/// compare-and-swap, descend, won compare-and-swap), both records are stored and the tree has the
/// root, the shared depth-1 node and both two-node branches. With `Discard` the loser's record
/// and chain are gone: one branch. In every execution the tree is exactly the stored records'
/// tree, and a quiescent lookup at either record walks exactly the part of it that its point
/// reaches and finds exactly its own record when stored.
pub fn two_deep_inserts_race_for_a_shared_child<O: Orderings>(policy: CasFailure) -> bool {
    let (a, b) = (deep_a(), deep_b());
    let cache = wf::<O>(policy);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, a));
    let mine = insert_one(&*cache, 0, b);
    let theirs = t.join().unwrap();
    let lost = mine.2 + theirs.2;
    assert!(lost <= 1, "two compare-and-swaps lost");
    let bound = 2 * DEEP;
    assert!(
        mine.1 <= bound && theirs.1 <= bound,
        "steps {} {} > {bound}",
        mine.1,
        theirs.1
    );
    let is_stored = |o: &Inserted| matches!(o, Inserted::Stored(_));
    let stored = usize::from(is_stored(&mine.0)) + usize::from(is_stored(&theirs.0));
    let mut cache = Arc::try_unwrap(cache).expect("threads joined");
    let shape = settled_shape(&mut cache);
    // Nodes of one record's path below the shared depth-1 node.
    let branch = (DEEP - 1) as usize;
    match policy {
        CasFailure::Adopt => {
            assert_eq!(stored, 2, "Adopt must keep both samples");
            assert_eq!(
                shape.nodes(),
                2 + 2 * branch,
                "root, one shared depth-1 node, two branches"
            );
            if lost == 1 {
                let loser = if mine.2 == 1 { mine } else { theirs };
                assert_eq!(
                    loser.1, 4,
                    "the loser must adopt the winner's depth-1 node and graft its own chain below it"
                );
            }
        }
        CasFailure::Discard => {
            assert_eq!(stored as u64, 2 - lost, "a lost race discards one");
            assert_eq!(
                shape.nodes(),
                2 + stored * branch,
                "root, one depth-1 node, one branch per stored record"
            );
        }
    }
    for (worker, r, outcome) in [(8, a, theirs.0), (9, b, mine.0)] {
        let (found, did) = lookup_at(&cache, worker, r.position);
        check_lookup(
            "deep child race",
            r.position,
            did,
            shape.reach(r.position),
            true,
        );
        assert!(found.iter().all(|f| f.is_intact()), "torn record");
        let expected: Vec<_> = is_stored(&outcome)
            .then_some(outcome.id())
            .into_iter()
            .collect();
        let ids: Vec<_> = found.iter().map(|f| f.id()).collect();
        assert_eq!(
            ids, expected,
            "a lookup at a record finds exactly it, if stored"
        );
    }
    lost > 0
}

/// A lookup races with an insert that publishes a three-node chain (depth-1 to depth-3 nodes and
/// the record) with one compare-and-swap. The lookup finds nothing, having visited the root alone,
/// or the whole record, having visited the root and the whole chain: never part of a chain.
/// Returns whether it found the record.
pub fn lookup_races_a_deep_chain<O: Orderings>() -> bool {
    let r = deep_a();
    let cache = wf::<O>(CasFailure::Adopt);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, r));
    let (found, did) = lookup_at(&*cache, 0, r.position);
    let whole = Work {
        nodes: 1 + u64::from(DEEP),
        records: 1,
    };
    let saw = match found.as_slice() {
        [] => {
            assert_eq!(
                did,
                Work {
                    nodes: 1,
                    records: 0
                },
                "a lookup that found nothing walked into a half-built chain"
            );
            false
        }
        [f] => {
            assert!(f.is_intact(), "torn record");
            assert_eq!(f.position, r.position, "phantom record");
            assert_eq!(
                did, whole,
                "the record was found, but not through the whole chain"
            );
            true
        }
        more => panic!("{} records found, one inserted", more.len()),
    };
    t.join().unwrap();
    let mut cache = Arc::try_unwrap(cache).expect("threads joined");
    let shape = settled_shape(&mut cache);
    assert_eq!(shape.reach(r.position), whole);
    check_lookup(
        "deep chain",
        r.position,
        did,
        shape.reach(r.position),
        false,
    );
    saw
}

/// Happens-before: an insert at depth 2 completes, then its thread sets a flag with Release; the
/// main thread loads the flag with Acquire, then looks up at the record. If it saw the flag, the
/// insert happens-before the lookup, and the lookup must find the record: nothing that
/// happens-before a lookup is missed (the precise claim, in the C++ model). Returns whether the
/// flag was seen.
///
/// With `existing`, another record was stored in the same depth-2 node before the threads
/// started, so the insert appends to a published list (Reserve, then SlotPublish) instead of
/// grafting a new chain. That is where the two Relaxed sites matter. The insert's `fetch_add` on
/// the head (Reserve) happens-before the lookup's load of that head (HeadRead) through the
/// flag, so by write-read coherence the load returns that value or a later one in the head's
/// modification order, never an older one. The scan therefore covers the new slot. The slot's
/// own Acquire load of its ready flag, which happens-after the Release store of it, sees `true`.
/// An ordering makes a load see a store that happens-before it, not a store that does not, so
/// nothing stronger than Relaxed is needed at either site. Without `existing`, the head is
/// written in the private chain before the Release compare-and-swap that publishes it.
pub fn an_insert_that_happens_before_a_lookup_is_found<O: Orderings>(existing: bool) -> bool {
    let earlier = record_at_depth(2, 0.2);
    let r = record_at_depth(2, 0.3);
    let cache = wf::<O>(CasFailure::Adopt);
    if existing {
        insert_one(&*cache, 2, earlier);
    }
    let flag = Arc::new(AtomicBool::new(false));
    let (c, f) = (cache.clone(), flag.clone());
    let t = thread::spawn(move || {
        insert_one(&*c, 1, r);
        // Release: the insert, and everything before it in this thread, happens-before any
        // Acquire load that reads this `true`.
        f.store(true, Ordering::Release);
    });
    // Acquire: pairs with the Release store above.
    let flagged = flag.load(Ordering::Acquire);
    let (found, did) = lookup_at(&*cache, 0, r.position);
    assert!(found.iter().all(|f| f.is_intact()), "torn record");
    let has = |x: &Record| found.iter().any(|f| f.position == x.position);
    if flagged {
        assert!(
            has(&r),
            "an insert that happens-before the lookup was missed"
        );
    }
    if existing {
        assert!(
            has(&earlier),
            "a record stored before the threads started was missed"
        );
    }
    t.join().unwrap();
    let mut cache = Arc::try_unwrap(cache).expect("threads joined");
    let shape = settled_shape(&mut cache);
    check_lookup(
        "happens-before",
        r.position,
        did,
        shape.reach(r.position),
        false,
    );
    flagged
}

// ---------------------------------------------------------------------------------------------
// Removal (`CacheHandle::remove`): a slot goes from live to removed by one compare-and-swap.
// ---------------------------------------------------------------------------------------------

/// A selection taking every record whose influence meets the point `p`.
fn at_point(p: Vec3) -> wfic::ic::Selection {
    wfic::ic::Selection::touching(p, p).expect("a finite point")
}

/// Removes what `selection` takes through a fresh handle of worker `worker`; returns the count.
pub fn remove_one<C: IrradianceCache>(
    cache: &C,
    worker: u32,
    selection: &wfic::ic::Selection,
) -> usize {
    remove_counted(cache, worker, selection).0
}

/// [`remove_one`], also returning the nodes the removal visited and the slots it examined.
pub fn remove_counted<C: IrradianceCache>(
    cache: &C,
    worker: u32,
    selection: &wfic::ic::Selection,
) -> (usize, Work) {
    let mut h = cache.handle(WorkerId::new(worker));
    let out = counted_removal(&mut h, selection);
    drop(h);
    out
}

/// The work a removal of `selection` may do in a tree of the records `inserted` (every record
/// inserted so far, removed or not: their slots and nodes stay until the frame closes).
fn removal_bound(inserted: &[Record], selection: &wfic::ic::Selection) -> Work {
    TreeShape::of(&config(), inserted).removal_reach(selection)
}

/// A removal races a lookup of the record it removes. The lookup finds the record whole or not
/// at all, the removal takes it exactly once, and a lookup after both finds nothing. Returns
/// whether the racing lookup found it.
pub fn removal_races_lookup_of_the_same_record<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let r = root_record(0.0);
    insert_one(&*cache, 0, r);
    let c = cache.clone();
    let t = Go::race(move || remove_one(&*c, 1, &at_point(r.position)));
    let found = valid_at(&*cache, 2, r.position);
    assert!(found.len() <= 1, "a record found twice");
    let saw = found.first().is_some_and(|f| {
        assert!(
            f.is_intact() && f.position == r.position,
            "torn or phantom record"
        );
        true
    });
    assert_eq!(
        t.join().unwrap(),
        1,
        "the removal must take the record once"
    );
    assert!(
        valid_at(&*cache, 3, r.position).is_empty(),
        "a removed record was found after its removal"
    );
    saw
}

/// A removal races an insert into the same list (the root's). The record stored before the
/// threads started is always removed; the racing one is removed or stays, never half of either:
/// what stays is exactly what was not counted, and no removed record comes back (the writer's
/// store of "live" cannot follow a removal, which only takes live slots). Returns whether the
/// removal took the racing record too.
pub fn removal_races_an_insert_into_one_list<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let (old, new) = (root_record(-0.5), root_record(0.5));
    insert_one(&*cache, 0, old);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, new));
    let selection = at_point(Vec3::splat(2.0));
    let (removed, did) = remove_counted(&*cache, 2, &selection);
    t.join().unwrap();
    // One pass over the list: at most the two slots it ends with, however the insert grew it.
    check_removal(
        "one list",
        did,
        removal_bound(&[old, new], &selection),
        false,
    );
    assert!(removed == 1 || removed == 2, "removed {removed}");
    let left = valid_at(&*cache, 3, Vec3::splat(2.0));
    assert!(left.iter().all(|f| f.is_intact()), "torn record");
    assert!(
        left.iter().all(|f| f.position == new.position),
        "the record stored before the race survived its removal"
    );
    assert_eq!(
        left.len(),
        2 - removed,
        "stayed + removed must be both records"
    );
    removed == 2
}

/// A removal races an insert that grafts a new child below the node it is scanning. The record
/// in the root is always removed; the grafted one is removed if the removal met it, else it
/// stays. When the frame closes, reclamation frees the child exactly when its record was
/// removed (loom reports a leak or a double free otherwise). Returns whether the grafted record
/// was removed.
pub fn removal_races_a_graft_below_it<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let (top, below) = (root_record(0.0), child_record(0.0));
    insert_one(&*cache, 0, top);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, below));
    // The root record's influence covers the world; the child's reaches (1, 1, 1).
    let selection = at_point(below.position);
    let (removed, did) = remove_counted(&*cache, 2, &selection);
    t.join().unwrap();
    check_removal(
        "graft",
        did,
        removal_bound(&[top, below], &selection),
        false,
    );
    assert!(removed == 1 || removed == 2, "removed {removed}");
    let left = valid_at(&*cache, 3, below.position);
    assert!(left.iter().all(|f| f.is_intact()), "torn record");
    let stayed = left.iter().any(|f| f.position == below.position);
    assert!(
        left.iter().all(|f| f.position == below.position),
        "the root record survived its removal"
    );
    assert_eq!(
        stayed,
        removed == 1,
        "the grafted record both stayed and was counted"
    );
    let mut cache = Arc::try_unwrap(cache).expect("threads joined");
    let report = cache.end_frame();
    assert_eq!(report.workers.removed, removed as u64);
    // Reclaimed: the child goes with its record; a surviving record keeps its path.
    assert_eq!(
        cache.stats().nodes,
        if stayed { 2 } else { 1 },
        "after reclamation"
    );
    assert_eq!(cache.stats().records, usize::from(stayed));
    removed == 2
}

/// Two removals of overlapping sets race: one takes `a` only, the other `a` and `b`. Each
/// record is counted by exactly one of them (the compare-and-swap), so the counts add up to two.
/// Returns whether the first removal took `a`.
pub fn two_removals_of_overlapping_sets<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    // Depth-1 records 1.4 apart, each with influence 0.71: a point selects one, a box both.
    let (a, b) = (record_at_depth(1, 0.3), record_at_depth(1, 1.7));
    insert_one(&*cache, 0, a);
    insert_one(&*cache, 1, b);
    let both = wfic::ic::Selection::touching(a.position, b.position).unwrap();
    let c = cache.clone();
    let t = Go::race(move || remove_one(&*c, 2, &at_point(a.position)));
    let second = remove_one(&*cache, 3, &both);
    let first = t.join().unwrap();
    assert!(first <= 1, "the point selection took {first}");
    assert!(
        first + second <= 2,
        "a record was removed twice: {first} + {second}"
    );
    assert!(
        first + second >= 2,
        "a record was not removed: {first} + {second}"
    );
    for p in [a.position, b.position] {
        assert!(
            valid_at(&*cache, 4 + p.x as u32, p).is_empty(),
            "a removed record was found"
        );
    }
    first == 1
}

/// Happens-before: a removal completes, then its thread sets a flag with Release; a lookup that
/// loaded the flag with Acquire and saw it must not find the record (the guarantee: a lookup that
/// happens-after a removal never returns what it removed). The removal's compare-and-swap is
/// Relaxed: write-read coherence alone makes the lookup's load of the slot see it. Returns
/// whether the flag was seen.
pub fn a_removal_that_happens_before_a_lookup_is_seen<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let r = record_at_depth(2, 0.3);
    insert_one(&*cache, 0, r);
    let flag = Arc::new(AtomicBool::new(false));
    let (c, f) = (cache.clone(), flag.clone());
    let t = thread::spawn(move || {
        remove_one(&*c, 1, &at_point(r.position));
        // Release: the removal happens-before any Acquire load that reads this `true`.
        f.store(true, Ordering::Release);
    });
    // Acquire: pairs with the Release store above.
    let flagged = flag.load(Ordering::Acquire);
    let found = valid_at(&*cache, 2, r.position);
    if flagged {
        assert!(
            found.is_empty(),
            "a lookup that happens-after a removal found the record"
        );
    }
    t.join().unwrap();
    flagged
}

/// A removal in one depth-1 subtree races an insert that grafts into another. The removal visits
/// only the root and the nodes its selection may reach, never the far subtree, whether or not the
/// graft is published yet; once both are done, a second removal of the same selection, with
/// nothing running beside it, does exactly the work the tree's shape gives, and a removal of
/// everything visits every node and slot. Returns whether the first removal took its record (it
/// always must: the insert happened before the threads started).
pub fn a_removal_visits_only_what_its_selection_may_reach<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    // (-,-,-) and (+,+,+) depth-1 records: the loose cells ([-1, 3] and [1, 5] a side) both hold
    // (2, 2, 2), but a point at 0.6 (or 3.4) a side lies in only one.
    let near = Record::new(Vec3::splat(0.6), Vec3::Z, Vec3::new(1.0, 1.0, 2.0), 0.8);
    let far = Record::new(Vec3::splat(3.4), Vec3::Z, Vec3::new(2.0, 1.0, 1.0), 0.8);
    insert_one(&*cache, 0, near);
    let c = cache.clone();
    let t = Go::race(move || insert_one(&*c, 1, far));
    let selection = at_point(near.position);
    let (removed, did) = remove_counted(&*cache, 2, &selection);
    t.join().unwrap();
    let inserted = [near, far];
    let shape = TreeShape::of(&config(), &inserted);
    let allowed = shape.removal_reach(&selection);
    assert!(
        allowed.nodes < shape.nodes() as u64,
        "the model's selection reaches every node, so it cannot tell pruning apart"
    );
    check_removal("disjoint subtrees", did, allowed, false);
    let (again, quiet) = remove_counted(&*cache, 3, &selection);
    assert_eq!(again, 0, "a record removed twice");
    check_removal("disjoint subtrees, quiescent", quiet, allowed, true);
    let everything = wfic::ic::Selection::touching(Vec3::splat(-1.0), Vec3::splat(5.0)).unwrap();
    let (rest, all) = remove_counted(&*cache, 4, &everything);
    assert_eq!(rest, 1, "the far record must be left for the last removal");
    check_removal(
        "everything, quiescent",
        all,
        shape.removal_reach(&everything),
        true,
    );
    removed == 1
}

/// Guarantee 7 across threads: an insert that happens-before a removal (through a thread join,
/// the insert made on another thread) is taken by it, whether or not the node it went into has
/// been marked in its parent's mask yet by the thread publishing that node. The removal finds
/// children through the mask, as lookups do, so it relies on the inserter's own marking (helping):
/// without it (`Unhelped`) the record is missed. Returns whether the insert walked into the node
/// the other thread published (the case only helping covers).
pub fn an_insert_that_happens_before_a_removal_is_taken<O: Orderings>() -> bool {
    let cache = wf::<O>(CasFailure::Adopt);
    let (c1, c2) = (cache.clone(), cache.clone());
    let mine = record_at_depth(1, 1.0);
    let publisher = thread::spawn(move || insert_one(&*c1, 1, deep_a()));
    let inserter = thread::spawn(move || insert_one(&*c2, 2, record_at_depth(1, 1.0)));
    let (outcome, steps, lost) = inserter.join().unwrap();
    assert!(matches!(outcome, Inserted::Stored(_)));
    let removed = remove_one(&*cache, 0, &at_point(mine.position));
    publisher.join().unwrap();
    let left = valid_at(&*cache, 3, mine.position);
    assert!(
        removed >= 1 && left.iter().all(|r| r.position != mine.position),
        "a record whose insert happened-before the removal was missed (removed {removed})"
    );
    steps == 1 && lost == 0
}
