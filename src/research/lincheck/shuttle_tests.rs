//! The recorder under shuttle: workers are shuttle threads, histories are checked per schedule.

use super::*;
use crate::cache::Inserted;
use crate::cache::{CacheConfig, CasFailure, IrradianceCache, Locked, MutexFlavour, WaitFree};
use crate::ic::{Record, RecordId, WorkerId};
use crate::sync::unchecked::{AtomicU64, Ordering};
use crate::sync::{thread, Arc};
use glam::Vec3;
use shuttle::scheduler::{PctScheduler, RandomScheduler};
use shuttle::{Config, Runner};

const P: Vec3 = Vec3::new(3.0, 3.0, 3.0);

fn world() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(10.0), 0.5).unwrap()
}

/// Record A belongs in the root's list, record B deep below it; both are valid at `P`.
fn a() -> Record {
    Record::new(P + Vec3::X * 0.01, Vec3::Z, Vec3::ONE, 8.0)
}

fn b() -> Record {
    Record::new(P - Vec3::X * 0.01, Vec3::Z, Vec3::ONE, 0.3)
}

/// One schedule: thread 0 looks up at `P` twice, thread 1 inserts A then B, thread 2 inserts B-like
/// records then looks up; returns the recorded history.
fn scenario<C: IrradianceCache + 'static>(cache: C) -> History<CacheOp, CacheRet> {
    let cache = Arc::new(cache);
    let recorder = Recorder::new();
    let mut workers = Vec::new();
    for t in 0..3usize {
        let (cache, log) = (Arc::clone(&cache), recorder.log(t));
        workers.push(thread::spawn(move || {
            let mut h = RecordingHandle::new(cache.handle(WorkerId::new(t as u32)), log);
            match t {
                0 => {
                    h.lookup(P, Vec3::Z);
                    h.lookup(P, Vec3::Z);
                }
                1 => {
                    h.insert(a()).unwrap();
                    h.insert(b()).unwrap();
                }
                _ => {
                    h.insert(b()).unwrap();
                    h.lookup(P + Vec3::Y * 0.01, Vec3::Z);
                }
            }
            h.into_parts().1
        }));
    }
    let logs: Vec<_> = workers.into_iter().map(|w| w.join().unwrap()).collect();
    recorder.into_history(logs)
}

#[test]
fn shuttle_lck_histories_are_linearizable() {
    let runs = std::sync::Arc::new(AtomicU64::new(0));
    let counted = std::sync::Arc::clone(&runs);
    Runner::new(RandomScheduler::new_from_seed(7, 300), Config::new()).run(move || {
        let h = scenario(Locked::<MutexFlavour>::new(world()));
        assert_eq!(h.len(), 6);
        if let Err(f) = check(&h, &CacheSpec::new(world())) {
            panic!("LCK under shuttle: {f}\n{}", h.render(Some(&f)));
        }
        assert_eq!(check_set_consistency(&h, &world()), Ok(()));
        counted.fetch_add(1, Ordering::Relaxed);
    });
    assert_eq!(runs.load(Ordering::Relaxed), 300);
}

/// The shape every shrunk WF violation is claimed to have: exactly a lookup, the root insert of A
/// and a deep insert of B (thread 1's or thread 2's), both `Stored`, A returned before B began, the
/// lookup overlapping both, returning exactly {B}. `Err` says why not.
fn root_missed_deep_seen(h: &History<CacheOp, CacheRet>) -> Result<(), String> {
    let ops = h.operations();
    if ops.len() != 3 {
        return Err(format!("{} operations", ops.len()));
    }
    let is = |o: &Operation<CacheOp, CacheRet>, r: Record| match (&o.op, &o.ret) {
        (
            CacheOp::Insert {
                record,
                id: InsertId::Known(id),
            },
            Some(CacheRet::Inserted(Inserted::Stored(_))),
        ) if record.position == r.position && record.radius == r.radius => Some(*id),
        _ => None,
    };
    let root = ops.iter().position(|o| is(o, a()).is_some());
    let deep = ops.iter().position(|o| is(o, b()).is_some());
    let lookup = ops
        .iter()
        .position(|o| matches!(o.op, CacheOp::Lookup { .. }));
    let (Some(root), Some(deep), Some(lookup)) = (root, deep, lookup) else {
        return Err("not a lookup, a stored root insert and a stored deep insert".into());
    };
    let (r, d, l) = (&ops[root], &ops[deep], &ops[lookup]);
    if !r.precedes(d) {
        return Err("the root insert did not return before the deep one began".into());
    }
    if r.precedes(l) || l.precedes(d) {
        return Err("the lookup does not overlap both inserts".into());
    }
    let seen = is(d, b()).expect("found above");
    match &l.ret {
        Some(CacheRet::Found { ids, torn: 0 }) if *ids == [seen] => Ok(()),
        other => Err(format!("the lookup returned {other:?}")),
    }
}

