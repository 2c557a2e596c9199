//! Loom models of the wait-free cache (`cargo test --features loom`): the shipped policy passes.
//!
//! Each model runs the shipped code (the caches take their atomics and cells from `wfic::sync`,
//! which is loom's under this feature) and is exhaustive for every interleaving, with
//! no preemption bound at all (`loom_common::PREEMPTION_BOUND` is `None`), within loom's own limits: it treats
//! `SeqCst` accesses as `AcqRel`, explores no load buffering, keeps the last 7 stores of an atomic,
//! runs at most 5 threads, and its DPOR remembers only the last access per atomic (see
//! `loom_common::Go`). Record lists are shrunk to segments of 2, 4 and 8 slots under loom, so a
//! segment boundary is met within three inserts.
//!
//! The models are generic over the ordering policy (`loom_common/models.rs`); the same bodies
//! refute each weakened ordering and the paper-literal list in `verify/loom_orderings.rs`.
#![cfg(feature = "loom")]

mod loom_common;

use loom_common::models::*;
use loom_common::{model, model_outcomes};
use wfic::cache::wf::Minimal;
use wfic::cache::CasFailure;
use wfic::research::orderings::{ReadFence, SeqCstEverywhere};

#[test]
fn two_inserts_into_one_list_minimal() {
    model(two_inserts_into_one_list::<Minimal>);
}

#[test]
fn two_inserts_race_to_create_one_child_adopt() {
    let (yes, no) =
        model_outcomes(|| two_inserts_race_to_create_one_child::<Minimal>(CasFailure::Adopt));
    assert!(yes > 0, "no explored schedule lost the race");
    assert!(
        no > 0,
        "no schedule where the second insert found the child"
    );
}

#[test]
fn two_inserts_race_to_create_one_child_discard() {
    let (yes, no) =
        model_outcomes(|| two_inserts_race_to_create_one_child::<Minimal>(CasFailure::Discard));
    assert!(yes > 0, "no explored schedule discarded a sample");
    assert!(
        no > 0,
        "no schedule where the second insert found the child"
    );
}

#[test]
fn insert_races_lookup_through_a_new_child_minimal() {
    let (yes, no) = model_outcomes(insert_races_lookup_through_a_new_child::<Minimal>);
    assert!(yes > 0, "the lookup never saw the record");
    assert!(no > 0, "the lookup always saw the record");
}

#[test]
fn insert_races_lookup_in_one_list_minimal() {
    let (yes, no) = model_outcomes(insert_races_lookup_in_one_list::<Minimal>);
    assert!(yes > 0, "the lookup never saw the record");
    assert!(no > 0, "the lookup always saw the record");
}

#[test]
fn a_later_slot_can_be_published_before_an_earlier_one_minimal() {
    let (yes, no) = model_outcomes(a_later_slot_can_be_published_before_an_earlier_one::<Minimal>);
    assert!(
        yes > 0,
        "loom never produced slot k+1 published before slot k"
    );
    assert!(no > 0, "every schedule published out of order");
}

#[test]
fn a_segment_grows_while_another_thread_inserts_and_a_third_reads_minimal() {
    model(a_segment_grows_while_another_thread_inserts_and_a_third_reads::<Minimal>);
}

#[test]
fn a_sealed_list_grows_while_another_thread_reads_minimal() {
    model(a_sealed_list_grows_while_another_thread_reads::<Minimal>);
}

/// Both outcomes are reached: the reader sees the graft below the slab, or not.
#[test]
fn a_relocated_tree_grows_while_another_thread_reads_minimal() {
    let (yes, no) = model_outcomes(a_relocated_tree_grows_while_another_thread_reads::<Minimal>);
    assert!(yes > 0, "the reader never saw the graft below the slab");
    assert!(no > 0, "the reader always saw the graft below the slab");
}

#[test]
fn two_inserts_race_to_install_one_segment_minimal() {
    model(two_inserts_race_to_install_one_segment::<Minimal>);
}

#[test]
fn two_inserts_race_to_install_a_later_segment_minimal() {
    model(two_inserts_race_to_install_a_later_segment::<Minimal>);
}

