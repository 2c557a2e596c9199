//! Shuttle schedule exploration of WF, LCK and LW (`cargo test --features shuttle`): 4–8 threads
//! and tens of operations per thread — sizes loom cannot reach — mixing inserts into shared lists,
//! races to create children at two depths, list segment growth and lookups.
//!
//! Shuttle runs every thread on one OS thread and models every atomic access as `SeqCst`: it
//! explores interleavings, not weak-memory reorderings (those are loom's job, `verify/loom_*.rs`).
//! Each test runs its fixed regression seeds and one fresh seed (printed); see
//! `shuttle_common` for replaying a failure.
#![cfg(feature = "shuttle")]

mod shuttle_common;
mod tree_shape;

use glam::Vec3;
use shuttle_common::{explore_all, Sched};
use std::collections::HashSet;
use tree_shape::{check_lookup, counted_lookup, TreeShape, Work};
use wfic::cache::wf::Minimal;
use wfic::cache::{
    CacheConfig, CacheHandle, CasFailure, Inserted, IrradianceCache, LocalWrite, Locked,
    MutexFlavour, RwLockFlavour, WaitFree,
};
use wfic::ic::{Record, Selection, WorkerId};
use wfic::sync::{thread, Arc};

/// The world: a 4-unit box, accuracy 1.
fn config() -> CacheConfig {
    CacheConfig::new(Vec3::ZERO, Vec3::splat(4.0), 1.0).unwrap()
}

/// The deepest placement of the workload's records (radius 0.35 at accuracy 1 in a 4-unit root).
const MAX_RECORD_DEPTH: u32 = 2;

/// Record `seq` of worker `worker`: a pure function of both, so any record read back can be
/// checked. Positions cluster in two octants so that workers race to create the same children;
/// radii place records in the root (one in four), at depth 1 or at depth 2.
fn record_for(worker: u32, seq: u64) -> Record {
    let h = (u64::from(worker) * 0x9e37_79b9 + seq * 0x85eb_ca6b) ^ 0x27d4_eb2f;
    let spot = if h % 2 == 0 {
        Vec3::splat(1.0)
    } else {
        Vec3::new(3.0, 1.0, 1.0)
    };
    let jitter = Vec3::new((h >> 8) as f32 % 7.0, (h >> 16) as f32 % 5.0, 0.0) * 0.03;
    let radius = match (h >> 24) % 4 {
        0 => 10.0,
        1 => 0.8,
        _ => 0.35,
    };
    let e = Vec3::new(1.0 + worker as f32, 1.0 + (seq % 7) as f32, 2.0);
    Record::new(spot + jitter, Vec3::Z, e, radius)
}

fn genuine(r: &Record) -> bool {
    let id = r.id();
    let expected = record_for(id.worker().index(), id.seq());
    r.is_intact() && r.position == expected.position && r.irradiance == expected.irradiance
}

/// One worker of [`workload`]: `ops` operations, one insert in `insert_every`, the rest lookups
/// at positions the other workers insert at; every record a lookup returns is genuine, and every
/// insert stays within the step bound. Returns the inserts' outcomes and each lookup's point and
/// work.
fn worker<C: IrradianceCache>(
    cache: &C,
    t: u32,
    threads: u32,
    ops: u64,
    insert_every: u64,
) -> (Vec<Inserted>, Vec<(Vec3, Work)>) {
    let scheme = cache.scheme().name();
    let mut h = cache.handle(WorkerId::new(t));
    let mut outcomes = Vec::new();
    let mut lookups = Vec::new();
    let mut found = Vec::new();
    for i in 0..ops {
        if i % insert_every == 0 {
            let seq = outcomes.len() as u64;
            outcomes.push(h.insert(record_for(t, seq)).expect("valid record"));
        } else {
            let other = (t + 1 + (i as u32 % threads.max(2))) % threads;
            let q = record_for(other, i / insert_every);
            found.clear();
            let did = counted_lookup(&mut h, q.position, q.normal, &mut found);
            lookups.push((q.position, did));
            assert!(
                found.iter().all(genuine),
                "{scheme}: phantom or torn record"
            );
        }
    }
    let steps = h.stats().max_insert_steps;
    assert!(
        steps <= 2 * MAX_RECORD_DEPTH,
        "{scheme}: an insert took {steps} steps, bound {}",
        2 * MAX_RECORD_DEPTH
    );
    (outcomes, lookups)
}