/// Monotonic-read obligations beyond the no-loss rule (see `check_set_consistency`): (lookup,
/// record) pairs where an earlier lookup of the same thread returned the record, valid at this
/// lookup's query, whose insert had not returned before this lookup began.
fn monotonic_obligations(h: &History<CacheOp, CacheRet>) -> u64 {
    let ops = h.operations();
    let mut n = 0;
    for (j, later) in ops.iter().enumerate() {
        let CacheOp::Lookup { point, normal } = later.op else {
            continue;
        };
        let mut earlier_ids: Vec<RecordId> = ops[..j]
            .iter()
            .filter(|o| o.thread == later.thread)
            .filter_map(|o| match &o.ret {
                Some(CacheRet::Found { ids, .. }) => Some(ids.iter().copied()),
                _ => None,
            })
            .flatten()
            .collect();
        earlier_ids.sort_unstable();
        earlier_ids.dedup();
        for id in earlier_ids {
            let insert = ops.iter().find(
                |o| matches!(o.op, CacheOp::Insert { id: InsertId::Known(x), .. } if x == id),
            );
            if let Some(Operation {
                op: CacheOp::Insert { record, .. },
                ..
            }) = insert
            {
                let insert = insert.expect("matched");
                if !insert.precedes(later)
                    && crate::ic::valid_weight(record, point, normal, world().accuracy()).is_some()
                {
                    n += 1;
                }
            }
        }
    }
    n
}

/// Every WF history of the scenario is set-consistent; shuttle finds non-linearizable ones (at
/// least one asserted; how many of the schedules is printed: an exact count would break on harmless
/// changes that move schedule points), and every one of them shrinks to the 3-operation shape.
#[test]
fn shuttle_wf_is_set_consistent_but_not_linearizable() {
    let violations = std::sync::Arc::new(AtomicU64::new(0));
    let counted = std::sync::Arc::clone(&violations);
    let example = std::sync::Arc::new(std::sync::Mutex::new(None::<String>));
    let keep = std::sync::Arc::clone(&example);
    let schedules = 500;
    Runner::new(PctScheduler::new_from_seed(11, 3, schedules), Config::new()).run(move || {
        let h = scenario(WaitFree::<crate::cache::wf::Minimal>::new(
            world(),
            CasFailure::Adopt,
        ));
        if let Err(v) = check_set_consistency(&h, &world()) {
            panic!("WF under shuttle: {v}\n{}", h.render(None));
        }
        if check(&h, &CacheSpec::new(world())).is_err() {
            counted.fetch_add(1, Ordering::Relaxed);
            let (small, f) = shrink_nonlinearizable(&h, &CacheSpec::new(world()));
            let text = small.render(Some(&f));
            if let Err(why) = root_missed_deep_seen(&small) {
                panic!("a WF violation shrunk to another shape ({why}):\n{text}");
            }
            keep.lock().unwrap().get_or_insert(text);
        }
    });
    let found = violations.load(Ordering::Relaxed);
    let example = example.lock().unwrap().take();
    println!(
        "WF under shuttle PCT (seed 11, depth 3): {found} of {schedules} schedules not linearizable, each \
         shrunk to (lookup, root insert, deep insert)"
    );
    assert!(
        found >= 1,
        "shuttle finds the WF lookup that sees B but not A"
    );
    println!("{}", example.expect("found >= 1"));
}

