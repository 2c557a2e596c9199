//! The checker on hand-built histories of a register and a set, whose verdicts are known.

use super::*;
use RegisterOp::{Read, Write};
use RegisterRet::{Done, Value};

fn reg(h: &History<RegisterOp, RegisterRet>) -> Result<Linearization, NotLinearizable> {
    check(h, &Register::default())
}

fn set(h: &History<SetOp, bool>) -> Result<Linearization, NotLinearizable> {
    check(h, &IntSet::default())
}

#[test]
fn sequential_register_history_is_linearizable_in_its_own_order() {
    let h = HistoryBuilder::new()
        .call(0, Write(1), Done)
        .call(1, Read, Value(1))
        .call(0, Write(2), Done)
        .call(1, Read, Value(2))
        .build();
    assert_eq!(reg(&h), Ok(vec![0, 1, 2, 3]));
}

/// Write(1) returns, then a read begins and still sees the initial 0.
fn stale_read() -> History<RegisterOp, RegisterRet> {
    HistoryBuilder::new()
        .call(0, Write(1), Done)
        .call(1, Read, Value(0))
        .build()
}

#[test]
fn stale_read_is_not_linearizable() {
    let err = reg(&stale_read()).unwrap_err();
    assert_eq!(
        err.longest,
        vec![0],
        "the write linearizes, the read cannot follow"
    );
    assert_eq!(err.stuck, vec![1]);
}

#[test]
fn overlapping_read_may_see_either_value() {
    for seen in [0, 1] {
        let h = HistoryBuilder::new()
            .invoke(0, Write(1))
            .invoke(1, Read)
            .ret(1, Value(seen))
            .ret(0, Done)
            .build();
        let order = reg(&h).unwrap();
        // Seeing 0 puts the read first; seeing 1 puts the write first.
        assert_eq!(order, if seen == 0 { vec![1, 0] } else { vec![0, 1] });
    }
}

#[test]
fn reads_that_disagree_on_the_order_of_two_writes_are_caught() {
    // Two concurrent writes; one reader sees 1 then 2, another 2 then 1, all reads inside the
    // writes' window: no single order of the writes explains both.
    let h = HistoryBuilder::new()
        .invoke(0, Write(1))
        .invoke(1, Write(2))
        .call(2, Read, Value(1))
        .call(3, Read, Value(2))
        .call(2, Read, Value(2))
        .call(3, Read, Value(1))
        .ret(0, Done)
        .ret(1, Done)
        .build();
    assert!(reg(&h).is_err());
    // Drop the last read: now writes 1, 2 in that order explain everything.
    let h2 = h.filter(|i| i != 5);
    assert!(reg(&h2).is_ok());
}

#[test]
fn a_value_nobody_wrote_is_not_linearizable_but_a_pending_write_explains_it() {
    let h = HistoryBuilder::new()
        .invoke(0, Write(7))
        .call(1, Read, Value(7))
        .build();
    assert!(h.operations()[0].ret.is_none(), "the write stays pending");
    assert!(reg(&h).is_ok(), "a pending write may have taken effect");
    let h = HistoryBuilder::new().call(1, Read, Value(7)).build();
    assert!(reg(&h).is_err());
}

#[test]
fn set_histories_are_classified() {
    use SetOp::{Contains, Insert, Remove};
    // Linearizable: a contains overlapping an insert may go either way.
    let ok = HistoryBuilder::new()
        .invoke(0, Insert(3))
        .call(1, Contains(3), true)
        .ret(0, true)
        .call(1, Remove(3), true)
        .call(0, Contains(3), false)
        .build();
    assert!(set(&ok).is_ok());
    // Not: the element was inserted (returned), then a later contains misses it.
    let lost = HistoryBuilder::new()
        .call(0, Insert(3), true)
        .call(1, Contains(3), false)
        .build();
    assert!(set(&lost).is_err());
    // Not: two inserts of the same element both report it new with no remove between.
    let twice = HistoryBuilder::new()
        .invoke(0, Insert(4))
        .invoke(1, Insert(4))
        .ret(0, true)
        .ret(1, true)
        .build();
    assert!(set(&twice).is_err());
    // But with a concurrent remove that saw it, both can be new.
    let with_remove = HistoryBuilder::new()
        .invoke(0, Insert(4))
        .invoke(1, Insert(4))
        .call(2, Remove(4), true)
        .ret(0, true)
        .ret(1, true)
        .build();
    assert!(set(&with_remove).is_ok());
}