/// One schedule: `threads` workers, each doing `ops` operations, one insert in `insert_every`, the
/// rest lookups at positions other workers insert at. Checks racing reads, then the final state,
/// then every lookup's work against the tree the stored records make (`tree_shape`).
fn workload<C: IrradianceCache + 'static>(cache: C, threads: u32, ops: u64, insert_every: u64) {
    let scheme = cache.scheme().name();
    let config = *cache.config();
    let cache = Arc::new(cache);
    let workers: Vec<_> = (0..threads)
        .map(|t| {
            let cache = cache.clone();
            thread::spawn(move || worker(&*cache, t, threads, ops, insert_every))
        })
        .collect();
    let mut stored = HashSet::new();
    let mut discarded = 0;
    let mut lookups = Vec::new();
    for (t, w) in workers.into_iter().enumerate() {
        let (outcomes, looked) = w.join().unwrap();
        lookups.push((t as u32, looked));
        for o in outcomes {
            match o {
                Inserted::Stored(id) => assert!(stored.insert(id), "{scheme}: id reused"),
                Inserted::Discarded(_) => discarded += 1,
                Inserted::NotCached(_) => unreachable!("{scheme} is a cache"),
            }
        }
    }
    let mut cache = Arc::try_unwrap(cache).unwrap_or_else(|_| panic!("workers joined"));
    let report = cache.end_frame();
    assert_eq!(report.workers.discarded, discarded);
    if scheme != "wf-discard" {
        assert_eq!(discarded, 0, "{scheme} lost a sample");
    }
    let snapshot = cache.snapshot();
    assert!(
        snapshot.iter().all(genuine),
        "{scheme}: torn record in the final cache"
    );
    let ids: HashSet<_> = snapshot.iter().map(Record::id).collect();
    assert_eq!(ids.len(), snapshot.len(), "{scheme}: duplicated record");
    assert_eq!(ids, stored, "{scheme}: stored set");

    // The tree the stored records make, worked out from them alone; the cache has exactly it.
    let shape = TreeShape::of(&config, &snapshot);
    assert_eq!(
        cache.stats().nodes,
        shape.nodes(),
        "{scheme}: a node off every stored record's path, or one missing"
    );
    assert!(
        shape.depth() <= MAX_RECORD_DEPTH as usize,
        "{scheme}: records placed deeper than the step bound assumes"
    );
    // Every racing lookup stayed within the final tree's part its point reaches. LW's workers
    // read the global octree (empty: the cache started empty, and the workers' records are merged
    // only at the frame's end) and their own local one.
    let no_earlier_frame = TreeShape::of(&config, &[]);
    for (t, looked) in &lookups {
        let own = (scheme == "lw").then(|| {
            let mine = snapshot.iter().filter(|r| r.id().worker().index() == *t);
            TreeShape::of(&config, mine)
        });
        for &(p, did) in looked {
            let allowed = match &own {
                Some(own) => no_earlier_frame.reach(p) + own.reach(p),
                None => shape.reach(p),
            };
            check_lookup(scheme, p, did, allowed, false);
        }
    }

    // Quiescent lookups, after the frame: every stored record found exactly once, and at every
    // point the workers asked at or inserted at, exactly the final tree's reach is walked.
    let mut h = cache.handle(WorkerId::new(threads));
    let mut found = Vec::new();
    let mut points = Vec::new();
    for id in &stored {
        let r = record_for(id.worker().index(), id.seq());
        found.clear();
        let did = counted_lookup(&mut h, r.position, r.normal, &mut found);
        check_lookup(scheme, r.position, did, shape.reach(r.position), true);
        assert_eq!(
            found.iter().filter(|f| f.id() == *id).count(),
            1,
            "{scheme}: {id} not found once"
        );
        points.push(r.position);
    }
    let asked: HashSet<[u32; 3]> = lookups
        .iter()
        .flat_map(|(_, looked)| looked.iter().map(|(p, _)| p.to_array().map(f32::to_bits)))
        .collect();
    for p in asked
        .into_iter()
        .map(|bits| Vec3::from_array(bits.map(f32::from_bits)))
    {
        found.clear();
        let did = counted_lookup(&mut h, p, Vec3::Z, &mut found);
        check_lookup(scheme, p, did, shape.reach(p), true);
        points.push(p);
    }
    // Vacuity: at some point the bound is below the whole tree, so a lookup that walked the whole
    // tree would have failed it.
    assert!(
        points
            .iter()
            .any(|p| shape.reach(*p).nodes < shape.nodes() as u64),
        "{scheme}: every point reaches the whole tree; the bound cannot tell a pruned lookup"
    );
}

