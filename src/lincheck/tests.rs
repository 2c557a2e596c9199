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

#[test]
fn stale_read_is_not_linearizable() {
    // Write(1) returns, then a read begins and still sees the initial 0.
    let h = HistoryBuilder::new()
        .call(0, Write(1), Done)
        .call(1, Read, Value(0))
        .build();
    let err = reg(&h).unwrap_err();
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