/// A register history with noise around a stale read: 3 threads, 13 operations.
fn noisy_stale_read() -> History<RegisterOp, RegisterRet> {
    HistoryBuilder::new()
        .call(2, Read, Value(0))
        .invoke(1, Write(5))
        .call(2, Read, Value(0))
        .ret(1, Done)
        .call(2, Read, Value(5))
        .call(0, Write(1), Done) // #4
        .call(1, Read, Value(1))
        .call(2, Write(6), Done)
        .call(0, Read, Value(6))
        .call(1, Read, Value(1)) // stale: 6 was written after 1, both returned
        .call(2, Read, Value(6))
        .call(0, Write(8), Done)
        .call(2, Read, Value(8))
        .build()
}

#[test]
fn shrinking_finds_a_minimal_stale_read() {
    let h = noisy_stale_read();
    assert_eq!(h.len(), 12);
    let err = reg(&h).unwrap_err();
    assert!(err.longest.len() < h.len());
    let (small, failure) = shrink_nonlinearizable(&h, &Register::default());
    let text = small.render(Some(&failure));
    // Minimal: write 6 (returned), then a read of 1 — with the write of 1 that it observes.
    assert_eq!(small.len(), 3, "{text}");
    assert!(reg(&small).is_err());
    for k in 0..small.len() {
        assert!(
            reg(&small.filter(|i| i != k)).is_ok() || {
                // Removing a write also removes its observers in the shrinker; check that too.
                let w = small.operations()[k].op;
                let sub = small.filter(|i| {
                    i != k
                        && !small.operations()[i]
                            .ret
                            .is_some_and(|r| Register::observes(&small.operations()[i].op, &r, &w))
                });
                reg(&sub).is_ok()
            },
            "operation {k} is not needed:\n{text}"
        );
    }
    let ops: Vec<RegisterOp> = small.operations().iter().map(|o| o.op).collect();
    assert_eq!(ops, vec![Write(1), Write(6), Read], "{text}");
    assert!(
        text.contains("thread 0") && text.contains("-> Value(1)"),
        "{text}"
    );
    assert!(text.contains("longest partial linearization"), "{text}");
}

#[test]
fn render_puts_threads_in_columns() {
    let h = HistoryBuilder::new()
        .invoke(0, Write(1))
        .call(1, Read, Value(0))
        .ret(0, Done)
        .build();
    let text = h.render(None);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2 + 4, "{text}");
    assert!(lines[0].starts_with("thread 0") && lines[0].contains("thread 1"));
    // The read's invocation is in the second column.
    let col = lines[0].find("thread 1").unwrap();
    assert_eq!(lines[3].find("#1 Read"), Some(col), "{text}");
}

#[test]
fn recorder_merges_logs_in_ticket_order() {
    let rec = Recorder::new();
    let mut a: ThreadLog<RegisterOp, RegisterRet> = rec.log(0);
    let mut b = rec.log(1);
    a.invoke(Write(1));
    b.invoke(Read);
    b.ret(Value(0));
    a.ret(Done);
    b.invoke(Read);
    b.ret(Value(1));
    let h = rec.into_history([a, b]);
    let ops = h.operations();
    assert_eq!(ops.len(), 3);
    assert_eq!((ops[0].invoked, ops[0].returned), (0, Some(3)));
    assert_eq!((ops[1].invoked, ops[1].returned), (1, Some(2)));
    assert!(ops[0].precedes(&ops[2]) && !ops[0].precedes(&ops[1]));
    assert_eq!(reg(&h), Ok(vec![1, 0, 2]));
}

#[test]
#[should_panic(expected = "another recorder")]
fn logs_of_another_recorder_are_refused() {
    let (r1, r2) = (Recorder::new(), Recorder::new());
    let log: ThreadLog<RegisterOp, RegisterRet> = r2.log(0);
    r1.into_history([log]);
}

/// A counter whose `Inc` returns the new value; it keeps every default of [`Specification`].
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Counter(u32);

#[derive(Clone, Copy, Debug, PartialEq)]
struct Inc;

impl Specification for Counter {
    type Op = Inc;
    type Ret = u32;
    fn apply(&mut self, _: &Inc) -> u32 {
        self.0 += 1;
        self.0
    }
}

