//! The ordering study, under loom: for every atomic site of the wait-free cache that is stronger
//! than `Relaxed` in the shipped `Minimal` policy, the policy `Weakened<SITE>` relaxes that one
//! site, and a model must catch it — by the causality (data-race) report the weakening opens, not
//! by any panic: each test asserts the kind of report loom 0.7 gives and the file that created the
//! racing object. The paper-literal list (Listing 6: no publication flag) is refuted the same way.
//! The table of which ordering each site needs is in `docs/verification.md`.
#![cfg(feature = "loom")]

mod loom_common;

use loom_common::models::*;
use loom_common::{expect_failure, model_outcomes};
use wfic::cache::CasFailure;
use wfic::research::orderings::{BlindRemove, PaperLiteral, Site, Unhelped, Weakened};

/// The kinds of causality report loom 0.7 gives (`loom/src/rt/cell.rs`, `rt/atomic.rs`) that our
/// weakenings produce. Each is the exact sentence loom prints, period included.
#[derive(Clone, Copy, Debug)]
enum Race {
    /// An `UnsafeCell` read not ordered after the cell's last write (`track_read`). Not to be
    /// confused with "Concurrent read and write accesses to `UnsafeCell`.", loom's report of a
    /// write not ordered after a read.
    ReadAfterUnorderedWrite,
    /// An atomic loaded (or read-modify-written, which loom tracks as a load first) by a thread
    /// the atomic's creation does not happen-before: loom records `Atomic::new` as an
    /// unsynchronised mutation ("mut").
    LoadOfUnorderedAtomic,
    /// An `UnsafeCell` written by a thread its last write does not happen-before (its creation,
    /// `UnsafeCell::new`, counts as a write).
    WriteAfterUnorderedWrite,
}

impl Race {
    fn sentence(self) -> &'static str {
        match self {
            Race::ReadAfterUnorderedWrite => {
                "Causality violation: Concurrent read and write accesses.\n"
            }
            Race::LoadOfUnorderedAtomic => {
                "Causality violation: Concurrent load and mut accesses.\n"
            }
            Race::WriteAfterUnorderedWrite => {
                "Causality violation: Concurrent write accesses to `UnsafeCell`.\n"
            }
        }
    }
}

/// Where the racing object was created: a record list (`list.rs`: a slot's record cell or ready
/// flag, a list's head) or a node (`mod.rs`: its child pointers).
#[derive(Clone, Copy, Debug)]
enum Made {
    InList,
    InNode,
}

/// Asserts that `message` is loom's report of the race `race` on an object created in `made`:
/// the race the weakening opens, not a model assertion, another kind of report or another object.
fn assert_race(what: &str, message: &str, race: Race, made: Made) {
    eprintln!("{what}: {}", message.trim().replace('\n', "\n    "));
    assert!(
        message.contains(race.sentence()),
        "{what}: expected loom's report {:?}, got: {message}",
        race.sentence().trim()
    );
    let created = match made {
        Made::InList => "created: src/cache/wf/list.rs:",
        Made::InNode => "created: src/cache/wf/mod.rs:",
    };
    assert!(
        message.contains(created),
        "{what}: expected the racing object to be created in {made:?} ({created}), got: {message}"
    );
}

#[test]
fn paper_literal_list_reads_a_reserved_but_unwritten_slot() {
    let message = expect_failure(|| {
        insert_races_lookup_in_one_list::<PaperLiteral>();
    });
    // The reader reads a reserved slot's record cell while its writer writes it.
    assert_race(
        "paper-literal",
        &message,
        Race::ReadAfterUnorderedWrite,
        Made::InList,
    );
}

/// Without helping, a record stored below a child its publisher has not yet marked is missed by a
/// lookup that happens-after its insert: the model's own assertion, not a causality report (no
/// memory is read unordered; the lookup just never loads the child).
#[test]
fn an_unhelped_insert_below_an_unmarked_child_is_missed() {
    let message = expect_failure(|| {
        an_insert_below_a_child_not_yet_marked_is_found::<Unhelped>();
    });
    eprintln!("unhelped: {}", message.trim());
    assert!(
        message.contains("a record whose insert happened-before the lookup was missed"),
        "expected the model's assertion, got: {message}"
    );
}

