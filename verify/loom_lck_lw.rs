//! Loom models of the baselines: LCK (both lock flavours) and LW's frame (workers reading the
//! global cache while writing their own, then the merge). Exhaustive, no preemption bound.
#![cfg(feature = "loom")]

mod loom_common;

use loom_common::*;
use wfic::cache::{
    CacheHandle, IrradianceCache, LocalWrite, LockFlavour, Locked, MutexFlavour, RwLockFlavour,
};
use wfic::ic::WorkerId;
use wfic::sync::{thread, Arc};

/// An insert and a lookup race on LCK: the lookup sees nothing or the whole record; afterwards
/// both inserts are there. Returns whether the racing lookup saw the record.
fn lck_insert_races_lookup<F: LockFlavour + 'static>() -> bool {
    let cache = Arc::new(Locked::<F>::new(config()));
    let c = cache.clone();
    let t = thread::spawn(move || insert_one(&*c, 1, child_record(0.0)));
    let found = valid_at(&*cache, 0, child_record(0.0).position);
    assert!(found.len() <= 1 && found.iter().all(|r| r.is_intact()));
    t.join().unwrap();
    insert_one(&*cache, 2, child_record(0.2));
    assert_eq!(valid_at(&*cache, 3, child_record(0.1).position).len(), 2);
    !found.is_empty()
}

#[test]
fn lck_mutex_insert_races_lookup() {
    let (saw, missed) = model_outcomes(lck_insert_races_lookup::<MutexFlavour>);
    assert!(saw > 0 && missed > 0, "both outcomes must be explored");
}

#[test]
fn lck_rwlock_insert_races_lookup() {
    let (saw, missed) = model_outcomes(lck_insert_races_lookup::<RwLockFlavour>);
    assert!(saw > 0 && missed > 0, "both outcomes must be explored");
}

/// Two LCK writers: both records stored, the lock-wait counter never negative or lost.
#[test]
fn lck_two_inserts() {
    model(|| {
        let cache = Arc::new(Locked::<MutexFlavour>::new(config()));
        let c = cache.clone();
        let t = thread::spawn(move || insert_one(&*c, 1, root_record(0.5)));
        insert_one(&*cache, 0, root_record(-0.5));
        t.join().unwrap();
        assert_eq!(valid_at(&*cache, 2, glam::Vec3::splat(2.0)).len(), 2);
    });
}

/// LW's frame: the global cache holds one record from an earlier frame; two workers read it
/// concurrently and each inserts into its own local cache (seeing its own record, never the
/// other's); after the barrier the merge publishes both to everyone.
#[test]
fn lw_frame_then_merge() {
    model(|| {
        let mut lw = LocalWrite::new(config());
        let mut h = lw.handle(WorkerId::new(9));
        // A root record on the plane z = 1 of the child records, valid wherever they are.
        let mut global = root_record(0.0);
        global.position.z = 1.0;
        h.insert(global).unwrap();
        drop(h);
        lw.end_frame();

        let lw = Arc::new(lw);
        let worker = |lw: Arc<LocalWrite>, id: u32, x: f32| {
            let mut h = lw.handle(WorkerId::new(id));
            let mut found = Vec::new();
            h.valid_records(child_record(0.0).position, glam::Vec3::Z, &mut found);
            assert_eq!(
                found.len(),
                1,
                "the global record is readable by every worker"
            );
            h.insert(child_record(x)).unwrap();
            found.clear();
            h.valid_records(child_record(0.1).position, glam::Vec3::Z, &mut found);
            // Its own record and the global one; the other worker's is local to it.
            assert_eq!(
                found.len(),
                2,
                "worker {id} sees the global record and its own"
            );
            // Dropping the handle hands its local records to the merge.
        };
        let l = lw.clone();
        let t = thread::spawn(move || worker(l, 1, 0.0));
        worker(lw.clone(), 0, 0.2);
        t.join().unwrap();
        let mut lw = Arc::try_unwrap(lw).unwrap_or_else(|_| panic!("workers joined"));
        let report = lw.end_frame();
        assert_eq!(report.workers.stored, 2);
        assert_eq!(
            lw.stats().records,
            3,
            "the merge publishes both local records"
        );
        assert_eq!(valid_at(&lw, 5, child_record(0.1).position).len(), 3);
    });
}
