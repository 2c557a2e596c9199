//! Leak detection under loom (`cargo test --features loom`).
//!
//! WF owns its nodes and list segments through raw pointers (`Box::into_raw`), which loom does not
//! see. Each node and each slot of a segment therefore carries a `wfic::sync::Tracked`, which under
//! loom is a `loom::alloc::Track`: at the end of every execution loom fails the model with
//! `Allocation leaked.` if a tracked object was never dropped. So every loom model of WF (these and
//! those in `verify/loom_wf.rs`, `verify/loom_orderings.rs`) also checks that no schedule leaks a
//! node or a segment — in particular that the loser of a child compare-and-swap frees its private
//! subtree (`graft`) and the loser of a segment compare-and-swap frees its fresh segment
//! (`install`).
//!
//! The tests here pin that machinery: leaking on purpose must produce loom's report, by its text,
//! and (with loom's location capture on) must name the line that allocated the leaked object. If
//! loom's leak detection stopped working, or a node or a slot lost its tracker, they fail.
#![cfg(feature = "loom")]

mod loom_common;

use loom_common::{child_record, config, expect_failure, insert_one, model, sealed};
use std::mem;
use wfic::cache::wf::{Minimal, RecordList};
use wfic::cache::{CasFailure, IrradianceCache, WaitFree};
use wfic::sync::Tracked;

/// The first line of loom's leak report, as loom 0.7 prints it (`loom::rt::alloc`).
const LEAK_REPORT: &str = "Allocation leaked.";

/// Asserts that `message` is loom's leak report and, if `allocated_in` is given, that it names an
/// allocation site in that file.
fn assert_leak(what: &str, message: &str, allocated_in: Option<&str>) {
    eprintln!("{what}: {}", message.replace('\n', " | "));
    assert!(
        message.starts_with(LEAK_REPORT),
        "{what}: expected loom's leak report ({LEAK_REPORT:?}), got: {message:?}"
    );
    if let Some(file) = allocated_in {
        let site = format!("Allocated: {file}:");
        assert!(
            message.contains(&site),
            "{what}: the report must name an allocation in {file}, got: {message:?}"
        );
    }
}

/// A tracker forgotten on purpose fails the model with loom's leak report: pins the text the other
/// tests and the notes rely on, and shows that loom's leak check runs at all.
#[test]
fn a_forgotten_tracker_fails_the_model_with_loom_leak_report() {
    let message = expect_failure(|| mem::forget(Tracked::new()));
    assert_leak("forgotten tracker", &message, Some("verify/loom_leaks.rs"));
}

/// A WF cache forgotten whole leaks its root node: the report names the node's allocation in
/// `src/cache/wf/mod.rs`, so nodes are tracked. Dropping the same cache passes.
#[test]
fn a_forgotten_cache_leaks_its_root_node() {
    let message = expect_failure(|| {
        mem::forget(WaitFree::<Minimal>::new(config(), CasFailure::Adopt));
    });
    assert_leak("forgotten cache", &message, Some("src/cache/wf/mod.rs"));
    // The control: the same cache, with a record in a child node (a published subtree and a
    // segment), dropped.
    model(|| {
        let cache = WaitFree::<Minimal>::new(config(), CasFailure::Adopt);
        insert_one(&cache, 0, child_record(0.0));
        assert_eq!(cache.config().accuracy(), 1.0);
        drop(cache);
    });
}

/// A record list forgotten after one push leaks its first segment: the report names the
/// segment's allocation in `src/cache/wf/list.rs` (`install`), so segments are tracked. Dropping
/// the same list passes.
#[test]
fn a_forgotten_list_leaks_its_segment() {
    let message = expect_failure(|| {
        let list = RecordList::<Minimal>::new();
        list.push(sealed(0.0)).unwrap();
        mem::forget(list);
    });
    assert_leak("forgotten list", &message, Some("src/cache/wf/list.rs"));
    model(|| {
        let list = RecordList::<Minimal>::new();
        list.push(sealed(0.0)).unwrap();
        drop(list);
    });
}
