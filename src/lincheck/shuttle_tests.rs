//! The recorder under shuttle: workers are shuttle threads, histories are checked per schedule.

use super::*;
use crate::cache::{CacheConfig, CasFailure, IrradianceCache, Locked, MutexFlavour, WaitFree};
use crate::ic::{Record, WorkerId};
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

#[test]
fn shuttle_wf_is_set_consistent_but_not_linearizable() {
    let violations = std::sync::Arc::new(AtomicU64::new(0));
    let counted = std::sync::Arc::clone(&violations);
    let example = std::sync::Arc::new(std::sync::Mutex::new(None::<String>));
    let keep = std::sync::Arc::clone(&example);
    Runner::new(PctScheduler::new_from_seed(11, 3, 500), Config::new()).run(move || {
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
            keep.lock()
                .unwrap()
                .get_or_insert_with(|| small.render(Some(&f)));
        }
    });
    let found = violations.load(Ordering::Relaxed);
    let example = example.lock().unwrap().take();
    println!("WF under shuttle PCT: {found} of 500 schedules not linearizable");
    let example = example.expect("shuttle finds the WF lookup that sees B but not A");
    println!("{example}");
    assert!(example.contains("not linearizable"));
}