/// A handle whose inserts reach a schedule point after the cache's insert returned and before the
/// recorder logs the return, so that other threads may see the record while its insert is pending.
/// (Without it no schedule point separates an insert's publication from its return: under shuttle
/// a record is never seen while its insert is in flight, and the monotonic-read rule asks nothing
/// beyond the no-loss rule.)
struct YieldsBeforeReturn<H>(H);

impl<H: crate::cache::CacheHandle> crate::cache::CacheHandle for YieldsBeforeReturn<H> {
    fn worker(&self) -> WorkerId {
        self.0.worker()
    }

    fn frame(&self) -> u64 {
        self.0.frame()
    }

    fn lookup_visible(
        &mut self,
        point: Vec3,
        normal: Vec3,
        visible: crate::cache::Visibility,
    ) -> Option<crate::ic::Interpolated> {
        self.0.lookup_visible(point, normal, visible)
    }

    fn lookup(&mut self, point: Vec3, normal: Vec3) -> Option<crate::ic::Interpolated> {
        self.0.lookup(point, normal)
    }

    fn insert(&mut self, record: Record) -> Result<Inserted, crate::ic::InsertError> {
        let result = self.0.insert(record);
        thread::yield_now();
        thread::yield_now();
        result
    }

    fn remove(&mut self, selection: &crate::ic::Selection) -> usize {
        self.0.remove(selection)
    }

    fn valid_records(&mut self, point: Vec3, normal: Vec3, out: &mut Vec<Record>) {
        self.0.valid_records(point, normal, out)
    }

    fn stats(&self) -> &crate::cache::WorkerStats {
        self.0.stats()
    }
}

#[test]
fn shuttle_wf_reads_are_monotonic_per_thread() {
    let obligations = std::sync::Arc::new(AtomicU64::new(0));
    let obliged = std::sync::Arc::clone(&obligations);
    let schedules = 300;
    Runner::new(PctScheduler::new_from_seed(13, 3, schedules), Config::new()).run(move || {
        let cache = Arc::new(WaitFree::<crate::cache::wf::Minimal>::new(
            world(),
            CasFailure::Adopt,
        ));
        let recorder = Recorder::new();
        let reader = {
            let (cache, log) = (Arc::clone(&cache), recorder.log(0));
            thread::spawn(move || {
                let mut h = RecordingHandle::new(cache.handle(WorkerId::new(0)), log);
                for _ in 0..3 {
                    h.lookup(P, Vec3::Z);
                }
                h.into_parts().1
            })
        };
        let writer = {
            let (cache, log) = (Arc::clone(&cache), recorder.log(1));
            thread::spawn(move || {
                let handle = YieldsBeforeReturn(cache.handle(WorkerId::new(1)));
                let mut h = RecordingHandle::new(handle, log);
                h.insert(a()).unwrap();
                h.insert(b()).unwrap();
                h.into_parts().1
            })
        };
        let h = recorder.into_history([reader.join().unwrap(), writer.join().unwrap()]);
        if let Err(v) = check_set_consistency(&h, &world()) {
            panic!("WF under shuttle: {v}\n{}", h.render(None));
        }
        obliged.fetch_add(monotonic_obligations(&h), Ordering::Relaxed);
    });
    let obligations = obligations.load(Ordering::Relaxed);
    println!(
        "WF under shuttle PCT (seed 13, depth 3), {schedules} schedules: {obligations} monotonic-read \
         obligations beyond the no-loss rule, all met"
    );
    assert!(obligations >= 1, "the schedules must exercise the rule");
}

/// The second minimal WF violation: exactly two lookups and two overlapping inserts, the root
/// insert of A and the deep insert of B, both `Stored`; one lookup returned exactly {B}, the other
/// exactly {A}. They disagree on the order of A and B, and each three-operation part of it is
/// linearizable. `Err` says why not.
fn lookups_disagree(h: &History<CacheOp, CacheRet>) -> Result<(), String> {
    let ops = h.operations();
    if ops.len() != 4 {
        return Err(format!("{} operations", ops.len()));
    }
    let stored = |r: Record| {
        ops.iter().find_map(|o| match (&o.op, &o.ret) {
            (
                CacheOp::Insert {
                    record,
                    id: InsertId::Known(id),
                },
                Some(CacheRet::Inserted(Inserted::Stored(_))),
            ) if record.position == r.position && record.radius == r.radius => Some((o, *id)),
            _ => None,
        })
    };
    let (Some((root, a)), Some((deep, b))) = (stored(a()), stored(b())) else {
        return Err("not a stored root insert and a stored deep insert".into());
    };
    if root.precedes(deep) || deep.precedes(root) {
        return Err("the inserts do not overlap".into());
    }
    let mut seen: Vec<Vec<RecordId>> = ops
        .iter()
        .filter_map(|o| match (&o.op, &o.ret) {
            (CacheOp::Lookup { .. }, Some(CacheRet::Found { ids, torn: 0 })) => Some(ids.clone()),
            _ => None,
        })
        .collect();
    seen.sort();
    let mut expected = vec![vec![a], vec![b]];
    expected.sort();
    if seen == expected {
        Ok(())
    } else {
        Err(format!("the lookups returned {seen:?}"))
    }
}