/// The occupancy mask: an insert that walks into a child its publisher has not yet marked marks
/// it, and the lookup that follows the insert finds the record. Both cases are reached: the
/// insert walking into the other's child, and not.
#[test]
fn an_insert_below_a_child_not_yet_marked_is_found_minimal() {
    let (yes, no) = model_outcomes(an_insert_below_a_child_not_yet_marked_is_found::<Minimal>);
    assert!(
        yes > 0 && no > 0,
        "walked into the other's child: {yes}, not: {no}"
    );
}

#[test]
fn two_deep_inserts_race_for_a_shared_child_adopt() {
    let (lost, won) =
        model_outcomes(|| two_deep_inserts_race_for_a_shared_child::<Minimal>(CasFailure::Adopt));
    assert!(
        lost > 0,
        "no schedule took lose, adopt the winner's child, graft deeper"
    );
    assert!(
        won > 0,
        "no schedule where the second insert found the child"
    );
}

#[test]
fn two_deep_inserts_race_for_a_shared_child_discard() {
    let (lost, won) =
        model_outcomes(|| two_deep_inserts_race_for_a_shared_child::<Minimal>(CasFailure::Discard));
    assert!(lost > 0, "no explored schedule discarded a sample");
    assert!(
        won > 0,
        "no schedule where the second insert found the child"
    );
}

#[test]
fn lookup_races_a_deep_chain_minimal() {
    let (yes, no) = model_outcomes(lookup_races_a_deep_chain::<Minimal>);
    assert!(yes > 0, "the lookup never saw the record");
    assert!(no > 0, "the lookup always saw the record");
}

#[test]
fn an_insert_that_happens_before_a_lookup_is_found_new_chain() {
    let (flagged, not) =
        model_outcomes(|| an_insert_that_happens_before_a_lookup_is_found::<Minimal>(false));
    assert!(flagged > 0, "the lookup never saw the flag");
    assert!(not > 0, "the lookup always saw the flag");
}

#[test]
fn an_insert_that_happens_before_a_lookup_is_found_existing_node() {
    let (flagged, not) =
        model_outcomes(|| an_insert_that_happens_before_a_lookup_is_found::<Minimal>(true));
    assert!(flagged > 0, "the lookup never saw the flag");
    assert!(not > 0, "the lookup always saw the flag");
}

/// The stronger policies are sound too (loom treats SeqCst as AcqRel: this shows they are at
/// least as strong as Minimal where loom can tell).
#[test]
fn stronger_policies_pass_the_same_models() {
    model(|| {
        insert_races_lookup_through_a_new_child::<SeqCstEverywhere>();
    });
    model(|| {
        insert_races_lookup_in_one_list::<ReadFence>();
    });
    model(|| {
        two_inserts_race_to_create_one_child::<SeqCstEverywhere>(CasFailure::Adopt);
    });
    model(two_inserts_race_to_install_one_segment::<SeqCstEverywhere>);
    model(|| {
        two_deep_inserts_race_for_a_shared_child::<SeqCstEverywhere>(CasFailure::Adopt);
    });
    model(|| {
        lookup_races_a_deep_chain::<ReadFence>();
    });
}

/// Under loom a list holds 2 + 4 + 8 = 14 slots; the fifteenth insert into one node is refused
/// with `ListFull`, an error, not an index past the last segment.
#[test]
fn a_full_list_refuses_the_next_insert() {
    use wfic::cache::{CacheHandle, Inserted, IrradianceCache, WaitFree};
    use wfic::ic::{InsertError, WorkerId};
    model(|| {
        let cache = WaitFree::<Minimal>::new(loom_common::config(), CasFailure::Adopt);
        let mut h = cache.handle(WorkerId::new(0));
        for i in 0..14 {
            let stored = h.insert(loom_common::root_record(i as f32 * 0.01));
            assert!(matches!(stored, Ok(Inserted::Stored(_))), "{stored:?}");
        }
        let refused = h.insert(loom_common::root_record(0.5));
        assert_eq!(refused, Err(InsertError::ListFull));
        // The refused insert still reserved an index, so the list's head now counts one slot more
        // than its segments hold: a scan must stop at the last segment (not index the directory
        // past it) and still find all fourteen records.
        let found = h.lookup(glam::Vec3::new(2.0, 2.0, 2.0), glam::Vec3::Z);
        assert_eq!(found.map(|f| f.records), Some(14), "{found:?}");
        drop(h);
        // The slots that exist, not the reservations: 14, though the head counts 15. A removal
        // and its reclamation leave none.
        let mut cache = cache;
        assert_eq!(cache.reserved_slots(), 14);
        let p = loom_common::root_record(0.0).position;
        let all = wfic::ic::Selection::touching(p, p).unwrap();
        // Every root record's influence covers the world: a point selection takes all 14.
        assert_eq!(cache.remove(&all), 14);
        assert_eq!((cache.reserved_slots(), cache.stats().records), (0, 0));
    });
}

