//! Real threads hammering every scheme: after join every inserted record is found exactly once and
//! whole, and a lookup racing with inserts only ever returns records that were really inserted.
//! Thread counts above 2 are oversubscribed on the 2-core CI machine: that is fine here (these are
//! correctness tests, and oversubscription only adds preemptions).
#![cfg(not(checker))]

mod common;

use common::{is_genuine, record_for, w, with_scheme, Rng, SchemeCheck, AXES, SCHEMES};
use glam::Vec3;
use std::collections::HashSet;
use std::thread;
use wfic::cache::{CacheHandle, Inserted, IrradianceCache};
use wfic::ic::{Record, RecordId};

/// Totals per scheme and run, as the foundation issue asks: at least 10^5 inserts, 10^6 lookups
/// (both multiplied by `WFIC_STRESS_SCALE`, default 1: see [`scale`]).
const INSERTS: u64 = 100_000;
const LOOKUPS: u64 = 1_000_000;
const FRAMES: u64 = 2;
/// Records the racing reads must meet in a run at full size (scaled like the run).
const CHECKED_READS: u64 = 1_000;

/// `WFIC_STRESS_SCALE`: a factor in `(0, 1]` on the inserts, the lookups and the records the racing
/// reads must meet; 1 (the sizes above) when unset. For slow runs only: valgrind's memcheck runs
/// the suite at 0.1 (`verify/valgrind-stress.sh`).
fn scale() -> f64 {
    match std::env::var("WFIC_STRESS_SCALE") {
        Err(_) => 1.0,
        Ok(v) => {
            let s: f64 = v.parse().expect("WFIC_STRESS_SCALE: a number in (0, 1]");
            assert!(s > 0.0 && s <= 1.0, "WFIC_STRESS_SCALE={s}: not in (0, 1]");
            s
        }
    }
}

/// `n` scaled by [`scale`], at least 1.
fn scaled(n: u64) -> u64 {
    ((n as f64 * scale()).round() as u64).max(1)
}

struct Stress {
    threads: u32,
}

struct WorkerOutcome {
    inserted: Vec<Inserted>,
    checked_reads: u64,
}

