//! The ordering study, under loom: for every atomic site of the wait-free cache that is stronger
//! than `Relaxed` in the shipped `Minimal` policy, the policy `Weakened<SITE>` relaxes that one
//! site, and a model must catch it — by loom's causality (data-race) report, not by any panic.
//! The paper-literal list (Listing 6: no publication flag) is refuted the same way. See the table
//! in `paper-notes.md`.
#![cfg(feature = "loom")]

mod loom_common;

use loom_common::expect_failure;
use loom_common::models::*;
use wfic::cache::wf::orderings::{PaperLiteral, Site, Weakened};
use wfic::cache::CasFailure;

/// Asserts that `message` is one of loom's causality reports: the race the weakening opens, not a
/// model assertion or anything else.
fn assert_race(what: &str, message: &str) {
    eprintln!("{what}: {}", message.lines().next().unwrap_or(""));
    assert!(
        message.contains("Causality violation"),
        "{what}: expected loom's causality violation, got: {message}"
    );
}

#[test]
fn paper_literal_list_reads_a_reserved_but_unwritten_slot() {
    let message = expect_failure(|| {
        insert_races_lookup_in_one_list::<PaperLiteral>();
    });
    assert_race("paper-literal", &message);
    assert!(
        message.contains("read and write"),
        "the race must be a read of the slot against its write: {message}"
    );
}

const SLOT_PUBLISH: usize = Site::SlotPublish as usize;
const SLOT_READ: usize = Site::SlotRead as usize;
const SEGMENT_READ: usize = Site::SegmentRead as usize;
const SEGMENT_PUBLISH: usize = Site::SegmentPublish as usize;
const SEGMENT_CAS_FAILURE: usize = Site::SegmentCasFailure as usize;
const CHILD_READ: usize = Site::ChildRead as usize;
const CHILD_PUBLISH: usize = Site::ChildPublish as usize;
const CHILD_CAS_FAILURE: usize = Site::ChildCasFailure as usize;

#[test]
fn relaxed_slot_publish_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SLOT_PUBLISH>>();
    });
    assert_race("SlotPublish", &m);
}

#[test]
fn relaxed_slot_read_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SLOT_READ>>();
    });
    assert_race("SlotRead", &m);
}

#[test]
fn relaxed_segment_read_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SEGMENT_READ>>();
    });
    assert_race("SegmentRead", &m);
}

#[test]
fn relaxed_segment_publish_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SEGMENT_PUBLISH>>();
    });
    assert_race("SegmentPublish", &m);
}

#[test]
fn relaxed_segment_cas_failure_is_caught() {
    let m =
        expect_failure(two_inserts_race_to_install_one_segment::<Weakened<SEGMENT_CAS_FAILURE>>);
    assert_race("SegmentCasFailure", &m);
}

#[test]
fn relaxed_child_read_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_through_a_new_child::<Weakened<CHILD_READ>>();
    });
    assert_race("ChildRead", &m);
}

#[test]
fn relaxed_child_publish_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_through_a_new_child::<Weakened<CHILD_PUBLISH>>();
    });
    assert_race("ChildPublish", &m);
}

#[test]
fn relaxed_child_cas_failure_is_caught_with_adopt() {
    let m = expect_failure(|| {
        two_inserts_race_to_create_one_child::<Weakened<CHILD_CAS_FAILURE>>(CasFailure::Adopt);
    });
    assert_race("ChildCasFailure", &m);
}