/// Schedules in which some removal took a record another worker stored (the removals race the
/// other workers' inserts and one another, not only the remover's own records).
static TOOK_FOREIGN: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// One schedule mixing removal with inserts and lookups: `threads` workers, `ops` operations each;
/// one in `insert_every` an insert, one in `remove_every` a removal at the point of one of the
/// worker's own earlier records (the records cluster, so a removal takes other workers' records
/// too, and removals overlap), the rest lookups. Checks: racing reads genuine; after a worker's
/// removal, its own lookup at that point meets none of its own earlier records that the removal
/// selects (they happen-before it, so they are gone); after the frame, every stored record is
/// alive or was counted by exactly one removal, and the tree has exactly the survivors' nodes
/// (reclamation).
fn removal_workload<C: IrradianceCache + 'static>(
    cache: C,
    threads: u32,
    ops: u64,
    insert_every: u64,
    remove_every: u64,
) {
    let scheme = cache.scheme().name();
    let config = *cache.config();
    let a = config.accuracy();
    let cache = Arc::new(cache);
    let workers: Vec<_> = (0..threads)
        .map(|t| {
            let cache = cache.clone();
            thread::spawn(move || {
                let mut h = cache.handle(WorkerId::new(t));
                let mut stored = Vec::new();
                let mut found = Vec::new();
                let mut took = 0;
                let mut own_selected = 0;
                for i in 0..ops {
                    if i % insert_every == 0 {
                        let seq = i / insert_every;
                        if let Inserted::Stored(id) =
                            h.insert(record_for(t, seq)).expect("valid record")
                        {
                            stored.push(id);
                        }
                    } else if i % remove_every == 0 && !stored.is_empty() {
                        let target = stored[(i as usize / 7) % stored.len()];
                        let p = record_for(t, target.seq()).position;
                        let selection = Selection::touching(p, p).unwrap();
                        took += h.remove(&selection);
                        // Own earlier records the selection takes: gone for this worker now.
                        let mine: HashSet<_> = stored
                            .iter()
                            .filter(|id| {
                                let r = record_for(t, id.seq());
                                selection.selects(&r.sealed(**id), a, 0)
                            })
                            .copied()
                            .collect();
                        own_selected += mine.len();
                        found.clear();
                        h.valid_records(p, Vec3::Z, &mut found);
                        assert!(
                            found.iter().all(genuine),
                            "{scheme}: phantom or torn record"
                        );
                        assert!(
                            found.iter().all(|f| !mine.contains(&f.id())),
                            "{scheme}: a record found after a removal that happens-after its insert"
                        );
                        stored.retain(|id| !mine.contains(id));
                    } else {
                        let other = (t + 1 + (i as u32 % threads.max(2))) % threads;
                        let q = record_for(other, i / insert_every);
                        found.clear();
                        h.valid_records(q.position, q.normal, &mut found);
                        assert!(
                            found.iter().all(genuine),
                            "{scheme}: phantom or torn record"
                        );
                    }
                }
                assert_eq!(h.stats().removed, took as u64, "{scheme}: handle count");
                (took, own_selected)
            })
        })
        .collect();
    let mut counted = 0;
    let mut foreign = false;
    for w in workers {
        let (took, own) = w.join().unwrap();
        counted += took;
        // Took more than its own selected records: some were another worker's. (LW's handles
        // take only their own local records.)
        foreign |= took > own;
    }
    if foreign {
        TOOK_FOREIGN.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    }
    let mut cache = Arc::try_unwrap(cache).unwrap_or_else(|_| panic!("workers joined"));
    let report = cache.end_frame();
    assert_eq!(
        report.workers.removed, counted as u64,
        "{scheme}: removals reported"
    );
    let stored = report.workers.stored;
    let snapshot = cache.snapshot();
    assert!(
        snapshot.iter().all(genuine),
        "{scheme}: torn record in the final cache"
    );
    let ids: HashSet<_> = snapshot.iter().map(Record::id).collect();
    assert_eq!(ids.len(), snapshot.len(), "{scheme}: duplicated record");
    assert_eq!(
        snapshot.len() as u64 + report.workers.removed,
        stored,
        "{scheme}: a record lost, or removed twice"
    );
    let shape = TreeShape::of(&config, &snapshot);
    assert_eq!(
        cache.stats().nodes,
        shape.nodes(),
        "{scheme}: after reclamation, a node off every surviving record's path, or one missing"
    );
}