/// The 3-operation shape is not the only minimal WF violation. Two lookups and two concurrent
/// inserts (threads 0 and 1 look up at P, thread 2 inserts A, thread 3 inserts B): besides the
/// 3-operation shape (when A returned before B began), some violations need all four operations,
/// one lookup seeing only B and the other only A. Every violation found shrinks to one of the two,
/// and both are found (fixed seed; the counts are printed).
#[test]
fn shuttle_wf_violations_shrink_to_one_of_two_shapes() {
    let counts = std::sync::Arc::new([AtomicU64::new(0), AtomicU64::new(0)]);
    let counted = std::sync::Arc::clone(&counts);
    let example = std::sync::Arc::new(std::sync::Mutex::new(None::<String>));
    let keep = std::sync::Arc::clone(&example);
    let schedules = 20_000;
    Runner::new(PctScheduler::new_from_seed(17, 8, schedules), Config::new()).run(move || {
        let cache = Arc::new(WaitFree::<crate::cache::wf::Minimal>::new(
            world(),
            CasFailure::Adopt,
        ));
        let recorder = Recorder::new();
        let workers: Vec<_> = (0..4usize)
            .map(|t| {
                let (cache, log) = (Arc::clone(&cache), recorder.log(t));
                thread::spawn(move || {
                    let mut h = RecordingHandle::new(cache.handle(WorkerId::new(t as u32)), log);
                    match t {
                        0 | 1 => drop(h.lookup(P, Vec3::Z)),
                        2 => drop(h.insert(a()).unwrap()),
                        _ => drop(h.insert(b()).unwrap()),
                    }
                    h.into_parts().1
                })
            })
            .collect();
        let logs: Vec<_> = workers.into_iter().map(|w| w.join().unwrap()).collect();
        let h = recorder.into_history(logs);
        if let Err(v) = check_set_consistency(&h, &world()) {
            panic!("WF under shuttle: {v}\n{}", h.render(None));
        }
        if check(&h, &CacheSpec::new(world())).is_err() {
            let (small, f) = shrink_nonlinearizable(&h, &CacheSpec::new(world()));
            let text = small.render(Some(&f));
            match (root_missed_deep_seen(&small), lookups_disagree(&small)) {
                (Ok(()), _) => counted[0].fetch_add(1, Ordering::Relaxed),
                (_, Ok(())) => {
                    keep.lock().unwrap().get_or_insert(text);
                    counted[1].fetch_add(1, Ordering::Relaxed)
                }
                (Err(e3), Err(e4)) => {
                    panic!("a WF violation of neither shape ({e3}; {e4}):\n{text}")
                }
            };
        }
    });
    let (three, four) = (
        counts[0].load(Ordering::Relaxed),
        counts[1].load(Ordering::Relaxed),
    );
    let example = example.lock().unwrap().take();
    println!(
        "WF, 2 lookups and 2 concurrent inserts, shuttle PCT (seed 17, depth 8), {schedules} schedules: \
         {three} violations shrunk to the 3-operation shape, {four} to the 4-operation one"
    );
    assert!(three >= 1, "the 3-operation shape is found");
    assert!(four >= 1, "the 4-operation shape is found");
    println!("{}", example.expect("four >= 1"));
}

