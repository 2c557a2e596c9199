//! Loom models of the baselines: LCK (both lock flavours) and LW's frame (workers reading the
//! global cache while writing their own, then the merge). Exhaustive, no preemption bound.
#![cfg(feature = "loom")]

mod loom_common;

use loom_common::tree_shape::{check_lookup, counted_lookup, TreeShape};
use loom_common::*;
use wfic::cache::{
    CacheHandle, IrradianceCache, LocalWrite, LockFlavour, Locked, MutexFlavour, RwLockFlavour,
};
use wfic::ic::WorkerId;
use wfic::sync::{thread, Arc};

/// An insert and a lookup race on LCK: the lookup sees nothing or the whole record, and walks no
/// more of the tree than the final records make; afterwards both inserts are there and a lookup
/// walks exactly that tree's reach. Returns whether the racing lookup saw the record.
fn lck_insert_races_lookup<F: LockFlavour + 'static>() -> bool {
    let cache = Arc::new(Locked::<F>::new(config()));
    let c = cache.clone();
    let p = child_record(0.0).position;
    let t = thread::spawn(move || insert_one(&*c, 1, child_record(0.0)));
    let (found, racing) = lookup_at(&*cache, 0, p);
    assert!(found.len() <= 1 && found.iter().all(|r| r.is_intact()));
    t.join().unwrap();
    insert_one(&*cache, 2, child_record(0.2));
    let mut cache = Arc::try_unwrap(cache).unwrap_or_else(|_| panic!("threads joined"));
    let shape = settled_shape(&mut cache);
    check_lookup("lck", p, racing, shape.reach(p), false);
    let q = child_record(0.1).position;
    let (all, did) = lookup_at(&cache, 3, q);
    assert_eq!(all.len(), 2);
    check_lookup("lck", q, did, shape.reach(q), true);
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
/// other's); after the barrier the merge publishes both to everyone. A worker's lookup walks
/// exactly the global octree's reach (nobody writes it during the frame) plus, once it holds a
/// record, its own local octree's: nothing another worker does changes either.
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
        let global_shape = settled_shape(&mut lw);

        let lw = Arc::new(lw);
        let worker = move |lw: Arc<LocalWrite>, id: u32, x: f32| {
            let mut h = lw.handle(WorkerId::new(id));
            let mut found = Vec::new();
            let p = child_record(0.0).position;
            let did = counted_lookup(&mut h, p, glam::Vec3::Z, &mut found);
            assert_eq!(
                found.len(),
                1,
                "the global record is readable by every worker"
            );
            check_lookup("lw global", p, did, global_shape.reach(p), true);
            h.insert(child_record(x)).unwrap();
            found.clear();
            let q = child_record(0.1).position;
            let did = counted_lookup(&mut h, q, glam::Vec3::Z, &mut found);
            // Its own record and the global one; the other worker's is local to it.
            assert_eq!(
                found.len(),
                2,
                "worker {id} sees the global record and its own"
            );
            let local = TreeShape::of(lw.config(), &[child_record(x)]);
            check_lookup(
                "lw global and local",
                q,
                did,
                global_shape.reach(q) + local.reach(q),
                true,
            );
            // Dropping the handle hands its local records to the merge.
        };
        let l = lw.clone();
        let w = worker.clone();
        let t = thread::spawn(move || w(l, 1, 0.0));
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
        let shape = settled_shape(&mut lw);
        let q = child_record(0.1).position;
        let (all, did) = lookup_at(&lw, 5, q);
        assert_eq!(all.len(), 3);
        check_lookup("lw merged", q, did, shape.reach(q), true);
    });
}