/// Removal racing a lookup of the record it removes: the lookup sees it whole or not at all.
#[test]
fn removal_races_lookup_of_the_same_record_minimal() {
    let (saw, not) = model_outcomes(removal_races_lookup_of_the_same_record::<Minimal>);
    assert!(
        saw > 0,
        "the lookup never saw the record before its removal"
    );
    assert!(not > 0, "the lookup always saw the record");
}

/// Removal racing an insert into the same list: the racing record is taken or stays, never both.
#[test]
fn removal_races_an_insert_into_one_list_minimal() {
    let (took, left) = model_outcomes(removal_races_an_insert_into_one_list::<Minimal>);
    assert!(took > 0, "the removal never met the racing record");
    assert!(left > 0, "the removal always met the racing record");
}

/// Removal racing the graft of a subtree below it, then reclamation at the frame's close.
#[test]
fn removal_races_a_graft_below_it_minimal() {
    let (took, left) = model_outcomes(removal_races_a_graft_below_it::<Minimal>);
    assert!(took > 0, "the removal never met the grafted record");
    assert!(left > 0, "the removal always met the grafted record");
}

/// Two removals of overlapping sets: every record counted once, by either of them.
#[test]
fn two_removals_of_overlapping_sets_minimal() {
    let (first, second) = model_outcomes(two_removals_of_overlapping_sets::<Minimal>);
    assert!(first > 0, "the point removal never took the shared record");
    assert!(second > 0, "the box removal never took the shared record");
}

/// A removal that happens-before a lookup is seen by it, with the Relaxed compare-and-swap.
#[test]
fn a_removal_that_happens_before_a_lookup_is_seen_minimal() {
    let (flagged, not) = model_outcomes(a_removal_that_happens_before_a_lookup_is_seen::<Minimal>);
    assert!(flagged > 0, "the lookup never saw the flag");
    assert!(not > 0, "the lookup always saw the flag");
}

/// SlotRemove is Relaxed in the shipped policy and cannot be weakened further; the removal models
/// above pass with it, and with the stronger policies too.
#[test]
fn the_removal_models_pass_with_seqcst_everywhere() {
    model(|| {
        two_removals_of_overlapping_sets::<SeqCstEverywhere>();
    });
    model(|| {
        removal_races_a_graft_below_it::<SeqCstEverywhere>();
    });
}

/// A removal visits only what its selection may reach, while a graft races in another subtree,
/// and exactly that when nothing runs beside it.
#[test]
fn a_removal_visits_only_what_its_selection_may_reach_minimal() {
    let (took, missed) =
        model_outcomes(a_removal_visits_only_what_its_selection_may_reach::<Minimal>);
    assert!(took > 0 && missed == 0, "the removal missed its record");
}

/// Guarantee 7 with the insert on another thread: taken, including when only the inserter's own
/// marking of the node makes the record reachable.
#[test]
fn an_insert_that_happens_before_a_removal_is_taken_minimal() {
    let (helped, not) = model_outcomes(an_insert_that_happens_before_a_removal_is_taken::<Minimal>);
    assert!(
        helped > 0,
        "the insert never walked into the node the other thread published"
    );
    assert!(not > 0, "the insert always walked into the published node");
}