#[test]
fn shuttle_wf_removal_random() {
    explore_all(
        "shuttle_wf_removal_random",
        "4 threads x 30 ops, 1 insert in 2, 1 removal in 5",
        Sched::Random,
        &SEEDS,
        1000,
        || {
            removal_workload(
                WaitFree::<Minimal>::new(config(), CasFailure::Adopt),
                4,
                30,
                2,
                5,
            )
        },
    );
    assert!(
        TOOK_FOREIGN.load(std::sync::atomic::Ordering::Relaxed) > 0,
        "no schedule had a removal take another worker's record"
    );
}

#[test]
fn shuttle_wf_removal_pct() {
    explore_all(
        "shuttle_wf_removal_pct",
        "8 threads x 16 ops, 1 insert in 2, 1 removal in 3",
        Sched::Pct(3),
        &SEEDS,
        600,
        || {
            removal_workload(
                WaitFree::<Minimal>::new(config(), CasFailure::Adopt),
                8,
                16,
                2,
                3,
            )
        },
    );
}

#[test]
fn shuttle_wf_discard_removal_random() {
    explore_all(
        "shuttle_wf_discard_removal_random",
        "4 threads x 30 ops, 1 insert in 2, 1 removal in 5",
        Sched::Random,
        &SEEDS,
        500,
        || {
            removal_workload(
                WaitFree::<Minimal>::new(config(), CasFailure::Discard),
                4,
                30,
                2,
                5,
            )
        },
    );
}

#[test]
fn shuttle_lck_removal_random() {
    explore_all(
        "shuttle_lck_removal_random",
        "4 threads x 30 ops, 1 insert in 2, 1 removal in 5",
        Sched::Random,
        &SEEDS,
        300,
        || removal_workload(Locked::<RwLockFlavour>::new(config()), 4, 30, 2, 5),
    );
}

#[test]
fn shuttle_lw_removal_random() {
    explore_all(
        "shuttle_lw_removal_random",
        "4 threads x 30 ops, 1 insert in 2, 1 removal in 5",
        Sched::Random,
        &SEEDS,
        300,
        || removal_workload(LocalWrite::new(config()), 4, 30, 2, 5),
    );
}

/// Fixed regression seeds, run every time beside a fresh one.
const SEEDS: [u64; 2] = [0x5eed_0001, 0x1c_2009];

#[test]
fn shuttle_wf_adopt_random() {
    explore_all(
        "shuttle_wf_adopt_random",
        "4 threads x 40 ops, 1 insert in 3",
        Sched::Random,
        &SEEDS,
        1500,
        || {
            workload(
                WaitFree::<Minimal>::new(config(), CasFailure::Adopt),
                4,
                40,
                3,
            )
        },
    );
}

#[test]
fn shuttle_wf_adopt_pct() {
    explore_all(
        "shuttle_wf_adopt_pct",
        "8 threads x 24 ops, 1 insert in 2",
        Sched::Pct(3),
        &SEEDS,
        1000,
        || {
            workload(
                WaitFree::<Minimal>::new(config(), CasFailure::Adopt),
                8,
                24,
                2,
            )
        },
    );
}

#[test]
fn shuttle_wf_discard_random() {
    explore_all(
        "shuttle_wf_discard_random",
        "4 threads x 40 ops, 1 insert in 2",
        Sched::Random,
        &SEEDS,
        1000,
        || {
            workload(
                WaitFree::<Minimal>::new(config(), CasFailure::Discard),
                4,
                40,
                2,
            )
        },
    );
}

#[test]
fn shuttle_lck_mutex_random() {
    explore_all(
        "shuttle_lck_mutex_random",
        "4 threads x 30 ops, 1 insert in 3",
        Sched::Random,
        &SEEDS,
        500,
        || workload(Locked::<MutexFlavour>::new(config()), 4, 30, 3),
    );
}

#[test]
fn shuttle_lck_rwlock_pct() {
    explore_all(
        "shuttle_lck_rwlock_pct",
        "6 threads x 20 ops, 1 insert in 3",
        Sched::Pct(3),
        &SEEDS,
        500,
        || workload(Locked::<RwLockFlavour>::new(config()), 6, 20, 3),
    );
}