#[test]
fn by_default_no_operation_observes_another() {
    assert!(!Counter::observes(&Inc, &1, &Inc));
    // So shrinking removes one increment at a time and leaves the others' results alone: three
    // sequential increments that all return 1 shrink to two (either pair still fails), not to
    // three, which a spec whose every operation observed every other would keep.
    let h = HistoryBuilder::new()
        .call(0, Inc, 1)
        .call(1, Inc, 1)
        .call(0, Inc, 1)
        .build();
    let (small, _) = shrink_nonlinearizable(&h, &Counter::default());
    assert_eq!(small.len(), 2, "{}", small.render(None));
}

#[test]
fn precedes_is_strict_real_time_order() {
    let op = |invoked: u64, returned: Option<u64>| Operation {
        thread: 0,
        op: Read,
        ret: returned.map(|_| Value(0)),
        invoked,
        returned,
    };
    assert!(op(0, Some(1)).precedes(&op(2, Some(3))));
    // Returned at the very ticket the other was invoked: not before it.
    assert!(!op(0, Some(2)).precedes(&op(2, Some(3))));
    assert!(
        !op(0, None).precedes(&op(2, Some(3))),
        "a pending operation never returned"
    );
}

#[test]
fn history_and_log_accessors() {
    let empty: History<RegisterOp, RegisterRet> = HistoryBuilder::new().build();
    assert!(empty.is_empty());
    assert_eq!((empty.len(), empty.threads()), (0, 0));
    let h = noisy_stale_read();
    assert!(!h.is_empty());
    // `filter` keeps exactly the operations asked for, tickets unchanged.
    let odd = h.filter(|i| i % 2 == 1);
    assert_eq!(odd.len(), h.len() / 2);
    for (k, o) in odd.operations().iter().enumerate() {
        assert_eq!(*o, h.operations()[2 * k + 1]);
    }

    let rec = Recorder::new();
    let mut log: ThreadLog<RegisterOp, RegisterRet> = rec.log(3);
    assert_eq!(log.thread(), 3);
    assert!(log.is_empty());
    assert_eq!(log.len(), 0);
    log.reserve(40);
    assert!(log.ops.capacity() >= 40);
    log.invoke(Write(2));
    assert_eq!(log.pending_op_mut(), Some(&mut Write(2)));
    log.ret(Done);
    log.invoke(Read);
    log.ret(Value(2));
    assert!(!log.is_empty() && log.len() == 2);
    assert_eq!(rec.into_history([log]).operations()[1].thread, 3);
}

#[test]
fn a_failure_reports_the_first_longest_prefix_its_steps_and_what_is_stuck() {
    // The stale read: the search linearizes the write (one step), fails the read (a second),
    // backtracks and gives up: 2 steps.
    assert_eq!(reg(&stale_read()).unwrap_err().steps, 2);

    // Two concurrent writes, then a read of a value neither wrote. The search reaches two
    // prefixes of length 2, (W1, W2) and then (W2, W1); it reports the first. The read (#2) is
    // what cannot come next.
    let h = HistoryBuilder::new()
        .invoke(0, Write(1))
        .invoke(1, Write(2))
        .ret(0, Done)
        .ret(1, Done)
        .call(2, Read, Value(3))
        .build();
    let err = reg(&h).unwrap_err();
    assert_eq!(err.longest, vec![0, 1]);
    assert_eq!(err.stuck, vec![2]);
    // Every configuration: W1, W2 (W1 first); R fails; W2, W1 (W2 first); R fails: 6 steps.
    assert_eq!(err.steps, 6);
    assert!(err
        .to_string()
        .contains("2 operations linearized at most, stuck before [2] (6 steps)"));
}

/// `noise` followed by a stale read: Write(1) on thread 0, Write(6) on thread 1, then a read of 1
/// on thread 2, each returning before the next begins.
fn stale_read_after(
    noise: HistoryBuilder<RegisterOp, RegisterRet>,
) -> History<RegisterOp, RegisterRet> {
    noise
        .call(0, Write(1), Done)
        .call(1, Write(6), Done)
        .call(2, Read, Value(1))
        .build()
}