impl SchemeCheck for Stress {
    fn check<C: IrradianceCache>(&mut self, mut cache: C) {
        let scheme = cache.scheme().name();
        let threads = self.threads;
        let per_frame = (scaled(INSERTS) / u64::from(threads) / FRAMES).max(1);
        let lookups_per_insert = LOOKUPS / INSERTS;
        let mut inserted: Vec<Inserted> = Vec::new();
        let mut checked_reads = 0;
        for frame in 0..FRAMES {
            let open = cache.frame();
            let outcomes: Vec<WorkerOutcome> = thread::scope(|s| {
                let open = &open;
                let workers: Vec<_> = (0..threads)
                    .map(|t| {
                        s.spawn(move || {
                            // One worker number per thread and frame, so that the handle's
                            // record numbering (from 0 per handle) matches the generator's.
                            let worker = frame as u32 * threads + t;
                            let mut handle = open.handle_for(w(worker));
                            let mut rng = Rng::new(u64::from(t) * 7919 + frame);
                            let mut inserted = Vec::with_capacity(per_frame as usize);
                            let mut found = Vec::new();
                            let mut checked_reads = 0;
                            for i in 0..per_frame {
                                let outcome = handle
                                    .insert(record_for(worker, i))
                                    .unwrap_or_else(|e| panic!("{scheme}: insert refused: {e}"));
                                inserted.push(outcome);
                                for k in 0..lookups_per_insert {
                                    let (p, n) =
                                        query(&mut rng, frame as u32 * threads, threads, i);
                                    if k == 0 {
                                        // A racing read: every record it returns must be whole
                                        // and one that some worker really inserted.
                                        found.clear();
                                        handle.valid_records(p, n, &mut found);
                                        for r in &found {
                                            assert!(
                                                is_genuine(r),
                                                "{scheme}: phantom or torn {r:?}"
                                            );
                                        }
                                        checked_reads += found.len() as u64;
                                    } else if let Some(hit) = handle.lookup(p, n) {
                                        assert!(hit.irradiance.is_finite() && hit.records > 0);
                                    }
                                }
                            }
                            WorkerOutcome {
                                inserted,
                                checked_reads,
                            }
                        })
                    })
                    .collect();
                workers.into_iter().map(|h| h.join().unwrap()).collect()
            });
            for o in outcomes {
                inserted.extend(o.inserted);
                checked_reads += o.checked_reads;
            }
            let report = open.close();
            assert_eq!(report.workers.inserts, per_frame * u64::from(threads));
        }
        // The racing reads did meet records (otherwise they checked nothing).
        assert!(
            checked_reads > scaled(CHECKED_READS),
            "{scheme}: racing reads saw only {checked_reads} records"
        );

        let stats = cache.stats();
        let total = per_frame * u64::from(threads) * FRAMES;
        assert_eq!(stats.totals.inserts, total, "{scheme}");
        assert_eq!(
            stats.totals.lookups,
            total * (lookups_per_insert - 1),
            "{scheme}: lookups counted"
        );
        let stored: Vec<RecordId> = inserted
            .iter()
            .filter_map(|o| match o {
                Inserted::Stored(id) => Some(*id),
                Inserted::Discarded(_) | Inserted::NotCached(_) => None,
            })
            .collect();
        match scheme {
            "wf-discard" => assert_eq!(stored.len() as u64 + stats.totals.discarded, total),
            _ => {
                assert_eq!(stats.totals.discarded, 0, "{scheme} lost samples");
                assert_eq!(stored.len() as u64, total);
            }
        }

        // Nothing duplicated, nothing torn, nothing invented, nothing lost.
        let snapshot = cache.snapshot();
        assert_eq!(snapshot.len(), stored.len(), "{scheme}: snapshot size");
        let ids: HashSet<RecordId> = snapshot.iter().map(Record::id).collect();
        assert_eq!(ids.len(), snapshot.len(), "{scheme}: duplicated record");
        assert!(
            snapshot.iter().all(is_genuine),
            "{scheme}: torn record in snapshot"
        );
        assert_eq!(
            ids,
            stored.iter().copied().collect(),
            "{scheme}: stored set"
        );

        // Every stored record is found by a lookup at its own position, exactly once.
        let open = cache.frame();
        let mut handle = open.handle_for(w(threads * FRAMES as u32 + 1));
        let mut found = Vec::new();
        for id in &stored {
            let r = record_for(id.worker().index(), id.seq());
            found.clear();
            handle.valid_records(r.position, r.normal, &mut found);
            let hits = found.iter().filter(|f| f.id() == *id).count();
            assert_eq!(hits, 1, "{scheme}: record {id} found {hits} times");
            assert!(handle.lookup(r.position, r.normal).is_some());
        }
        drop(handle);
        open.close();
    }
}

/// A query near a record some worker inserts around this time (its own or another's), or anywhere.
fn query(rng: &mut Rng, first_worker: u32, threads: u32, seq: u64) -> (Vec3, Vec3) {
    match rng.below(4) {
        0 => (
            Vec3::new(
                rng.range(0.0, 10.0),
                rng.range(0.0, 10.0),
                rng.range(0.0, 10.0),
            ),
            AXES[rng.below(6) as usize],
        ),
        _ => {
            let worker = first_worker + rng.below(u64::from(threads)) as u32;
            let r = record_for(worker, seq.saturating_sub(rng.below(64)));
            let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.1;
            (r.position + jitter, r.normal)
        }
    }
}

fn stress(scheme: &str) {
    for threads in [2, 8] {
        with_scheme(scheme, common::world(0.3), &mut Stress { threads });
    }
}

#[test]
fn stress_tra() {
    stress("tra");
}

#[test]
fn stress_lck_mutex() {
    stress("lck");
}

#[test]
fn stress_lck_rwlock() {
    stress("lck-rw");
}

#[test]
fn stress_lw() {
    stress("lw");
}

#[test]
fn stress_wf_adopt() {
    stress("wf");
}

#[test]
fn stress_wf_discard() {
    stress("wf-discard");
}

#[test]
fn every_scheme_is_stressed() {
    assert_eq!(SCHEMES.len(), 6);
}