#[test]
fn shuttle_lw_random() {
    explore_all(
        "shuttle_lw_random",
        "4 threads x 40 ops, 1 insert in 3",
        Sched::Random,
        &SEEDS,
        500,
        || workload(LocalWrite::new(config()), 4, 40, 3),
    );
}

/// Vacuity: the `Discard` exploration does reach schedules where a race to create a child is lost.
#[test]
fn shuttle_wf_discard_reaches_a_lost_race() {
    use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
    static DISCARDED: AtomicU64 = AtomicU64::new(0);
    let _gate = shuttle_common::shared();
    shuttle_common::explore(
        "shuttle_wf_discard_reaches_a_lost_race",
        "4 threads x 8 inserts",
        Sched::Pct(2),
        7,
        300,
        || {
            let cache = Arc::new(WaitFree::<Minimal>::new(config(), CasFailure::Discard));
            let ws: Vec<_> = (0..4u32)
                .map(|t| {
                    let c = cache.clone();
                    thread::spawn(move || {
                        let mut h = c.handle(WorkerId::new(t));
                        (0..8).for_each(|i| {
                            h.insert(record_for(t, i)).unwrap();
                        });
                        h.stats().discarded
                    })
                })
                .collect();
            let d: u64 = ws.into_iter().map(|w| w.join().unwrap()).sum();
            DISCARDED.fetch_add(d, Relaxed);
        },
    );
    assert!(
        DISCARDED.load(Relaxed) > 0,
        "no schedule discarded a sample"
    );
}

/// A deliberately false property: "two WF `Discard` inserts racing for one child never discard".
/// Shuttle refutes it; the failure is saved, and its replay reproduces the same failure.
fn no_discard_ever() {
    let cache = Arc::new(WaitFree::<Minimal>::new(config(), CasFailure::Discard));
    let c = cache.clone();
    let r = |x: f32| Record::new(Vec3::new(1.0 + x, 1.0, 1.0), Vec3::Z, Vec3::ONE, 0.8);
    let t = thread::spawn(move || c.handle(WorkerId::new(1)).insert(r(0.0)).unwrap());
    let mine = cache.handle(WorkerId::new(0)).insert(r(0.1)).unwrap();
    let theirs = t.join().unwrap();
    assert!(
        matches!((mine, theirs), (Inserted::Stored(_), Inserted::Stored(_))),
        "a sample was discarded"
    );
}

#[test]
fn a_failure_is_saved_and_its_replay_reproduces_it() {
    let _alone = shuttle_common::exclusive();
    let (test, seed) = ("demo_no_discard_ever", 11);
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let outcome = std::panic::catch_unwind(|| {
        shuttle_common::explore(
            test,
            "2 threads, 1 insert each",
            Sched::Random,
            seed,
            2000,
            no_discard_ever,
        )
    });
    std::panic::set_hook(hook);
    assert!(
        outcome.is_err(),
        "shuttle did not refute the false property"
    );
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(format!("target/shuttle-failures/{test}-random-{seed}.txt"));
    let saved = shuttle_common::load_failure(&path);
    assert_eq!((saved.test.as_str(), saved.seed), (test, seed));
    assert!(
        saved.message.contains("a sample was discarded"),
        "{}",
        saved.message
    );
    let replayed = shuttle_common::replay_failure(&saved, no_discard_ever);
    let replayed = replayed.expect("the replay must fail again");
    assert!(replayed.contains("a sample was discarded"), "{replayed}");
}

/// Every failure file committed under `verify/shuttle-regressions/` is re-run from its seed (its
/// encoded schedule is tied to the code it was recorded on; the seed is not). A file whose test is
/// a real property must now pass (its bug is fixed); the demonstration file of the false property
/// above must still fail the same way.
#[test]
fn committed_regressions_replay() {
    let _alone = shuttle_common::exclusive();
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("verify/shuttle-regressions");
    let mut replayed = 0;
    for entry in std::fs::read_dir(&dir).expect("verify/shuttle-regressions exists") {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "txt") {
            continue;
        }
        let saved = shuttle_common::load_failure(&path);
        match saved.test.as_str() {
            "demo_no_discard_ever" => {
                let m = shuttle_common::rerun_seed(&saved, no_discard_ever);
                assert!(
                    m.is_some_and(|m| m.contains("a sample was discarded")),
                    "{}",
                    path.display()
                );
            }
            other => panic!(
                "{}: no replay registered for test `{other}`",
                path.display()
            ),
        }
        replayed += 1;
    }
    assert!(replayed > 0, "no regression file found");
}