/// Removal, one schedule: A is in the root's list before the threads start (inserted and
/// recorded by worker 2); thread 0 removes at `P` (its selection takes A and B); thread 1 inserts B
/// (deep) and then looks up at `P`.
fn removal_scenario() -> History<CacheOp, CacheRet> {
    let cache = Arc::new(WaitFree::<crate::cache::wf::Minimal>::new(
        world(),
        CasFailure::Adopt,
    ));
    let recorder = Recorder::new();
    let mut first = RecordingHandle::new(cache.handle(WorkerId::new(2)), recorder.log(2));
    first.insert(a()).unwrap();
    let first = first.into_parts().1;
    let remover = {
        let (cache, log) = (Arc::clone(&cache), recorder.log(0));
        thread::spawn(move || {
            let mut h = RecordingHandle::new(cache.handle(WorkerId::new(0)), log);
            h.remove(crate::ic::Selection::touching(P, P).unwrap(), 0);
            h.into_parts().1
        })
    };
    let inserter = {
        let (cache, log) = (Arc::clone(&cache), recorder.log(1));
        thread::spawn(move || {
            let mut h = RecordingHandle::new(cache.handle(WorkerId::new(1)), log);
            h.insert(b()).unwrap();
            h.lookup(P, Vec3::Z);
            h.into_parts().1
        })
    };
    let logs = [remover.join().unwrap(), inserter.join().unwrap(), first];
    recorder.into_history(logs)
}

/// WF's removal keeps its stated guarantee in every schedule (set consistency with the removal
/// rules), and shuttle finds schedules that are not linearizable. The removal and the lookup walk
/// the same two nodes, and neither is atomic: the removal counts both A and B (so it follows B's
/// insert, as the lookup does), yet the lookup sees exactly one of them. Either it saw A in the
/// root before the removal took it and missed B, which the removal took below before the lookup
/// got there; or it missed A, already taken, and saw B, not yet taken. Each violation shrinks to
/// exactly the four operations.
#[test]
fn shuttle_wf_removal_is_set_consistent_but_not_linearizable() {
    let violations = std::sync::Arc::new(AtomicU64::new(0));
    let counted = std::sync::Arc::clone(&violations);
    let example = std::sync::Arc::new(std::sync::Mutex::new(None::<String>));
    let keep = std::sync::Arc::clone(&example);
    let only_b = std::sync::Arc::new(AtomicU64::new(0));
    let saw_b = std::sync::Arc::clone(&only_b);
    let schedules = 1000;
    Runner::new(PctScheduler::new_from_seed(17, 3, schedules), Config::new()).run(move || {
        let h = removal_scenario();
        assert_eq!(h.len(), 4);
        if let Err(v) = check_set_consistency(&h, &world()) {
            panic!("WF removal under shuttle: {v}\n{}", h.render(None));
        }
        if check(&h, &CacheSpec::new(world())).is_err() {
            counted.fetch_add(1, Ordering::Relaxed);
            let (small, f) = shrink_nonlinearizable(&h, &CacheSpec::new(world()));
            let text = small.render(Some(&f));
            let ops = small.operations();
            let removed_two = ops
                .iter()
                .any(|o| matches!(o.ret, Some(CacheRet::Removed(2))));
            let saw_one = ops
                .iter()
                .any(|o| matches!(&o.ret, Some(CacheRet::Found { ids, .. }) if ids.len() == 1));
            if ops
                .iter()
                .any(|o| matches!(&o.ret, Some(CacheRet::Found { ids, .. }) if ids.len() == 1 && ids[0].worker() == WorkerId::new(1)))
            {
                saw_b.fetch_add(1, Ordering::Relaxed);
            }
            assert!(
                small.len() == 4 && removed_two && saw_one,
                "a WF removal violation of another shape:\n{text}"
            );
            keep.lock().unwrap().get_or_insert(text);
        }
    });
    let found = violations.load(Ordering::Relaxed);
    let only_b = only_b.load(Ordering::Relaxed);
    println!(
        "WF removal under shuttle PCT (seed 17, depth 3): {found} of {schedules} schedules not \
         linearizable; the lookup saw B alone in {only_b}, A alone in {}",
        found - only_b
    );
    assert!(
        found >= 1,
        "shuttle finds the removal that takes B after a lookup saw B without A"
    );
    println!("{}", example.lock().unwrap().take().expect("found >= 1"));
}