/// Counts how often the shrinker asks whether a history still fails.
fn shrink_calls(h: &History<RegisterOp, RegisterRet>) -> (History<RegisterOp, RegisterRet>, usize) {
    let mut calls = 0;
    let small = shrink::<Register>(h, |c| {
        calls += 1;
        reg(c).is_err()
    });
    (small, calls)
}

#[test]
fn a_thread_of_pure_noise_goes_in_one_step() {
    // Thread 3 reads the initial 0 three hundred times first; then the stale read of
    // `noisy_stale_read` happens on threads 0-2. Removing thread suffixes takes thread 3's whole
    // log at its first try, so the shrinker asks 8 questions, not hundreds.
    let mut b = HistoryBuilder::new();
    for _ in 0..300 {
        b = b.call(3, Read, Value(0));
    }
    let h = stale_read_after(b);
    let (small, calls) = shrink_calls(&h);
    assert_eq!(small.len(), 3);
    assert!(calls <= 12, "{calls} calls to shrink a thread of noise");
}

#[test]
fn noise_before_every_needed_operation_goes_in_halving_chunks() {
    // Each of the three needed operations comes after 100 reads of 0 on its own thread, so no
    // thread suffix can go without a needed operation (3 x 101 tries fail): the chunks must remove
    // the noise. Halving chunks take it in 21 questions; one operation at a time would take two
    // passes of about 150 each.
    let mut b = HistoryBuilder::new();
    for t in 0..3 {
        for _ in 0..100 {
            b = b.call(t, Read, Value(0));
        }
    }
    let h = stale_read_after(b);
    let (small, calls) = shrink_calls(&h);
    let ops: Vec<RegisterOp> = small.operations().iter().map(|o| o.op).collect();
    assert_eq!(ops, vec![Write(1), Write(6), Read]);
    assert!(
        calls <= 303 + 60,
        "{calls} calls to shrink interleaved noise"
    );
}