/// Without helping, a removal that happens-after an insert (on another thread) misses the record
/// stored below a child its publisher has not yet marked: the model's own assertion.
#[test]
fn an_unhelped_insert_below_an_unmarked_child_escapes_a_removal() {
    let message = expect_failure(|| {
        an_insert_that_happens_before_a_removal_is_taken::<Unhelped>();
    });
    eprintln!("unhelped (removal): {}", message.trim());
    assert!(
        message.contains("a record whose insert happened-before the removal was missed"),
        "expected the model's assertion, got: {message}"
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
const MASK_SET: usize = Site::MaskSet as usize;
const MASK_READ: usize = Site::MaskRead as usize;

/// Asserts that `message` is the cache's own check in `Node::follow` (mod.rs), which a weakened
/// mask site trips: the lookup saw a bit, and its Relaxed load of the child's pointer, no longer
/// ordered after the compare-and-swap that published it, returned the null the node was built
/// with. The check runs under the model checkers (and in debug builds); the shipped release build
/// rests on the argument the study proves.
fn assert_mask_race(what: &str, message: &str) {
    eprintln!("{what}: {}", message.trim());
    assert!(
        message.contains("a lookup saw a mask bit without its published child"),
        "{what}: expected the mask check in Node::follow, got: {message}"
    );
}

// SlotPublish and SlotRead: the reader reads a slot's record cell (list.rs) that it saw ready, but
// the write of the record is not ordered before the read.

#[test]
fn relaxed_slot_publish_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SLOT_PUBLISH>>();
    });
    assert_race(
        "SlotPublish",
        &m,
        Race::ReadAfterUnorderedWrite,
        Made::InList,
    );
}

#[test]
fn relaxed_slot_read_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SLOT_READ>>();
    });
    assert_race("SlotRead", &m, Race::ReadAfterUnorderedWrite, Made::InList);
}

/// The deep happens-before model catches both slot sites too, in its executions where the lookup
/// did not see the flag and raced the append into the existing depth-2 node.
#[test]
fn relaxed_slot_sites_are_caught_below_depth_1() {
    let m = expect_failure(|| {
        an_insert_that_happens_before_a_lookup_is_found::<Weakened<SLOT_PUBLISH>>(true);
    });
    assert_race(
        "SlotPublish, depth 2",
        &m,
        Race::ReadAfterUnorderedWrite,
        Made::InList,
    );
    let m = expect_failure(|| {
        an_insert_that_happens_before_a_lookup_is_found::<Weakened<SLOT_READ>>(true);
    });
    assert_race(
        "SlotRead, depth 2",
        &m,
        Race::ReadAfterUnorderedWrite,
        Made::InList,
    );
}

// SegmentRead and SegmentPublish: the reader loads the ready flag of a slot in a segment whose
// creation (the flag's `AtomicBool::new`, list.rs) it is not ordered after.

#[test]
fn relaxed_segment_read_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SEGMENT_READ>>();
    });
    assert_race("SegmentRead", &m, Race::LoadOfUnorderedAtomic, Made::InList);
}

#[test]
fn relaxed_segment_publish_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_in_one_list::<Weakened<SEGMENT_PUBLISH>>();
    });
    assert_race(
        "SegmentPublish",
        &m,
        Race::LoadOfUnorderedAtomic,
        Made::InList,
    );
}

