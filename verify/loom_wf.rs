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

use loom_common::model;
use loom_common::models::*;
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};
use wfic::cache::wf::{Minimal, ReadFence, SeqCstEverywhere};
use wfic::cache::CasFailure;

#[test]
fn two_inserts_into_one_list_minimal() {
    model(two_inserts_into_one_list::<Minimal>);
}

#[test]
fn two_inserts_race_to_create_one_child_adopt() {
    static LOST: AtomicUsize = AtomicUsize::new(0);
    static WON: AtomicUsize = AtomicUsize::new(0);
    model(|| {
        let counter = if two_inserts_race_to_create_one_child::<Minimal>(CasFailure::Adopt) {
            &LOST
        } else {
            &WON
        };
        counter.fetch_add(1, Relaxed);
    });
    assert!(
        WON.load(Relaxed) > 0,
        "no schedule where the second insert found the child"
    );
    assert!(
        LOST.load(Relaxed) > 0,
        "no explored schedule lost the race: the model is vacuous"
    );
}

#[test]
fn two_inserts_race_to_create_one_child_discard() {
    static LOST: AtomicUsize = AtomicUsize::new(0);
    static WON: AtomicUsize = AtomicUsize::new(0);
    model(|| {
        let counter = if two_inserts_race_to_create_one_child::<Minimal>(CasFailure::Discard) {
            &LOST
        } else {
            &WON
        };
        counter.fetch_add(1, Relaxed);
    });
    assert!(
        WON.load(Relaxed) > 0,
        "no schedule where the second insert found the child"
    );
    assert!(
        LOST.load(Relaxed) > 0,
        "no explored schedule discarded a sample"
    );
}

#[test]
fn insert_races_lookup_through_a_new_child_minimal() {
    static SAW: AtomicUsize = AtomicUsize::new(0);
    static MISSED: AtomicUsize = AtomicUsize::new(0);
    model(|| {
        let counter = if insert_races_lookup_through_a_new_child::<Minimal>() {
            &SAW
        } else {
            &MISSED
        };
        counter.fetch_add(1, Relaxed);
    });
    assert!(
        SAW.load(Relaxed) > 0 && MISSED.load(Relaxed) > 0,
        "both outcomes must be explored"
    );
}

#[test]
fn insert_races_lookup_in_one_list_minimal() {
    static SAW: AtomicUsize = AtomicUsize::new(0);
    static MISSED: AtomicUsize = AtomicUsize::new(0);
    model(|| {
        let counter = if insert_races_lookup_in_one_list::<Minimal>() {
            &SAW
        } else {
            &MISSED
        };
        counter.fetch_add(1, Relaxed);
    });
    assert!(
        SAW.load(Relaxed) > 0 && MISSED.load(Relaxed) > 0,
        "both outcomes must be explored"
    );
}

#[test]
fn a_later_slot_can_be_published_before_an_earlier_one_minimal() {
    static OUT_OF_ORDER: AtomicUsize = AtomicUsize::new(0);
    model(|| {
        if a_later_slot_can_be_published_before_an_earlier_one::<Minimal>() {
            OUT_OF_ORDER.fetch_add(1, Relaxed);
        }
    });
    assert!(
        OUT_OF_ORDER.load(Relaxed) > 0,
        "loom never produced slot k+1 published before slot k"
    );
}

#[test]
fn a_segment_grows_while_another_thread_inserts_and_a_third_reads_minimal() {
    model(a_segment_grows_while_another_thread_inserts_and_a_third_reads::<Minimal>);
}

#[test]
fn two_inserts_race_to_install_one_segment_minimal() {
    model(two_inserts_race_to_install_one_segment::<Minimal>);
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
}