#[test]
fn render_truncates_only_what_is_wider_than_100_and_describes_the_failure() {
    // A register value wide enough to print past 100 characters.
    let wide = i64::MAX;
    let ops = (0..8).fold(HistoryBuilder::new(), |b, k| {
        b.call(0, Write(wide - k), Done)
    });
    let h = ops
        .invoke(1, Write(3))
        .call(2, Read, Value(0))
        .call(2, Read, Value(wide))
        .build();
    let text = h.render(None);
    // The longest text ("#10 -> Value(9223372036854775807)", 33 characters) sets the column
    // width and is printed whole.
    assert!(text.contains("#10 -> Value(9223372036854775807)"), "{text}");
    // A stale read of the first write, seen by a thread after the last write returned: the
    // failure lists the longest prefix and the stuck operations, each described.
    let failing = HistoryBuilder::new()
        .call(0, Write(1), Done)
        .invoke(1, Write(5))
        .call(0, Read, Value(0))
        .build();
    let failure = reg(&failing).unwrap_err();
    let text = failing.render(Some(&failure));
    assert!(text.contains("#0 (thread 0) Write(1) -> Done"), "{text}");
    assert!(text.contains("#1 (thread 1) Write(5) (pending)"), "{text}");
    assert!(text.contains("#2 (thread 0) Read -> Value(0)"), "{text}");

    // 120 characters of operation: cut to the widest column, 100, ending in "...".
    #[derive(Clone, Debug)]
    struct Long(#[allow(dead_code)] String);
    let one = |text: String| {
        History::from_operations(vec![Operation {
            thread: 0,
            op: Long(text),
            ret: Some(()),
            invoked: 0,
            returned: Some(1),
        }])
    };
    let text = one("x".repeat(110)).render(None);
    let row = text.lines().nth(2).unwrap();
    assert_eq!(row.chars().count(), 100, "{text}");
    assert!(
        row.starts_with("#0 Long(\"xxx") && row.ends_with("xxx..."),
        "{text}"
    );
    // The column is exactly as wide as its longest cell when that is under 100: nothing cut.
    let text = one("y".repeat(40)).render(None);
    assert!(
        text.contains(&format!("#0 Long(\"{}\")", "y".repeat(40))),
        "{text}"
    );
}

#[test]
fn a_set_read_observes_only_the_insert_of_what_it_found() {
    use SetOp::{Contains, Insert, Remove};
    assert!(IntSet::observes(&Contains(3), &true, &Insert(3)));
    assert!(IntSet::observes(&Remove(3), &true, &Insert(3)));
    assert!(!IntSet::observes(&Contains(3), &false, &Insert(3)));
    assert!(!IntSet::observes(&Contains(4), &true, &Insert(3)));
    assert!(!IntSet::observes(&Insert(3), &true, &Insert(3)));
    // Shrinking a lost insert amid noise keeps the insert and the read that missed it; the reads
    // that found 5 go with the insert of 5 they observed.
    let h = HistoryBuilder::new()
        .call(1, Insert(5), true)
        .call(2, Contains(5), true)
        .call(0, Insert(3), true)
        .call(2, Remove(5), true)
        .call(1, Contains(3), false)
        .build();
    let (small, _) = shrink_nonlinearizable(&h, &IntSet::default());
    let ops: Vec<SetOp> = small.operations().iter().map(|o| o.op).collect();
    assert_eq!(ops, vec![Insert(3), Contains(3)]);
}

#[test]
fn cache_operations_print_as_the_failure_reports_show_them() {
    use crate::cache::Inserted;
    use crate::ic::{InsertError, Record, RecordId, WorkerId};
    use glam::Vec3;
    let id = RecordId::new(WorkerId::new(1), 0, 2);
    assert_eq!(InsertId::Known(id).to_string(), "r1.0.2");
    assert_eq!(InsertId::Unknown(WorkerId::new(4)).to_string(), "r4.?");
    let r = Record::new(Vec3::new(1.0, 2.5, -3.0), Vec3::Z, Vec3::ONE, 0.5);
    assert_eq!(
        format!("{:?}", CacheOp::insert(id, r)),
        "insert r1.0.2 (1.00,2.50,-3.00) R=0.50"
    );
    assert_eq!(
        format!("{:?}", CacheOp::insert_unknown(WorkerId::new(4), r)),
        "insert r4.? (1.00,2.50,-3.00) R=0.50"
    );
    let lookup = CacheOp::Lookup {
        point: Vec3::new(0.0, 1.0, 2.0),
        normal: Vec3::Z,
    };
    assert_eq!(format!("{lookup:?}"), "lookup (0.00,1.00,2.00)");
    let other = RecordId::new(WorkerId::new(0), 0, 7);
    let found = |ids: Vec<RecordId>, torn| format!("{:?}", CacheRet::Found { ids, torn });
    assert_eq!(found(vec![], 0), "{}");
    assert_eq!(found(vec![id], 0), "{r1.0.2}");
    assert_eq!(found(vec![other, id], 0), "{r0.0.7, r1.0.2}");
    assert_eq!(found(vec![id], 2), "{r1.0.2} +2 torn");
    assert_eq!(
        format!("{:?}", CacheRet::Inserted(Inserted::Stored(id))),
        "Stored"
    );
    assert_eq!(
        format!("{:?}", CacheRet::Inserted(Inserted::Discarded(id))),
        "Discarded"
    );
    assert_eq!(
        format!("{:?}", CacheRet::Inserted(Inserted::NotCached(id))),
        "NotCached"
    );
    let e = InsertError::NonPositiveRadius(0.0);
    assert_eq!(
        format!("{:?}", CacheRet::Rejected(e)),
        format!("Rejected({e})")
    );
}

#[test]
fn set_violations_name_the_operations_and_the_record() {
    use crate::ic::{RecordId, WorkerId};
    let id = RecordId::new(WorkerId::new(2), 1, 3);
    let cases = [
        (SetViolation::Phantom { lookup: 4, id }, "lookup #4 returned r2.1.3, which no insert stored"),
        (
            SetViolation::FromTheFuture { lookup: 4, insert: 6, id },
            "lookup #4 returned r2.1.3, whose insert #6 began after the lookup ended",
        ),
        (
            SetViolation::Lost { lookup: 4, insert: 1, id },
            "lookup #4 missed r2.1.3, valid there, whose insert #1 returned before the lookup began",
        ),
        (
            SetViolation::Forgotten { earlier: 2, later: 5, id },
            "lookup #5 missed r2.1.3, valid there, which lookup #2 of the same thread returned",
        ),
        (SetViolation::Duplicate { lookup: 4, id }, "lookup #4 returned r2.1.3 more than once"),
        (SetViolation::Torn { lookup: 4, count: 2 }, "lookup #4 met 2 torn records"),
    ];
    for (v, text) in cases {
        assert_eq!(v.to_string(), text);
    }
}

#[test]
fn bitset_sets_and_clears_single_bits_across_words() {
    let mut b = Bitset::new(130);
    assert_eq!(b.0.len(), 3);
    b.set(3);
    b.set(70);
    b.set(129);
    b.clear(3);
    let mut only = Bitset::new(130);
    only.set(70);
    only.set(129);
    assert_eq!(b, only);
    b.clear(129);
    b.clear(70);
    assert_eq!(b, Bitset::new(130));
}

mod cache_spec {
    use super::super::*;
    use crate::cache::{CacheConfig, Inserted};
    use crate::ic::{Record, RecordId, WorkerId};
    use glam::Vec3;
    use std::hash::{DefaultHasher, Hash, Hasher};

    fn world() -> CacheConfig {
        CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), 0.5).unwrap()
    }

    fn id(worker: u32, seq: u64) -> RecordId {
        RecordId::new(WorkerId::new(worker), 0, seq)
    }

    fn record(x: f32) -> Record {
        Record::new(Vec3::new(x, 3.0, 3.0), Vec3::Z, Vec3::ONE, 0.5)
    }

    fn hash(s: &CacheSpec) -> u64 {
        let mut h = DefaultHasher::new();
        s.hash(&mut h);
        h.finish()
    }

    /// `base` with `op` applied as a pending operation.
    fn pending(base: &CacheSpec, op: CacheOp) -> CacheSpec {
        let mut s = base.clone();
        s.apply_pending(&op);
        s
    }

    #[test]
    fn states_compare_by_ids_spent_ids_and_unnamed_records() {
        let empty = CacheSpec::new(world());
        let mut one = empty.clone();
        one.apply(&CacheOp::insert(id(1, 0), record(3.0)));
        assert_eq!(one.records().len(), 1);
        assert_eq!(one.records()[0].id(), id(1, 0));
        // The same id reached through another record (within a history an id names one record),
        // in a state that shares nothing with `one`.
        let mut again = empty.clone();
        again.apply(&CacheOp::insert(id(1, 0), record(4.0)));
        assert_eq!(one, again);
        assert_eq!(hash(&one), hash(&again));
        let mut other = empty.clone();
        other.apply(&CacheOp::insert(id(1, 1), record(3.0)));
        assert_ne!(one, other);
        assert_ne!(hash(&one), hash(&other));
        assert_ne!(one, empty);

        // An id spent by a discarded insert.
        let mut spent = empty.clone();
        let discarded = CacheRet::Inserted(Inserted::Discarded(id(1, 0)));
        assert!(spent.step(&CacheOp::insert(id(1, 0), record(3.0)), &discarded));
        assert_eq!(spent.records().len(), 0);
        assert_ne!(spent, empty);
        assert_ne!(hash(&spent), hash(&empty));
        // The spent id is not fresh any more: storing a record under it cannot be linearized.
        let stored = CacheRet::Inserted(Inserted::Stored(id(1, 0)));
        assert!(!spent
            .clone()
            .step(&CacheOp::insert(id(1, 0), record(3.0)), &stored));
        assert!(!one
            .clone()
            .step(&CacheOp::insert(id(1, 0), record(3.0)), &stored));
        assert!(empty
            .clone()
            .step(&CacheOp::insert(id(1, 0), record(3.0)), &stored));

        // Unnamed records (pending inserts whose id is unknown) compare by worker and bits.
        let w1 = |x| CacheOp::insert_unknown(WorkerId::new(1), record(x));
        let w2 = |x| CacheOp::insert_unknown(WorkerId::new(2), record(x));
        let a = pending(&empty, w1(3.0));
        assert_eq!(a, pending(&empty, w1(3.0)));
        assert_eq!(hash(&a), hash(&pending(&empty, w1(3.0))));
        assert_ne!(a, empty);
        assert_ne!(a, pending(&empty, w2(3.0)));
        assert_ne!(a, pending(&empty, w1(3.5)));
        assert_ne!(hash(&a), hash(&pending(&empty, w1(3.5))));
        assert_ne!(a, pending(&a, w1(3.5)));
        assert_ne!(hash(&a), hash(&pending(&a, w1(3.5))));
        // The same records unnamed in two states, differing in what is stored.
        assert_ne!(pending(&one, w1(3.0)), a);
        // Every field's bits count: a record differing only in a gradient is another record.
        let g = record(3.0).with_gradients([Vec3::X; 3], [Vec3::ZERO; 3]);
        let b = pending(&empty, CacheOp::insert_unknown(WorkerId::new(1), g));
        assert_ne!(a, b);
        assert_ne!(hash(&a), hash(&b));
    }

    #[test]
    fn a_pending_insert_stores_only_a_valid_record_under_a_fresh_id() {
        let empty = CacheSpec::new(world());
        let bad = Record::new(Vec3::splat(3.0), Vec3::Z, Vec3::ONE, -1.0);
        assert_eq!(pending(&empty, CacheOp::insert(id(1, 0), bad)), empty);
        assert_eq!(
            pending(&empty, CacheOp::insert_unknown(WorkerId::new(1), bad)),
            empty
        );
        let one = pending(&empty, CacheOp::insert(id(1, 0), record(3.0)));
        assert_eq!(one.records().len(), 1);
        // A second pending insert under a stored id changes nothing.
        assert_eq!(pending(&one, CacheOp::insert(id(1, 0), record(5.0))), one);
        assert_eq!(
            pending(&one, CacheOp::insert(id(1, 0), record(5.0))).records()[0]
                .position
                .x,
            3.0
        );
        // A pending lookup changes nothing.
        let look = CacheOp::Lookup {
            point: Vec3::splat(3.0),
            normal: Vec3::Z,
        };
        assert_eq!(pending(&one, look), one);
    }

    #[test]
    fn a_refusal_must_be_the_one_the_specification_gives() {
        let empty = CacheSpec::new(world());
        let bad = Record::new(Vec3::splat(3.0), Vec3::Z, Vec3::ONE, -1.0);
        let op = CacheOp::insert_unknown(WorkerId::new(1), bad);
        let right = CacheRet::Rejected(crate::ic::InsertError::NonPositiveRadius(-1.0));
        let wrong = CacheRet::Rejected(crate::ic::InsertError::NonFinite { field: "radius" });
        assert!(empty.clone().step(&op, &right));
        assert!(!empty.clone().step(&op, &wrong));
        // A valid record refused is not this specification.
        let good = CacheOp::insert_unknown(WorkerId::new(1), record(3.0));
        assert!(!empty.clone().step(&good, &right));
        // Nor is a valid record given no place, or a lookup answered as an insert.
        let none = CacheRet::Inserted(Inserted::NotCached(id(1, 0)));
        assert!(!empty
            .clone()
            .step(&CacheOp::insert(id(1, 0), record(3.0)), &none));
        let look = CacheOp::Lookup {
            point: Vec3::splat(3.0),
            normal: Vec3::Z,
        };
        assert!(!empty.clone().step(
            &look,
            &CacheRet::Rejected(crate::ic::InsertError::NonPositiveRadius(1.0))
        ));
    }

    /// A lookup at `p` with normal +Z that returned `ids`, stepped on a copy of `s`.
    fn look(s: &CacheSpec, p: Vec3, ids: &[RecordId]) -> Option<CacheSpec> {
        let mut s = s.clone();
        let op = CacheOp::Lookup {
            point: p,
            normal: Vec3::Z,
        };
        let ret = CacheRet::Found {
            ids: ids.to_vec(),
            torn: 0,
        };
        s.step(&op, &ret).then_some(s)
    }

    #[test]
    fn a_lookup_names_the_unnamed_records_valid_at_its_query() {
        let p = Vec3::new(3.0, 3.0, 3.0);
        let far = Vec3::new(8.0, 8.0, 8.0);
        let mut s = CacheSpec::new(world());
        s.apply(&CacheOp::insert(id(1, 0), record(3.0)));
        // Worker 2's pending insert at p, worker 3's far away; neither id is known.
        let s = pending(&s, CacheOp::insert_unknown(WorkerId::new(2), record(3.1)));
        let far_record = Record::new(far, Vec3::Z, Vec3::ONE, 0.5);
        let s = pending(&s, CacheOp::insert_unknown(WorkerId::new(3), far_record));

        // Named and unnamed, sorted, one id of worker 2 for its record: accepted, and the record
        // is stored under it.
        let named = look(&s, p, &[id(1, 0), id(2, 5)]).expect("a valid naming");
        assert_eq!(named.records().len(), 2);
        assert_eq!(named.records()[1].id(), id(2, 5));
        // Once named, it must be returned like any stored record.
        assert!(look(&named, p, &[id(1, 0)]).is_none());
        assert!(look(&named, p, &[id(1, 0), id(2, 5)]).is_some());
        // The far record is still unnamed, and a lookup there names it.
        assert!(look(&named, far, &[]).is_none());
        let both = look(&named, far, &[id(3, 0)]).expect("the far record named");
        assert_eq!(both.records().len(), 3);

        // A lookup at p may leave the far record unnamed (it is not valid there).
        assert!(look(&s, p, &[id(1, 0), id(2, 5)]).is_some());
        // Not sorted, or a duplicate: refused.
        assert!(look(&s, p, &[id(2, 5), id(1, 0)]).is_none());
        assert!(look(&s, p, &[id(1, 0), id(1, 0), id(2, 5)]).is_none());
        assert!(look(&s, p, &[id(1, 0), id(2, 5), id(2, 5)]).is_none());
        // The named record missing, an unnamed record missing, or an id too many: refused.
        assert!(look(&s, p, &[id(2, 5)]).is_none());
        assert!(look(&s, p, &[id(1, 0)]).is_none());
        assert!(look(&s, p, &[id(1, 0), id(2, 5), id(2, 6)]).is_none());
        // Another worker's id for worker 2's record: refused.
        assert!(look(&s, p, &[id(1, 0), id(3, 5)]).is_none());
        // An id a discarded insert spent is not fresh: refused; the next one is.
        let mut spent = s.clone();
        let discarded = CacheRet::Inserted(Inserted::Discarded(id(2, 5)));
        assert!(spent.step(&CacheOp::insert(id(2, 5), record(6.0)), &discarded));
        assert!(look(&spent, p, &[id(1, 0), id(2, 5)]).is_none());
        assert!(look(&spent, p, &[id(1, 0), id(2, 6)]).is_some());
        // A query that cannot be answered finds nothing and names nothing.
        let nan = Vec3::new(f32::NAN, 3.0, 3.0);
        assert!(look(&s, nan, &[]).is_some());
        // A torn record is never the specification's.
        let op = CacheOp::Lookup {
            point: p,
            normal: Vec3::Z,
        };
        let torn = CacheRet::Found {
            ids: vec![id(1, 0), id(2, 5)],
            torn: 1,
        };
        assert!(!s.clone().step(&op, &torn));
    }

    /// Under loom the lists hold a few slots, and a full one refuses an insert: a no-op the
    /// specification accepts (a capacity of the model, not an error of the record).
    #[cfg(feature = "loom")]
    #[test]
    fn a_full_model_list_is_a_no_op() {
        let empty = CacheSpec::new(world());
        let full = CacheRet::Rejected(crate::ic::InsertError::ListFull);
        let mut s = empty.clone();
        assert!(s.step(
            &CacheOp::insert_unknown(WorkerId::new(1), record(3.0)),
            &full
        ));
        assert_eq!(s, empty);
    }

    #[test]
    fn a_lookup_observes_the_inserts_whose_records_it_returned() {
        let look = CacheOp::Lookup {
            point: Vec3::splat(3.0),
            normal: Vec3::Z,
        };
        let found = CacheRet::Found {
            ids: vec![id(1, 0), id(2, 4)],
            torn: 0,
        };
        let known = |w, s| CacheOp::insert(id(w, s), record(3.0));
        let unknown = |w| CacheOp::insert_unknown(WorkerId::new(w), record(3.0));
        assert!(lookup_observes(&look, &found, &known(2, 4)));
        assert!(!lookup_observes(&look, &found, &known(2, 5)));
        assert!(lookup_observes(&look, &found, &unknown(1)));
        assert!(!lookup_observes(&look, &found, &unknown(3)));
        // Only lookups observe, and only inserts are observed.
        let stored = CacheRet::Inserted(Inserted::Stored(id(1, 0)));
        assert!(!lookup_observes(&known(1, 0), &stored, &known(1, 0)));
        assert!(!lookup_observes(&look, &found, &look));
        for other in [known(2, 4), known(2, 5), unknown(1), unknown(3)] {
            assert_eq!(
                CacheSpec::observes(&look, &found, &other),
                lookup_observes(&look, &found, &other)
            );
        }
    }
}