/// SegmentCasFailure, at its two uses. (1) A list that first outgrows its first segment installs
/// its directory of later segments the way it installs a segment; the loser of that race loads an
/// entry of the winner's directory, whose creation (`AtomicPtr::new`, list.rs) it is not ordered
/// after. (2) With the directory already there, the loser of the race for a segment writes a
/// record into a slot of the winner's segment, whose creation (the cell's `UnsafeCell::new`,
/// list.rs) it is not ordered after.
#[test]
fn relaxed_segment_cas_failure_is_caught() {
    let m =
        expect_failure(two_inserts_race_to_install_one_segment::<Weakened<SEGMENT_CAS_FAILURE>>);
    assert_race(
        "SegmentCasFailure (directory)",
        &m,
        Race::LoadOfUnorderedAtomic,
        Made::InList,
    );
    let m = expect_failure(
        two_inserts_race_to_install_a_later_segment::<Weakened<SEGMENT_CAS_FAILURE>>,
    );
    assert_race(
        "SegmentCasFailure (segment)",
        &m,
        Race::WriteAfterUnorderedWrite,
        Made::InList,
    );
}

// ChildRead and ChildPublish order an *insert* after the construction of a child another insert
// published: a lookup no longer needs them, since it follows a child only under its mask bit,
// whose Release/Acquire pair orders it (MaskSet and MaskRead below). An insert that walks into a
// published node loads its list's head (list.rs) to push, whose creation it is not ordered after.

#[test]
fn relaxed_child_read_is_caught() {
    let m = expect_failure(|| {
        an_insert_below_a_child_not_yet_marked_is_found::<Weakened<CHILD_READ>>();
    });
    assert_race("ChildRead", &m, Race::LoadOfUnorderedAtomic, Made::InList);
}

#[test]
fn relaxed_child_publish_is_caught() {
    let m = expect_failure(|| {
        an_insert_below_a_child_not_yet_marked_is_found::<Weakened<CHILD_PUBLISH>>();
    });
    assert_race(
        "ChildPublish",
        &m,
        Race::LoadOfUnorderedAtomic,
        Made::InList,
    );
}

/// Below depth 1, the deep child race: the loser walking down the winner's depth-1 node loads one
/// of its child pointers (`AtomicPtr::new` in `Node::new`, mod.rs).
#[test]
fn relaxed_child_sites_are_caught_below_depth_1() {
    let m = expect_failure(|| {
        two_deep_inserts_race_for_a_shared_child::<Weakened<CHILD_READ>>(CasFailure::Adopt);
    });
    assert_race(
        "ChildRead, deep race",
        &m,
        Race::LoadOfUnorderedAtomic,
        Made::InNode,
    );
    let m = expect_failure(|| {
        two_deep_inserts_race_for_a_shared_child::<Weakened<CHILD_PUBLISH>>(CasFailure::Adopt);
    });
    assert_race(
        "ChildPublish, deep race",
        &m,
        Race::LoadOfUnorderedAtomic,
        Made::InNode,
    );
}

/// A lookup is ordered after a child's construction by the mask alone: with either child site
/// weakened, the lookup models pass, both outcomes of the race reached (the record found, and the
/// lookup that ran first finding nothing).
#[test]
fn lookups_need_neither_child_site() {
    for (what, outcomes) in [
        (
            "ChildRead",
            model_outcomes(insert_races_lookup_through_a_new_child::<Weakened<CHILD_READ>>),
        ),
        (
            "ChildPublish",
            model_outcomes(insert_races_lookup_through_a_new_child::<Weakened<CHILD_PUBLISH>>),
        ),
        (
            "ChildRead, deep chain",
            model_outcomes(lookup_races_a_deep_chain::<Weakened<CHILD_READ>>),
        ),
        (
            "ChildPublish, deep chain",
            model_outcomes(lookup_races_a_deep_chain::<Weakened<CHILD_PUBLISH>>),
        ),
    ] {
        let (found, missed) = outcomes;
        assert!(
            found > 0 && missed > 0,
            "{what}: both outcomes of the race must be explored"
        );
    }
}

// MaskSet and MaskRead: a lookup that sees a child's bit follows the child's pointer with a
// Relaxed load and no null check (`Node::follow`). Weakened, the bit arrives without the
// publication it was set after.

#[test]
fn relaxed_mask_set_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_through_a_new_child::<Weakened<MASK_SET>>();
    });
    assert_mask_race("MaskSet", &m);
}

