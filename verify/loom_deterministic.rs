//! Loom models of deterministic frames (`wfic::cache::deterministic`; `cargo test --features
//! loom`), on the shipped WF cache with no preemption bound (`loom_common::PREEMPTION_BOUND`):
//!
//! * the visibility rule: under every interleaving, a tile's lookup uses the records of earlier
//!   frames and never another tile's record of this frame, also in the executions where that
//!   record is already in the octree when the lookup walks it (both outcomes of the race are
//!   reached); with a rule that admits everything, the same model fails with its own message;
//! * the canonical sum: two tiles insert two records each into one list, so the list's order
//!   differs between executions; the id-ordered lookup returns the same bits in every execution,
//!   while the plain lookup returns two different values over the executions.
#![cfg(feature = "loom")]

mod loom_common;

use glam::Vec3;
use loom_common::{config, expect_failure, model_outcomes, root_record, Go};
use wfic::cache::{CacheHandle, IrradianceCache, Visibility, WaitFree};
use wfic::ic::{Record, WorkerId};
use wfic::sync::Arc;

/// Where the lookups of these models ask: inside the root records' reach.
const QUERY: Vec3 = Vec3::new(2.0, 2.0, 2.0);

/// One frame's lookup at [`QUERY`] by tile 0 races with tile 1's insert of a record valid there;
/// a record of the previous frame is valid there too. `rule(frame)` is the rule tile 0's lookup
/// follows. Asserts the lookup used exactly the earlier frame's record; returns whether tile 1's
/// record was already in the octree (a walk just before the lookup found it).
fn a_tile_never_uses_another_tiles_record_of_this_frame(rule: fn(u64) -> Visibility) -> bool {
    let mut cache = WaitFree::adopt(config());
    let earlier = root_record(0.0);
    let mut h = cache.handle(WorkerId::new(0));
    h.insert(earlier).expect("the model's record");
    drop(h);
    cache.end_frame();
    let cache = Arc::new(cache);
    let c = cache.clone();
    let other = Go::race(move || {
        let mut h = c.handle(WorkerId::new(1));
        h.insert(root_record(0.25)).expect("the model's record");
    });
    let mut me = cache.handle(WorkerId::new(0));
    let mut present = Vec::new();
    me.valid_records(QUERY, Vec3::Z, &mut present);
    let raced = present.len() == 2;
    let found = me
        .lookup_visible(QUERY, Vec3::Z, rule(me.frame()))
        .expect("the earlier frame's record is valid");
    assert!(
        found.records == 1 && found.irradiance == earlier.irradiance,
        "another tile's record of this frame was used: {} records, {}",
        found.records,
        found.irradiance
    );
    drop(me);
    other.join().unwrap();
    raced
}

#[test]
fn a_tile_never_uses_another_tiles_record_of_this_frame_minimal() {
    let (raced, not) = model_outcomes(|| {
        a_tile_never_uses_another_tiles_record_of_this_frame(|f| {
            Visibility::new(f, WorkerId::new(0))
        })
    });
    assert!(
        raced > 0,
        "the other tile's record was never in the octree in time"
    );
    assert!(
        not > 0,
        "the other tile's record was always in the octree in time"
    );
}

/// The negative control: a rule that takes this frame for another admits every record, and the
/// model fails with its own assertion.
#[test]
fn a_rule_that_admits_this_frame_fails_the_model() {
    let message = expect_failure(|| {
        a_tile_never_uses_another_tiles_record_of_this_frame(|f| {
            Visibility::new(f + 1, WorkerId::new(0))
        });
    });
    assert!(
        message.contains("another tile's record of this frame was used: 2 records"),
        "{message}"
    );
}

/// Four records at one point whose sum at [`QUERY`] rounds by order (the unit test
/// `a_visible_lookup_sums_in_id_order_whatever_the_insertion_order` explains the values; each
/// weighs 2 there): tile 0 inserts 2^-53 then 1, tile 1 inserts 2^-53 then 2^-24, racing. A list
/// that holds both tiny records before the 1 sums them to one ulp of 2 that stays (0.25 + 2^-25);
/// any other order loses them to ties (0.25).
fn rounding_records() -> [Record; 4] {
    [2f32.powi(-53), 2f32.powi(-53), 1.0, 2f32.powi(-24)]
        .map(|e| Record::new(Vec3::new(1.0, 2.0, 2.0), Vec3::Z, Vec3::splat(e), 2.0))
}

/// Returns whether the plain lookup's sum differed from the id-ordered one, after asserting the
/// id-ordered one is 0.25 (its records in id order: tile 0's 2^-53 and 1, then tile 1's 2^-53
/// and 2^-24: the first tiny one meets the 1 alone and is lost to a tie).
fn the_ordered_sum_is_the_same_whatever_order_the_list_holds() -> bool {
    let cache = Arc::new(WaitFree::adopt(config()));
    let r = rounding_records();
    let c = cache.clone();
    let other = Go::race(move || {
        let mut h = c.handle(WorkerId::new(1));
        h.insert(r[1]).expect("the model's record");
        h.insert(r[3]).expect("the model's record");
    });
    {
        let mut h = cache.handle(WorkerId::new(0));
        h.insert(r[0]).expect("the model's record");
        h.insert(r[2]).expect("the model's record");
    }
    other.join().unwrap();
    let mut h = cache.handle(WorkerId::new(2));
    // Every record of this frame visible: the rule of the next frame's tiles.
    let everything = Visibility::new(h.frame() + 1, WorkerId::new(2));
    let ordered = h.lookup_visible(QUERY, Vec3::Z, everything).unwrap();
    let plain = h.lookup(QUERY, Vec3::Z).unwrap();
    assert_eq!(ordered.records, 4);
    assert_eq!(
        ordered.irradiance.x.to_bits(),
        0.25f32.to_bits(),
        "the id-ordered sum depends on the list's order"
    );
    plain.irradiance.x.to_bits() != ordered.irradiance.x.to_bits()
}

#[test]
fn the_ordered_sum_is_the_same_whatever_order_the_list_holds_minimal() {
    let (differ, same) = model_outcomes(the_ordered_sum_is_the_same_whatever_order_the_list_holds);
    assert!(
        differ > 0,
        "no execution held the list in an order whose plain sum rounds up"
    );
    assert!(same > 0, "no execution held the list in id order");
}