#[test]
fn relaxed_mask_read_is_caught() {
    let m = expect_failure(|| {
        insert_races_lookup_through_a_new_child::<Weakened<MASK_READ>>();
    });
    assert_mask_race("MaskRead", &m);
}

/// Below depth 1: the lookup racing a three-node chain.
#[test]
fn relaxed_mask_sites_are_caught_below_depth_1() {
    let m = expect_failure(|| {
        lookup_races_a_deep_chain::<Weakened<MASK_SET>>();
    });
    assert_mask_race("MaskSet, deep chain", &m);
    let m = expect_failure(|| {
        lookup_races_a_deep_chain::<Weakened<MASK_READ>>();
    });
    assert_mask_race("MaskRead, deep chain", &m);
}

/// ChildCasFailure with `Adopt`: the loser goes on into the winner's child, which its failed
/// compare-and-swap no longer orders it after. At depth 1 it loads the head of that node's list
/// to push (list.rs).
#[test]
fn relaxed_child_cas_failure_is_caught_with_adopt() {
    let m = expect_failure(|| {
        two_inserts_race_to_create_one_child::<Weakened<CHILD_CAS_FAILURE>>(CasFailure::Adopt);
    });
    assert_race(
        "ChildCasFailure",
        &m,
        Race::LoadOfUnorderedAtomic,
        Made::InList,
    );
}

/// Below depth 1 the adopting loser walks through the winner's depth-1 node instead, and the
/// first thing it loads there is a child pointer (mod.rs).
#[test]
fn relaxed_child_cas_failure_is_caught_below_depth_1_with_adopt() {
    let m = expect_failure(|| {
        two_deep_inserts_race_for_a_shared_child::<Weakened<CHILD_CAS_FAILURE>>(CasFailure::Adopt);
    });
    assert_race(
        "ChildCasFailure, deep race",
        &m,
        Race::LoadOfUnorderedAtomic,
        Made::InNode,
    );
}

/// With `Discard` the ChildCasFailure site could be Relaxed: the loser never touches the winner's
/// node. Both child races pass with it weakened, lost races included.
#[test]
fn relaxed_child_cas_failure_is_harmless_with_discard() {
    type W = Weakened<CHILD_CAS_FAILURE>;
    let (lost, won) =
        model_outcomes(|| two_inserts_race_to_create_one_child::<W>(CasFailure::Discard));
    assert!(
        lost > 0 && won > 0,
        "both outcomes of the race must be explored"
    );
    let (lost, won) =
        model_outcomes(|| two_deep_inserts_race_for_a_shared_child::<W>(CasFailure::Discard));
    assert!(
        lost > 0 && won > 0,
        "both outcomes of the race must be explored"
    );
}

/// Removal without its compare-and-swap (`BlindRemove`: the slot's state loaded, then "removed"
/// stored): two overlapping removals can both see the shared record live and both count it. The
/// model's own assertion ("removed twice", not "not removed"), not a causality report: nothing is
/// read unordered, the count is wrong.
#[test]
fn a_blind_removal_counts_a_record_twice() {
    let message = expect_failure(|| {
        two_removals_of_overlapping_sets::<BlindRemove>();
    });
    eprintln!("blind removal: {}", message.trim());
    assert!(
        message.contains("a record was removed twice: "),
        "expected the model's assertion, got: {message}"
    );
}

/// A removal reads the record of every live slot it meets to test its selection, under the
/// scan's Acquire load of the state (SlotRead): relaxed, that read races the writer's. Caught by
/// the removal that races an insert into its list, by loom's report on the record's cell.
#[test]
fn relaxed_slot_read_is_caught_by_a_removal() {
    let m = expect_failure(|| {
        removal_races_an_insert_into_one_list::<Weakened<SLOT_READ>>();
    });
    assert_race(
        "SlotRead (removal)",
        &m,
        Race::ReadAfterUnorderedWrite,
        Made::InList,
    );
}
